//! `soig experiment` end to end: a 2x2 grid runs, a rerun with a point added reuses the four
//! it already has, and each kind of malformed experiment is refused before anything runs,
//! naming file, line and field.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::{CampaignToml, ELEMENTS_40649};

fn soig(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_soig"))
        .args(args)
        .env("RAYON_NUM_THREADS", "2")
        .output()
        .unwrap()
}

/// A small campaign with orbits given as elements (no TLE file), rendered but not detected.
fn base() -> String {
    CampaignToml::new("tiny", 7, 3)
        .stages(&["render", "enhance", "dataset"])
        .observer("norad = 1\nelements = { period_min = 100.0, inclination_deg = 98.6, apogee_km = 800.0, perigee_km = 790.0 }")
        .debris(ELEMENTS_40649)
        .text()
}

fn experiment(dir: &Path, file: &str, axes: &str) -> String {
    std::fs::write(dir.join("base.toml"), base()).unwrap();
    let path = dir.join(file);
    std::fs::write(
        &path,
        format!("base = \"base.toml\"\ncollect = [\"seconds\"]\n{axes}"),
    )
    .unwrap();
    path.to_str().unwrap().to_string()
}

/// The points of the experiment's manifest `out/experiment.json`.
fn points(out: &Path) -> Vec<serde_json::Value> {
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("experiment.json")).unwrap())
            .unwrap();
    m["points"].as_array().unwrap().clone()
}

fn digests(out: &Path) -> Vec<(String, String)> {
    points(out)
        .iter()
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_string(),
                p["digest"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// The folder of the point named `name` (in the experiment's manifest).
fn folder_of(out: &Path, name: &str) -> String {
    points(out)
        .iter()
        .find(|p| p["name"] == name)
        .unwrap_or_else(|| panic!("no point {name}"))["folder"]
        .as_str()
        .unwrap()
        .to_string()
}

/// Two values whose names sanitise alike (`a/b` and `a_b`) are two points in two folders, each
/// with its values in a readable file beside it, not one folder averaged as replicates
/// (issue #43: on the main of 2026-11-28 they shared `points/output=_a_b_`).
#[test]
fn values_that_read_alike_get_folders_of_their_own() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let path = experiment(
        tmp.path(),
        "e.toml",
        "set = [\"images=1\", \"stages=[\\\"render\\\"]\"]\n[[axis]]\nfield = \"output\"\nvalues = [\"a/b\", \"a_b\"]\n",
    );
    let o = soig(&["experiment", &path, "--out", out.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut folders: Vec<String> = std::fs::read_dir(out.join("points"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    folders.sort();
    assert_eq!(
        folders.len(),
        4,
        "two folders and their values: {folders:?}"
    );
    let values: Vec<String> = folders
        .iter()
        .filter(|f| f.ends_with(".json"))
        .map(|f| std::fs::read_to_string(out.join("points").join(f)).unwrap())
        .collect();
    assert!(
        values.iter().any(|v| v.contains("\\\"a/b\\\"")),
        "{values:?}"
    );
    assert!(
        values.iter().any(|v| v.contains("\\\"a_b\\\"")),
        "{values:?}"
    );
}

#[test]
fn a_grid_runs_and_a_rerun_reuses_unchanged_points() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let axes = |exposures: &str| {
        format!(
            "[[axis]]\nfield = \"exposure.max_s\"\nvalues = {exposures}\n\n[[axis]]\nfield = \"seed\"\nfrom = 1\nto = 2\nstep = 1\n"
        )
    };
    // `soig experiment` of `axes`, which must succeed and say `summary`.
    let run = |axes: &str, summary: &str| {
        let path = experiment(tmp.path(), "e.toml", axes);
        let o = soig(&["experiment", &path, "--out", out.to_str().unwrap(), "-q"]);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(stdout.contains(summary), "{stdout}");
    };
    run(&axes("[5.0, 8.0]"), "4 point(s), 0 reused, 0 failed");
    let first = digests(&out);
    assert_eq!(first.len(), 4);
    assert!(
        first.iter().any(|(n, _)| n == "exposure.max_s=8.0,seed=2"),
        "{first:?}"
    );
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    assert!(out.join("plots/seconds-vs-exposure.max_s.png").is_file());
    // Each point is a verifiable soig run.
    let v = soig(&[
        "verify",
        out.join("points")
            .join(folder_of(&out, "exposure.max_s=5.0,seed=1"))
            .to_str()
            .unwrap(),
    ]);
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stderr));

    // A point added: the four others are reused, with their digests.
    run(&axes("[5.0, 8.0, 11.0]"), "6 point(s), 4 reused, 0 failed");
    let second = digests(&out);
    for p in &first {
        assert!(second.contains(p), "{p:?} changed");
    }
}

#[test]
fn malformed_experiments_are_refused_before_anything_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let cases = [
        (
            "[[axis]]\nfield = \"visibility.snr_minn\"\nvalues = [0.1]\n",
            ":4: field `axis[0].field`",
            "unknown field `snr_minn`",
        ),
        (
            "[[axis]]\nfield = \"images\"\nvalues = [\"many\"]\n",
            ":5: field `axis[0].values`",
            "expected u32",
        ),
        (
            "[[axis]]\nfield = \"images\"\nvalues = []\n",
            ":5: field `axis[0].values`",
            "no values",
        ),
        (
            "mode = \"zip\"\n[[axis]]\nfield = \"images\"\nvalues = [3, 4]\n[[axis]]\nfield = \"seed\"\nvalues = [1]\n",
            ":9: field `axis[1].values`",
            "equal length",
        ),
    ];
    for (axes, place, why) in cases {
        let path = experiment(tmp.path(), "bad.toml", axes);
        let o = soig(&["experiment", &path, "--out", out.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(&format!("bad.toml{place}")), "{stderr}");
        assert!(stderr.contains(why), "{stderr}");
        assert!(!out.exists(), "nothing runs for a refused experiment");
    }
}

/// `schemas/experiment.schema.json` is the output of `soig schema --experiment`; regenerate
/// with `target/release/soig schema --experiment > schemas/experiment.schema.json`.
#[test]
fn committed_experiment_schema_is_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("schemas/experiment.schema.json");
    let committed = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        committed,
        soig::sweep::schema_json() + "\n",
        "schemas/experiment.schema.json is stale: run `soig schema --experiment > schemas/experiment.schema.json`"
    );
}
