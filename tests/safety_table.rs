//! The output-safety table (issue #43): every verb of `soig --help` either has a row here, run
//! against the attacks below, or is named as one that writes nothing; a new verb that is in
//! neither list fails this test, so no writer can skip it.
//!
//! Each writing verb, in a fresh folder holding the inputs it needs, against:
//! - `user-folder`: its output is a folder holding a user's file;
//! - `symlinks`: its output holds links, named as the files soig writes, to a user's file
//!   outside it; and its output is itself a link to a folder holding a user's file;
//! - `fifo`: its input is a FIFO (it must end, within 30 s, with an error);
//! - `full-disk`: its output lies on a full tmpfs (as root; skipped, saying so, otherwise);
//! - `kill`: it is killed just before its output moves into place (`SOIG_TEST_ABORT_AT=rename`,
//!   an abort as `kill -9` stops it), or between the first file it writes atomically and that
//!   file's rename (`write`), then run again.
//!
//! In every case the user's files are byte for byte as they were, a command that fails changes
//! nothing at all (but the folders a full disk's temporary file passed through), and no
//! staging folder, lock or temporary file stays once the command is over (after a kill, once
//! the rerun is over).

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::collections::BTreeMap;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One writing verb: its arguments (`{out}` is the output), the input the FIFO attack
/// replaces, and whether it can finish here (`train` needs Ultralytics: it is given
/// `/bin/true` as its Python, so only its refusals and its dataset run are exercised).
struct Row {
    verb: &'static str,
    args: &'static [&'static str],
    fifo: &'static str,
    finishes: bool,
}

const WRITERS: &[Row] = &[
    Row {
        verb: "run",
        args: &["run", "c.toml", "--quiet", "--out", "{out}"],
        fifo: "c.toml",
        finishes: true,
    },
    Row {
        verb: "merge",
        args: &["merge", "s0", "s1", "--quiet", "--out", "{out}"],
        fifo: "s1/manifest.json",
        finishes: true,
    },
    Row {
        verb: "slurm",
        args: &["slurm", "c.toml", "--shards", "2", "--scripts", "{out}"],
        fifo: "c.toml",
        finishes: true,
    },
    Row {
        verb: "k8s",
        args: &["k8s", "c.toml", "--shards", "2", "--scripts", "{out}"],
        fifo: "c.toml",
        finishes: true,
    },
    Row {
        verb: "train",
        args: &[
            "train",
            "c.toml",
            "--quiet",
            "--python",
            "/bin/true",
            "--out",
            "{out}",
        ],
        fifo: "c.toml",
        finishes: false,
    },
    Row {
        verb: "study",
        args: &[
            "study", "c.toml", "--quick", "--seeds", "2", "--out", "{out}",
        ],
        fifo: "c.toml",
        finishes: true,
    },
    Row {
        verb: "tables",
        args: &["tables", "run1", "--out", "{out}"],
        fifo: "run1/report/report.json",
        finishes: true,
    },
    Row {
        verb: "detect",
        args: &["detect", "f.fits", "--out", "{out}"],
        fifo: "f.fits",
        finishes: true,
    },
    Row {
        verb: "enhance",
        args: &["enhance", "f.fits", "--out", "{out}"],
        fifo: "f.fits",
        finishes: true,
    },
    Row {
        verb: "experiment",
        args: &["experiment", "e.toml", "--out", "{out}", "-q"],
        fifo: "e.toml",
        finishes: true,
    },
    Row {
        verb: "export",
        args: &["export", "run1", "--out", "{out}"],
        fifo: "run1/manifest.json",
        finishes: true,
    },
];

/// The verbs that write no file, and why.
const READERS: &[(&str, &str)] = &[
    ("verify", "reads an output and its manifest"),
    ("compare", "reads two outputs, prints"),
    ("eval", "reads labels and predictions, prints"),
    ("schema", "prints"),
    ("help", "prints"),
];

fn soig() -> &'static str {
    env!("CARGO_BIN_EXE_soig")
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The verbs `soig --help` lists.
fn verbs() -> Vec<String> {
    let o = Command::new(soig()).arg("--help").output().unwrap();
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next().map(String::from))
        .collect()
}

