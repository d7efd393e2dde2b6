//! Never losing work: a run killed at any point (`kill -9` while rendering; an abort at the
//! dataset step, after the manifest, during the final move, by the test-only hook
//! `SOIG_TEST_ABORT_AT`) or stopped by SIGTERM is resumed by running it again, which ends with
//! the uninterrupted run's digest and leaves no staging directory or lock.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

mod common;
use common::{CampaignToml, ELEMENTS_40649, arg, differing_files, digest, small_detecting_run};

/// `images` small images (fixed pointing, the detect stage with the streak detector), written
/// as `dir/NAME.toml`.
fn campaign(dir: &Path, name: &str, images: u32) -> PathBuf {
    small_detecting_run(
        "resume",
        21,
        images,
        "[artifacts]\nnoise_free_fits = true\n",
    )
    .write(&dir.join(format!("{name}.toml")))
}

/// A scratch folder holding `campaign(.., name, images)` and the output path `out` in it.
fn resume_case(name: &str, images: u32) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let c = campaign(tmp.path(), name, images);
    let out = tmp.path().join("out");
    (tmp, c, out)
}

fn command(campaign: &Path, out: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_soig"));
    cmd.args(["run", arg(campaign), "--quiet", "--out"])
        .arg(out)
        .env_remove("SOIG_TEST_ABORT_AT");
    cmd
}

/// The hidden entries (staging directories, locks) beside `out`.
fn leftovers(out: &Path) -> Vec<String> {
    std::fs::read_dir(out.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect()
}

/// Nothing hidden is left beside `out`: no staging directory, no lock.
fn assert_no_leftovers(out: &Path) {
    let left = leftovers(out);
    assert!(left.is_empty(), "{left:?}");
}

/// Lines in the journal of the staging directory of process `pid` writing `out`.
fn journaled(out: &Path, pid: u32) -> usize {
    let name = out.file_name().unwrap().to_string_lossy();
    let journal = out
        .with_file_name(format!(".{name}.partial-{pid}"))
        .join(".soig-journal.jsonl");
    std::fs::read_to_string(journal).map_or(0, |t| t.lines().count().saturating_sub(1))
}

/// `resumed`, the run that resumed into `out`, ends with the digest of `campaign` run
/// uninterrupted (beside it, into `reference`), naming the files that differ otherwise.
fn assert_resumed_as_uninterrupted(campaign: &Path, out: &Path, resumed: &Output) {
    let reference = out.with_file_name("reference");
    let uninterrupted = digest(&command(campaign, &reference).output().unwrap());
    assert_eq!(
        digest(resumed),
        uninterrupted,
        "files that differ: {:?}",
        differing_files(out, &reference)
    );
}

/// Spawn the run on one thread (so that it is still rendering when the signal comes, on any
/// machine), wait until it has journaled `images` images, signal it, and wait for its end.
fn stop_after(campaign: &Path, out: &Path, images: usize, signal: &str) -> Output {
    let child = command(campaign, out)
        .env("RAYON_NUM_THREADS", "1")
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while journaled(out, child.id()) < images && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(
        journaled(out, child.id()) >= images,
        "the run never got going"
    );
    let sent = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    child.wait_with_output().unwrap()
}

#[test]
fn killed_at_any_phase_a_run_resumes_to_the_same_digest() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    // kill -9 while rendering, then resume: only the missing images are rendered.
    let long = campaign(t, "long", 150);
    let out = t.join("out");
    let stopped = stop_after(&long, &out, 3, "-KILL");
    assert_eq!(stopped.status.code(), None, "{stopped:?}");
    let resumed = command(&long, &out).output().unwrap();
    assert_resumed_as_uninterrupted(&long, &out, &resumed);
    let said = String::from_utf8_lossy(&resumed.stdout);
    assert!(
        said.contains("resumed)") && !said.starts_with("150 images"),
        "{said}"
    );
    assert_no_leftovers(&out);

    let c = campaign(t, "short", 24);
    let reference = digest(&command(&c, &t.join("reference")).output().unwrap());

    // Aborted (as by kill -9) at each later phase; `rename` both with and without an old
    // output in place.
    for phase in ["render:5", "dataset", "manifest", "rename"] {
        let o = command(&c, &out)
            .arg("--fresh")
            .env("SOIG_TEST_ABORT_AT", phase)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), None, "{phase}: {o:?}");
        assert!(!leftovers(&out).is_empty(), "{phase}: nothing to resume");
        assert_eq!(
            digest(&command(&c, &out).output().unwrap()),
            reference,
            "{phase}"
        );
        assert!(leftovers(&out).is_empty(), "{phase}: {:?}", leftovers(&out));
    }
    std::fs::remove_dir_all(&out).unwrap();
    let o = command(&c, &out)
        .env("SOIG_TEST_ABORT_AT", "rename")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), None);
    assert_eq!(digest(&command(&c, &out).output().unwrap()), reference);
    assert_no_leftovers(&out);

    // Another campaign does not resume this one's work: it removes it and starts afresh.
    let o = command(&c, &out)
        .env("SOIG_TEST_ABORT_AT", "render:2")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), None);
    let other = CampaignToml::new("resume", 22, 4)
        .debris(ELEMENTS_40649)
        .tables("[sensor]\nwidth_px = 128\nheight_px = 128\nfov_radius_deg = 0.0125\n")
        .write(&t.join("other.toml"));
    let o = command(&other, &out).output().unwrap();
    digest(&o);
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("4 images rendered in"));
    assert_no_leftovers(&out);
}

