//! `soig slurm` and `soig k8s` from the command line: the cluster's resources reach the job
//! files, a malformed one is refused before anything is written, and paths the pods cannot
//! see are warned about.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::Path;
use std::process::Output;

mod common;
use common::{arg, scratch, soig_in};

/// `soig slurm campaigns/quickstart.toml --shards 2 ARGS --scripts SCRIPTS` from the
/// repository root.
fn slurm(args: &[&str], scripts: &Path) -> Output {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = vec!["slurm", QUICKSTART, "--shards", "2"];
    all.extend_from_slice(args);
    all.extend(["--scripts", arg(scripts)]);
    soig_in(root, &all)
}

/// The campaign the cluster scripts are written for, from the repository root.
const QUICKSTART: &str = "campaigns/quickstart.toml";

/// `soig k8s CAMPAIGN --shards 2 ARGS --scripts JOBS` from folder `cwd`.
fn k8s(cwd: &Path, campaign: &str, args: &[&str], jobs: &Path) -> Output {
    let mut all = vec!["k8s", campaign, "--shards", "2"];
    all.extend_from_slice(args);
    all.extend(["--scripts", arg(jobs)]);
    soig_in(cwd, &all)
}

#[test]
fn slurm_resources_reach_every_job() {
    let (dir, scripts) = scratch("jobs");
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
            arg(&out),
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
    let (_dir, scripts) = scratch("jobs");
    let o = slurm(&["--time", "2h"], &scripts);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--time \"2h\""), "{err}");
    assert!(!scripts.exists());
}

#[test]
fn k8s_warns_of_paths_outside_the_volume() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (_dir, jobs) = scratch("jobs");
    // Relative paths within the volume's root (here the repository): no warning.
    let o = k8s(root, QUICKSTART, &["--out", "runs/q"], &jobs);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!String::from_utf8_lossy(&o.stderr).contains("warning"));
    let o = k8s(
        &root.join("campaigns"),
        "quickstart.toml",
        &["--out", "/scratch/q"],
        &jobs,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: the output path /scratch/q is absolute"),
        "{err}"
    );
    let o = k8s(root, QUICKSTART, &["--out", "../q"], &jobs);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: the output path ../q is outside the volume"),
        "{err}"
    );
}

/// Run the k8s `submit.sh` in `jobs` against a fake `kubectl` (on PATH) whose Jobs never
/// finish and whose pods answer `pods`; killed after 60 s.
fn submit_against(jobs: &Path, pods: &str, env: &[(&str, &str)]) -> (Option<i32>, String) {
    use std::os::unix::fs::PermissionsExt;
    let bin = jobs.join("fake-bin");
    std::fs::create_dir_all(&bin).unwrap();
    let kubectl = bin.join("kubectl");
    std::fs::write(
        &kubectl,
        format!(
            "#!/bin/sh\n# A cluster whose Jobs never end.\ncase \"$1 $2\" in\n  \"get pods\") printf '{pods}\\n' ;;\nesac\nexit 0\n"
        ),
    )
    .unwrap();
    std::fs::set_permissions(&kubectl, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut child = std::process::Command::new("bash")
        .arg(jobs.join("submit.sh"))
        .env("PATH", path)
        .env("SOIG_K8S_POLL_S", "1")
        .envs(env.iter().copied())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if started.elapsed().as_secs() > 60 {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    let mut err = String::new();
    use std::io::Read;
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (code, err)
}

/// Issue #43: pods that stay Pending, or cannot pull the image, made submit.sh wait for ever.
/// Now each Job has a deadline (`--deadline`, the Jobs' activeDeadlineSeconds) after which
/// submit.sh gives up naming the pods' state, and an image that cannot be pulled ends it
/// after a grace.
#[test]
fn k8s_submit_gives_up_after_its_deadline() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (dir, jobs) = scratch("jobs");
    let with_deadline = ["--out", "runs/q", "--deadline", "3s"];
    let o = k8s(root, QUICKSTART, &with_deadline, &jobs);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["shards.yaml", "merge.yaml"] {
        let text = std::fs::read_to_string(jobs.join(f)).unwrap();
        assert!(text.contains("activeDeadlineSeconds: 3\n"), "{f}: {text}");
    }
    let (code, err) = submit_against(&jobs, "soig-quick-start-0-abc Pending", &[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("not complete after"), "{err}");
    assert!(err.contains("deadline"), "{err}");
    assert!(err.contains("soig-quick-start-0-abc Pending"), "{err}");

    // An image the cluster cannot pull: given up after the grace, long before the deadline.
    let unpullable = ["--out", "runs/q", "--image", "reg.example/none:1"];
    let o = k8s(root, QUICKSTART, &unpullable, &jobs);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (code, err) = submit_against(
        &jobs,
        "soig-quick-start-0-abc Pending ImagePullBackOff",
        &[("SOIG_K8S_PULL_GRACE_S", "2")],
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("cannot pull the image reg.example/none:1"),
        "{err}"
    );
    // A deadline that is no duration is refused before anything is written.
    let none = dir.path().join("none");
    let o = k8s(root, QUICKSTART, &["--deadline", "soon"], &none);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--deadline \"soon\""));
    assert!(!none.exists());
}
