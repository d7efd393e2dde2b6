//! Shards (`soig run --shard`, `soig merge`): any split of a campaign, run in any order, merges
//! to the single run's digest, report included; a set of shards that is not one whole campaign
//! is refused with the reason.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::{arg, assert_refused, digest, repo, small_detecting_run};

fn soig(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_soig"));
    cmd.args(args);
    for var in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_COUNT",
        "SLURM_ARRAY_TASK_STEP",
        "JOB_COMPLETION_INDEX",
    ] {
        cmd.env_remove(var);
    }
    cmd.envs(env.iter().copied());
    cmd.output().expect("soig runs")
}

/// 7 small images with the detect stage (both detectors, the model given relative to the
/// campaign's folder, which a merge must find again), written as `dir/NAME.toml`.
fn campaign(dir: &Path, name: &str, seed: u64) -> PathBuf {
    let model = repo("tests/fixtures/yolo/tiny.onnx");
    std::fs::copy(model, dir.join("tiny.onnx")).unwrap();
    small_detecting_run(name, seed, 7, "[detect]\nmodel = \"tiny.onnx\"\n")
        .write(&dir.join(format!("{name}.toml")))
}

/// Run shard `k` of `n` of `campaign` into `out`.
fn shard(campaign: &Path, k: u64, n: u64, out: &Path) -> Output {
    let spec = format!("{k}/{n}");
    let args = ["run", arg(campaign), "--quiet", "--shard", &spec];
    let out_args = ["--out", arg(out)];
    soig(&[&args[..], &out_args[..]].concat(), &[])
}

fn merge(shards: &[&PathBuf], out: &Path) -> Output {
    let mut args = vec!["merge", "--quiet", "--out", arg(out)];
    args.extend(shards.iter().map(|s| arg(s)));
    soig(&args, &[])
}

#[test]
fn any_split_in_any_order_merges_to_the_single_run_digest() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let c = campaign(t, "split", 11);
    let single = digest(&soig(
        &["run", arg(&c), "--quiet", "--out", arg(&t.join("single"))],
        &[],
    ));
    for n in [1u64, 3, 7] {
        // Last shard first.
        let dirs: Vec<PathBuf> = (0..n).map(|k| t.join(format!("s{n}-{k}"))).collect();
        for k in (0..n).rev() {
            digest(&shard(&c, k, n, &dirs[k as usize]));
        }
        let out = t.join(format!("merged{n}"));
        let refs: Vec<&PathBuf> = dirs.iter().rev().collect();
        assert_eq!(digest(&merge(&refs, &out)), single, "{n} shards");
        let v = soig(&["verify", arg(&out)], &[]);
        assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stderr));
        assert!(out.join("report/report.json").is_file());
    }
    // The shard taken from a Slurm array task and from a Kubernetes Indexed Job, into the
    // default output `runs/<name>-shard-K-of-N`, are the same shards.
    let slurm = soig(
        &["run", arg(&c), "--quiet", "--shard", "auto"],
        &[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ],
    );
    let k8s = soig(
        &["run", arg(&c), "--quiet", "--shard", "auto/3"],
        &[("JOB_COMPLETION_INDEX", "2")],
    );
    assert_eq!(digest(&slurm), digest(&shard(&c, 1, 3, &t.join("again-1"))));
    assert_eq!(digest(&k8s), digest(&shard(&c, 2, 3, &t.join("again-2"))));
    assert!(t.join("runs/split-shard-1-of-3/manifest.json").is_file());
    let both = [
        t.join("s3-0"),
        t.join("runs/split-shard-1-of-3"),
        t.join("runs/split-shard-2-of-3"),
    ];
    assert_eq!(
        digest(&merge(&both.iter().collect::<Vec<_>>(), &t.join("m"))),
        single
    );
}

#[test]
fn a_set_of_shards_that_is_not_one_whole_campaign_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let c = campaign(t, "one", 5);
    let other = campaign(t, "other", 6);
    let s: Vec<PathBuf> = (0..3).map(|k| t.join(format!("s{k}"))).collect();
    for k in 0..3 {
        digest(&shard(&c, k, 3, &s[k as usize]));
    }
    let foreign = t.join("foreign");
    digest(&shard(&other, 2, 3, &foreign));
    let out = t.join("out");
    assert_refused(&merge(&[&s[0], &s[1]], &out), "shard(s) 2 of 3 missing");
    assert_refused(
        &merge(&[&s[0], &s[1], &s[1], &s[2]], &out),
        "shard 1 of 3 is given twice",
    );
    assert_refused(&merge(&[&s[0], &s[1], &foreign], &out), "not one campaign");
    assert_refused(&merge(&[&s[2], &s[0]], &out), "of 3 missing");
    let whole = t.join("whole");
    digest(&soig(
        &["run", arg(&c), "--quiet", "--out", arg(&whole)],
        &[],
    ));
    assert_refused(&merge(&[&whole], &out), "is not a shard");
    assert_refused(&merge(&[&s[0], &s[1], &s[2]], &s[1]), "one of the shards");
    // A shard whose files changed after it was made.
    let truth = s[1].join("truth/img_000003.json");
    let text = std::fs::read_to_string(&truth).unwrap();
    std::fs::write(&truth, text.replace("\"snr\"", "\"snr\" ")).unwrap();
    assert_refused(&merge(&[&s[0], &s[1], &s[2]], &out), "does not verify");
    assert!(!out.exists());
    // Bad shard specifications.
    for (spec, says) in [
        ("3/3", "below the count"),
        ("1/8", "8 shards for the campaign's 7 images"),
        ("auto", "neither"),
    ] {
        let o = soig(&["run", arg(&c), "--quiet", "--shard", spec], &[]);
        assert_refused(&o, says);
    }
}