#[test]
fn sigterm_keeps_the_work_and_the_same_command_resumes_it() {
    let (tmp, c, out) = resume_case("resume", 150);
    let t = tmp.path();
    let stopped = stop_after(&c, &out, 2, "-TERM");
    assert_eq!(stopped.status.code(), Some(143), "{stopped:?}");
    let err = String::from_utf8_lossy(&stopped.stderr);
    assert!(
        err.contains("kept in") && err.contains("run the same command again"),
        "{err}"
    );
    // The work is kept, the lock is not.
    let staging = t.join(&leftovers(&out)[0]);
    assert!(staging.join(".soig-journal.jsonl").is_file());
    assert_eq!(
        leftovers(&out),
        vec![staging.file_name().unwrap().to_string_lossy()]
    );
    let resumed = command(&c, &out).output().unwrap();
    assert!(String::from_utf8_lossy(&resumed.stdout).contains("resumed)"));
    assert_resumed_as_uninterrupted(&c, &out, &resumed);
    assert_no_leftovers(&out);
}

/// Issue #31: soig as PID 1 of its own PID namespace (a Kubernetes pod), killed with SIGKILL,
/// then run again the same way (the retried pod's soig is PID 1 again, its lock and staging
/// folder named after PID 1): the retry resumes and ends with the uninterrupted run's digest.
/// Needs root for `unshare -p`; skipped, saying so, without it.
#[test]
fn a_killed_pid_1_in_its_own_namespace_resumes_on_retry() {
    let (tmp, c, out) = resume_case("pod", 60);
    let t = tmp.path();
    let pod = || {
        let mut cmd = Command::new("unshare");
        cmd.args([
            "-p",
            "-f",
            "--mount-proc",
            env!("CARGO_BIN_EXE_soig"),
            "run",
        ])
        .arg(&c)
        .args(["--quiet", "--out"])
        .arg(&out)
        .env("RAYON_NUM_THREADS", "1")
        .env_remove("SOIG_TEST_ABORT_AT");
        cmd
    };
    let probe = Command::new("unshare")
        .args(["-p", "-f", "--mount-proc", "true"])
        .output();
    if !probe.is_ok_and(|o| o.status.success()) {
        eprintln!("skipped: `unshare -p -f --mount-proc` is not available here (needs root)");
        return;
    }
    let child = pod().stderr(std::process::Stdio::piped()).spawn().unwrap();
    let started = Instant::now();
    while journaled(&out, 1) < 3 && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(journaled(&out, 1) >= 3, "the pod's run never got going");
    // The pod's soig is unshare's only child: SIGKILL it, as a node would.
    let children =
        std::fs::read_to_string(format!("/proc/{0}/task/{0}/children", child.id())).unwrap();
    let soig: i32 = children.split_whitespace().next().unwrap().parse().unwrap();
    let lock = std::fs::read_to_string(t.join(".out.lock")).unwrap();
    assert!(lock.starts_with("pid 1 on host"), "{lock}");
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(soig),
        nix::sys::signal::Signal::SIGKILL,
    )
    .unwrap();
    let killed = child.wait_with_output().unwrap();
    assert!(!killed.status.success());
    assert!(t.join(".out.partial-1").is_dir(), "no staging folder left");

    let retry = pod().output().unwrap();
    assert!(
        retry.status.success(),
        "{}",
        String::from_utf8_lossy(&retry.stderr)
    );
    let said = String::from_utf8_lossy(&retry.stdout);
    assert!(said.contains("resumed)"), "{said}");
    let verify = Command::new(env!("CARGO_BIN_EXE_soig"))
        .arg("verify")
        .arg(&out)
        .output()
        .unwrap();
    assert!(verify.status.success(), "{verify:?}");
    assert_resumed_as_uninterrupted(&c, &out, &retry);
    assert_no_leftovers(&out);
}
