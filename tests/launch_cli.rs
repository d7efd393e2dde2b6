//! `soig slurm` and `soig k8s` from the command line: the cluster's resources reach the job
//! files, a malformed one is refused before anything is written, and paths the pods cannot
//! see are warned about.

use std::path::Path;
use std::process::Output;

mod common;
use common::soig_in;

/// `soig slurm campaigns/quickstart.toml --shards 2 ARGS --scripts SCRIPTS` from the
/// repository root.
fn slurm(args: &[&str], scripts: &Path) -> Output {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = vec!["slurm", "campaigns/quickstart.toml", "--shards", "2"];
    all.extend_from_slice(args);
    all.extend(["--scripts", scripts.to_str().unwrap()]);
    soig_in(root, &all)
}

#[test]
fn slurm_resources_reach_every_job() {
    let dir = tempfile::tempdir().unwrap();
    let scripts = dir.path().join("jobs");
    let out = dir.path().join("out");
    let o = slurm(
        &[
            "--partition",
            "p",
            "--account",
            "a1",
            "--time",
            "01:00:00",
            "--mem",
            "4G",
            "--cpus-per-task",
            "4",
            "--sbatch=--qos=high",
            "--out",
            out.to_str().unwrap(),
        ],
        &scripts,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["array.sbatch", "merge.sbatch"] {
        let text = std::fs::read_to_string(scripts.join(f)).unwrap();
        assert!(
            text.contains(
                "#SBATCH --partition=p\n#SBATCH --account=a1\n#SBATCH --time=01:00:00\n\
                 #SBATCH --mem=4G\n#SBATCH --cpus-per-task=4\n#SBATCH --qos=high\n"
            ),
            "{f}:\n{text}"
        );
    }
}

#[test]
fn a_malformed_slurm_time_is_refused_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let scripts = dir.path().join("jobs");
    let o = slurm(&["--time", "2h"], &scripts);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--time \"2h\""), "{err}");
    assert!(!scripts.exists());
}

#[test]
fn k8s_warns_of_paths_outside_the_volume() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let jobs = dir.path().join("jobs");
    let jobs = jobs.to_str().unwrap();
    // Relative paths within the volume's root (here the repository): no warning.
    let o = soig_in(
        root,
        &[
            "k8s",
            "campaigns/quickstart.toml",
            "--shards",
            "2",
            "--out",
            "runs/q",
            "--scripts",
            jobs,
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!String::from_utf8_lossy(&o.stderr).contains("warning"));
    let o = soig_in(
        &root.join("campaigns"),
        &[
            "k8s",
            "quickstart.toml",
            "--shards",
            "2",
            "--out",
            "/scratch/q",
            "--scripts",
            jobs,
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: the output path /scratch/q is absolute"),
        "{err}"
    );
    let o = soig_in(
        root,
        &[
            "k8s",
            "campaigns/quickstart.toml",
            "--shards",
            "2",
            "--out",
            "../q",
            "--scripts",
            jobs,
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: the output path ../q is outside the volume"),
        "{err}"
    );
}
