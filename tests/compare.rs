//! `soig compare` through the binary: identical runs, a rerun, a changed seed, a metric drop
//! within and beyond tolerance, a tampered artifact, errors; and the CI script against its
//! committed baseline.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::{
    CampaignToml, ELEMENTS_40649, arg, json, ort_available, repo, run_quiet, scratch, soig,
};

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `soig compare BASELINE RUN [extra...]`, which must not fail (exit 2): exit code and stdout.
fn compare(baseline: &Path, run: &Path, extra: &[&str]) -> (i32, String) {
    let mut args = vec!["compare", arg(baseline), arg(run)];
    args.extend(extra);
    let o = soig(&args);
    let code = o.status.code().expect("exit code");
    assert_ne!(code, 2, "{}", String::from_utf8_lossy(&o.stderr));
    (code, stdout(&o))
}

/// A tiny campaign: 256 px, 6 images, as tests/cli.rs's `small`; with `model`, the detect
/// stage on half of them.
fn campaign(dir: &Path, seed: u64, model: Option<&Path>) -> PathBuf {
    let mut c = CampaignToml::leo("small", seed, 6)
        .debris(ELEMENTS_40649)
        .tables("[sensor]\nwidth_px = 256\nheight_px = 256\nfov_radius_deg = 0.025\n[render]\ntrajectory_samples = 500\n[artifacts]\nnoise_free_fits = true\n");
    if let Some(model) = model {
        c = c
            .stages(&["render", "enhance", "dataset", "detect"])
            .tables(&format!(
                "[split]\ntrain = 0.5\nval = 0.0\ntest = 0.5\n[detect]\nmodel = \"{}\"\n",
                model.display()
            ));
    }
    c.write(&dir.join(format!("small-{seed}.toml")))
}