#[test]
fn every_verb_has_a_row_or_writes_nothing() {
    let listed = verbs();
    assert!(listed.len() >= 15, "{listed:?}");
    for v in &listed {
        let rows = WRITERS.iter().any(|r| r.verb == v);
        let reads = READERS.iter().any(|(r, _)| r == v);
        assert!(
            rows != reads,
            "verb `{v}`: give it a row in WRITERS (it writes) or name it in READERS (it writes nothing), not both or neither"
        );
    }
    for r in WRITERS
        .iter()
        .map(|r| r.verb)
        .chain(READERS.iter().map(|r| r.0))
    {
        assert!(listed.iter().any(|v| v == r), "`{r}` is no verb of soig");
    }
}

const TLE: &str = "campaigns/data/catalog-2022-01-22.tle";

/// The inputs every row needs, made once: a campaign, a finished run with a report, two shards,
/// a real frame, an experiment.
fn fixture(dir: &Path) {
    let tle = repo().join(TLE).display().to_string();
    let campaign = format!(
        "name = \"x\"\nimages = 2\nstages = [\"render\", \"enhance\", \"dataset\", \"detect\"]\n\
         [observer]\ntle_file = \"{tle}\"\nnorad = 41335\n\
         [[debris]]\ntle_file = \"{tle}\"\nnorad = 37476\n\
         [sensor]\nwidth_px = 64\nheight_px = 64\n\
         [split]\ntrain = 0.5\nval = 0.0\ntest = 0.5\n\
         [detect]\nclassical = true\n"
    );
    std::fs::write(dir.join("c.toml"), campaign).unwrap();
    std::fs::write(
        dir.join("e.toml"),
        "base = \"c.toml\"\ncollect = [\"seconds\"]\n[[axis]]\nfield = \"seed\"\nvalues = [1]\n",
    )
    .unwrap();
    std::fs::copy(
        repo().join("tests/fixtures/neossat/NEOS_SCI_2024239174545_cord.fits"),
        dir.join("f.fits"),
    )
    .unwrap();
    for args in [
        &["run", "c.toml", "--quiet", "--out", "run1"][..],
        &["run", "c.toml", "--quiet", "--shard", "0/2", "--out", "s0"],
        &["run", "c.toml", "--quiet", "--shard", "1/2", "--out", "s1"],
    ] {
        let o = Command::new(soig())
            .args(args)
            .current_dir(dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
}

/// A fresh case folder: a copy of the fixture.
fn case(fixture: &Path, root: &Path, name: &str) -> PathBuf {
    let dir = root.join(name);
    let ok = Command::new("cp")
        .arg("-a")
        .arg(fixture)
        .arg(&dir)
        .status()
        .unwrap()
        .success();
    assert!(ok);
    dir
}

/// Every path under `dir` with what identifies it: a link's target, else size, mtime, mode and
/// (for a file) its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, String> {
    fn walk(dir: &Path, into: &mut BTreeMap<PathBuf, String>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries {
            let path = e.unwrap().path();
            let meta = std::fs::symlink_metadata(&path).unwrap();
            let id = if meta.file_type().is_symlink() {
                format!("-> {:?}", std::fs::read_link(&path).unwrap())
            } else if meta.is_file() {
                format!(
                    "{} {} {:o} {:?}",
                    meta.len(),
                    meta.mtime_nsec() + meta.mtime() * 1_000_000_000,
                    meta.mode(),
                    std::fs::read(&path).unwrap_or_default()
                )
            } else {
                format!(
                    "{} {:o}",
                    meta.mtime_nsec() + meta.mtime() * 1_000_000_000,
                    meta.mode()
                )
            };
            into.insert(path.clone(), id);
            if meta.is_dir() {
                walk(&path, into);
            }
        }
    }
    let mut m = BTreeMap::new();
    walk(dir, &mut m);
    m
}

/// What changed between two snapshots, but the folders in `touched` themselves.
fn changes(
    before: &BTreeMap<PathBuf, String>,
    after: &BTreeMap<PathBuf, String>,
    touched: &[PathBuf],
) -> Vec<String> {
    let mut out = Vec::new();
    for (p, id) in before {
        match after.get(p) {
            None => out.push(format!("deleted {}", p.display())),
            Some(_) if touched.contains(p) => {}
            Some(now) if now != id => out.push(format!("changed {}", p.display())),
            Some(_) => {}
        }
    }
    for p in after.keys().filter(|p| !before.contains_key(*p)) {
        out.push(format!("created {}", p.display()));
    }
    out
}

/// Staging folders, locks, set-aside outputs and temporary files under `dir`.
fn strays(dir: &Path) -> Vec<String> {
    strays_in(&snapshot(dir))
}

/// The staging folders, locks, set-aside outputs and temporary files of a `snapshot`.
fn strays_in(snapshot: &BTreeMap<PathBuf, String>) -> Vec<String> {
    snapshot
        .keys()
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.starts_with('.')
                && (n.contains(".partial-")
                    || n.ends_with(".lock")
                    || n.contains(".old-")
                    || n.contains(".tmp-"))
        })
        .map(|p| p.display().to_string())
        .collect()
}

/// Run the row's command in `dir` with `out`; its exit code (None: a signal, or killed after
/// 30 s) and stderr.
fn run(row: &Row, dir: &Path, out: &str, env: &[(&str, &str)]) -> (Option<i32>, String, bool) {
    let args: Vec<String> = row.args.iter().map(|a| a.replace("{out}", out)).collect();
    let err_path = dir.with_extension("stderr");
    let mut child = Command::new(soig())
        .args(&args)
        .current_dir(dir)
        .env("RAYON_NUM_THREADS", "1")
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let (code, hung) = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break (s.code(), false);
        }
        if started.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            child.wait().unwrap();
            break (None, true);
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = std::fs::read_to_string(&err_path).unwrap_or_default();
    (code, err, hung)
}

fn nix_is_root() -> bool {
    std::fs::read_to_string("/proc/self/status").is_ok_and(|s| {
        s.lines()
            .find(|l| l.starts_with("Uid:"))
            .is_some_and(|l| l.split_whitespace().nth(2) == Some("0"))
    })
}

/// The attacks on one row; the ways it went wrong.
fn attack(row: &Row, fixture: &Path, root: &Path) -> Vec<String> {
    let mut problems = Vec::new();
    let mut check = |what: &str, list: Vec<String>| {
        problems.extend(list.into_iter().map(|p| format!("{what}: {p}")));
    };

    // A user's folder as the output.
    let dir = case(fixture, root, &format!("{}-user-folder", row.verb));
    std::fs::create_dir(dir.join("out")).unwrap();
    std::fs::write(dir.join("out/notes.txt"), "a user's notes\n").unwrap();
    let before = snapshot(&dir);
    let (code, err, _) = run(row, &dir, "out", &[]);
    let after = snapshot(&dir);
    if code != Some(0) {
        check("user-folder (refused)", changes(&before, &after, &[]));
    } else {
        let notes = before
            .iter()
            .filter(|(p, _)| p.starts_with(dir.join("out/notes.txt")))
            .filter(|(p, id)| after.get(*p) != Some(id))
            .map(|(p, _)| format!("changed {}", p.display()))
            .collect();
        check("user-folder (written beside)", notes);
    }
    check("user-folder", strays(&dir));
    if err.contains("panicked") {
        check("user-folder", vec![err]);
    }

    // Links named as soig's files to a user's file outside; the output itself a link.
    let dir = case(fixture, root, &format!("{}-symlinks", row.verb));
    std::fs::write(dir.join("victim.txt"), "the user's\n").unwrap();
    std::fs::create_dir(dir.join("out")).unwrap();
    for name in [
        "manifest.json",
        "submit.sh",
        "shards.yaml",
        "tables.md",
        "summary.md",
        "study.csv",
        "detections.json",
        "timing.json",
        "experiment.json",
        ".soig-launch.json",
    ] {
        std::os::unix::fs::symlink("../victim.txt", dir.join("out").join(name)).unwrap();
    }
    std::fs::create_dir(dir.join("elsewhere")).unwrap();
    std::fs::write(dir.join("elsewhere/notes.txt"), "a user's notes\n").unwrap();
    std::os::unix::fs::symlink("elsewhere", dir.join("link")).unwrap();
    for out in ["out", "link"] {
        let before = snapshot(&dir);
        let (code, err, _) = run(row, &dir, out, &[]);
        let after = snapshot(&dir);
        let keep = [
            dir.join("victim.txt"),
            dir.join("elsewhere/notes.txt"),
            dir.join("link"),
        ];
        let lost: Vec<String> = keep
            .iter()
            .filter(|p| before.get(*p) != after.get(*p))
            .map(|p| format!("changed {}", p.display()))
            .collect();
        check(&format!("symlinks --out {out}"), lost);
        if code != Some(0) {
            check(
                &format!("symlinks --out {out} (refused)"),
                changes(&before, &after, &[]),
            );
        }
        check(&format!("symlinks --out {out}"), strays(&dir));
        if err.contains("panicked") {
            check("symlinks", vec![err]);
        }
    }

    // A FIFO input.
    let dir = case(fixture, root, &format!("{}-fifo", row.verb));
    let _ = std::fs::remove_file(dir.join(row.fifo));
    let ok = Command::new("mkfifo")
        .arg(dir.join(row.fifo))
        .status()
        .unwrap()
        .success();
    assert!(ok);
    let before = snapshot(&dir);
    let (code, err, hung) = run(row, &dir, "out", &[]);
    if hung {
        check("fifo", vec![format!("still running after 30 s: {err}")]);
    } else if code == Some(0) {
        check("fifo", vec!["exit 0".into()]);
    }
    check("fifo", changes(&before, &snapshot(&dir), &[]));

    full_disk(row, fixture, root, &mut check);
    kill_then_again(row, fixture, root, &mut check);
    problems
}