/// `soig run`, which must succeed: its stdout.
fn run(campaign: &Path, out: &Path) -> String {
    let o = run_quiet(campaign, out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    stdout(&o)
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

#[test]
fn identical_rerun_changed_seed_and_tampered_artifact() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, rerun, seed) = (
        tmp.path().join("a"),
        tmp.path().join("rerun"),
        tmp.path().join("seed"),
    );
    run(&campaign(tmp.path(), 7, None), &a);
    run(&campaign(tmp.path(), 7, None), &rerun);
    run(&campaign(tmp.path(), 8, None), &seed);

    for other in [&a, &rerun] {
        let (code, text) = compare(&a, other, &[]);
        assert_eq!(code, 0, "{text}");
        assert!(text.contains("identical: digest"), "{text}");
    }

    // Another seed: another campaign hash, every image changed, and no metrics to hold it.
    let (code, text) = compare(&a, &seed, &[]);
    assert_eq!(code, 1, "{text}");
    for expect in [
        "campaign hash: differs",
        "soig version: same",
        "pixels differ, largest difference",
        "changed fits/img_000000.fits",
        "no metrics to hold within a tolerance",
    ] {
        assert!(text.contains(expect), "{expect} not in\n{text}");
    }
    let o = soig(&["compare", arg(&a), arg(&seed), "--json"]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["verdict"], "regression");
    let changed = json["artifacts"]["changed"].as_array().unwrap();
    assert!(
        changed
            .iter()
            .any(|c| c["path"] == "fits/img_000005_clean.fits")
    );
    assert!(
        changed.iter().any(|c| c["detail"]["kind"] == "boxes"
            && !c["detail"]["moved"].as_array().unwrap().is_empty()),
        "no label box moved: {json:#}"
    );

    // One byte of one image changed behind the manifest's back: same digest, not identical.
    let tampered = tmp.path().join("tampered");
    copy_dir(&a, &tampered);
    let png = std::fs::read_dir(tampered.join("images/train"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let mut bytes = std::fs::read(&png).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&png, bytes).unwrap();
    let (code, text) = compare(&a, &tampered, &[]);
    assert_eq!(code, 1, "{text}");
    let name = png.file_name().unwrap().to_str().unwrap();
    assert!(
        text.contains(&format!(
            "RUN: changed: images/train/{name} (sha256 differs from the manifest)"
        )),
        "{text}"
    );
    assert!(!text.contains("identical"), "{text}");
}

/// Rewrite `dir`'s report.json through `edit` and seal its manifest again: what a run with
/// another model would leave, made by hand so the test pins compare's arithmetic.
fn fabricate(dir: &Path, edit: impl Fn(&mut serde_json::Value)) {
    let path = dir.join("report/report.json");
    let mut report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    edit(&mut report);
    std::fs::write(&path, serde_json::to_string_pretty(&report).unwrap()).unwrap();
    let old = soig::Manifest::read(dir).unwrap();
    let mut m = soig::Manifest::build(dir, &old.campaign_hash, old.campaign.clone(), &old.volatile)
        .unwrap();
    m.effective = old.effective;
    m.seal();
    m.write(dir).unwrap();
}

#[test]
fn metric_drop_within_and_beyond_tolerance_and_a_results_row() {
    if !ort_available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let model = repo("tests/fixtures/yolo/tiny.onnx");
    let c = campaign(tmp.path(), 7, Some(&model));
    // `soig run .../x/../base` ends naming the clean path, the digest, the report and the
    // headline metrics of each detector.
    std::fs::create_dir(tmp.path().join("x")).unwrap();
    let ending = run(&c, &tmp.path().join("x/../base"));
    let base = tmp.path().canonicalize().unwrap().join("base");
    let digest = soig::Manifest::read(&base).unwrap().digest;
    let lines: Vec<&str> = ending.lines().collect();
    assert!(
        lines[0].ends_with(&format!("-> {}", base.display())),
        "{ending}"
    );
    assert_eq!(lines[1], format!("digest {digest}"));
    assert_eq!(
        lines[2],
        format!(
            "report {}/report/report.md (3 test images, 3 objects)",
            base.display()
        )
    );
    for (line, detector) in lines[3..].iter().zip(["streak", "yolo"]) {
        assert!(line.trim_start().starts_with(detector), "{ending}");
        assert!(line.contains("mAP50-95"), "{ending}");
    }
    let map50 = |dir: &Path| -> f64 {
        let r = json(&dir.join("report/report.json"));
        r["detectors"][1]["ultralytics"]["map50"].as_f64().unwrap()
    };
    let before = map50(&base);
    for (drop, code, tolerance, expect) in [
        (
            0.001,
            0,
            None,
            "within tolerance: the outputs differ, no metric regressed",
        ),
        (0.05, 1, None, "yolo map50 fell by 0.0500 (tolerance 0.002)"),
        (0.05, 0, Some("map50=0.06"), "within tolerance"),
    ] {
        let other = tmp.path().join(format!("drop-{drop}-{code}"));
        copy_dir(&base, &other);
        fabricate(&other, |r| {
            let yolo = &mut r["detectors"][1];
            assert_eq!(yolo["detector"], "yolo");
            yolo["model_sha256"] = "another model".into();
            yolo["ultralytics"]["map50"] = (before - drop).into();
        });
        let extra: Vec<&str> = tolerance.iter().flat_map(|t| ["--tolerance", t]).collect();
        let (got, text) = compare(&base, &other, &extra);
        assert_eq!(got, code, "{text}");
        assert!(text.contains(expect), "{expect} not in\n{text}");
        assert!(
            text.contains("artifacts: 1 changed, 0 added, 0 removed"),
            "{text}"
        );
    }

    // A results/ row of the same run (digest, report, metrics; no images) is identical to it.
    let row = tmp.path().join("row");
    std::fs::create_dir(&row).unwrap();
    for f in ["report.json", "metrics.csv"] {
        std::fs::copy(base.join("report").join(f), row.join(f)).unwrap();
    }
    std::fs::write(row.join("digest.txt"), format!("{digest}\n")).unwrap();
    let (code, text) = compare(&row, &base, &[]);
    assert_eq!((code, text.contains("identical")), (0, true), "{text}");

    // The run's tables: one Table 3 row per detector, in Markdown and CSV.
    let out = tmp.path().join("tables");
    let o = soig(&["tables", arg(&base), "--out", arg(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = stdout(&o);
    assert!(md.contains("### Table 3 (fixed pointing)"), "{md}");
    assert!(md.contains("| Original (synthetic) | yolo |"), "{md}");
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(
        std::fs::read_to_string(out.join("timing.csv"))
            .unwrap()
            .contains("conversion")
    );
}

#[test]
fn errors_exit_2() {
    let (tmp, missing) = scratch("missing");
    let o = soig(&["compare", arg(&missing), arg(tmp.path())]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no such folder"));
    let o = soig(&["compare", arg(tmp.path()), arg(tmp.path())]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("is not a soig output"));
    let row = repo("results/ci-quickstart");
    let row = arg(&row);
    let o = soig(&["compare", row, row, "--tolerance", "map=1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown metric `map`"));
}

/// The workflow's check, run as the workflow runs it, against the committed baseline.
#[test]
fn ci_script_passes_against_its_committed_baseline() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let workflow = std::fs::read_to_string(root.join(".github/workflows/soig.yml")).unwrap();
    let runs: Vec<&str> = workflow
        .lines()
        .filter_map(|l| l.trim().strip_prefix("run: "))
        .collect();
    assert_eq!(
        runs,
        [
            "bash scripts/setup.sh",
            "cargo build --release --locked",
            "bash scripts/ci.sh"
        ]
    );
    if !ort_available() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let o = Command::new("bash")
        .arg(root.join("scripts/ci.sh"))
        .env("SOIG", env!("CARGO_BIN_EXE_soig"))
        .env("OUT", tmp.path().join("ci"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "scripts/ci.sh failed (re-pin with `bash scripts/ci.sh --pin` after an intended change):\n{}\n{}",
        stdout(&o),
        String::from_utf8_lossy(&o.stderr)
    );
}