/// A full disk: a 16 MiB tmpfs, filled, holds the output (needs root to mount).
fn full_disk(row: &Row, fixture: &Path, root: &Path, check: &mut impl FnMut(&str, Vec<String>)) {
    if nix_is_root() {
        let dir = case(fixture, root, &format!("{}-full-disk", row.verb));
        let vol = dir.join("vol");
        std::fs::create_dir(&vol).unwrap();
        let mounted = Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=16m", "tmpfs"])
            .arg(&vol)
            .status()
            .is_ok_and(|s| s.success());
        if mounted {
            std::fs::write(vol.join("notes.txt"), "a user's notes\n").unwrap();
            {
                use std::io::Write;
                let mut f = std::fs::File::create(vol.join("zeros")).unwrap();
                let zeros = vec![0u8; 1 << 16];
                while f.write_all(&zeros).is_ok() {}
            }
            let before = snapshot(&dir);
            let (code, err, hung) = run(row, &dir, "vol/out", &[]);
            let after = snapshot(&dir);
            let _ = Command::new("umount").arg(&vol).status();
            if hung || code == Some(0) || code.is_none() {
                check(
                    "full-disk",
                    vec![format!("exit {code:?} (hung: {hung}): {err}")],
                );
            }
            let touched = [vol.clone(), vol.join("out")];
            check("full-disk", changes(&before, &after, &touched));
            check("full-disk", strays_in(&after));
        } else {
            eprintln!("{}: full-disk skipped: cannot mount a tmpfs", row.verb);
        }
    } else {
        eprintln!(
            "{}: full-disk skipped: mounting a tmpfs needs root",
            row.verb
        );
    }
}

/// Killed just before the output moves into place, or between a file's temporary and its
/// rename, then run again.
fn kill_then_again(
    row: &Row,
    fixture: &Path,
    root: &Path,
    check: &mut impl FnMut(&str, Vec<String>),
) {
    for phase in ["rename", "write"] {
        let what = format!("kill at {phase}");
        let dir = case(fixture, root, &format!("{}-kill-{phase}", row.verb));
        std::fs::write(dir.join("notes.txt"), "a user's notes\n").unwrap();
        let notes = snapshot(&dir).get(&dir.join("notes.txt")).cloned().unwrap();
        let (_, err, hung) = run(row, &dir, "out", &[("SOIG_TEST_ABORT_AT", phase)]);
        if hung {
            check(&what, vec![format!("still running after 30 s: {err}")]);
        }
        let (code, err, _) = run(row, &dir, "out", &[]);
        if row.finishes && code != Some(0) {
            check(&what, vec![format!("then again: exit {code:?}: {err}")]);
        }
        check(&format!("{what}, then again"), strays(&dir));
        if snapshot(&dir).get(&dir.join("notes.txt")) != Some(&notes) {
            check(&what, vec!["changed notes.txt".into()]);
        }
    }
}

#[test]
fn every_writer_keeps_the_users_files() {
    let tmp = tempfile::tempdir().unwrap();
    let fix = tmp.path().join("fixture");
    std::fs::create_dir(&fix).unwrap();
    fixture(&fix);
    let mut failures = Vec::new();
    std::thread::scope(|s| {
        let handles: Vec<_> = WRITERS
            .chunks(WRITERS.len().div_ceil(2))
            .map(|rows| {
                let (fix, root) = (&fix, tmp.path());
                s.spawn(move || {
                    rows.iter()
                        .flat_map(|row| {
                            attack(row, fix, root)
                                .into_iter()
                                .map(move |p| format!("{}: {p}", row.verb))
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            failures.extend(h.join().unwrap());
        }
    });
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}
