//! Output directories written whole or not at all, and never at the cost of a user's files.
//!
//! A run fills a hidden staging directory `.NAME.partial-PID` beside its output and moves it
//! into place only when it succeeded. Before anything is written:
//!
//! - the output must not be `/`, the current directory, an input (the campaign, a frame, a
//!   catalogue, a model, starting weights) or its folder, or an ancestor of any of them
//!   (`name = ".."`, `output = "new/.."` and `--out .` resolve to those);
//! - the output must not lie inside another soig output (a rerun of that one would delete it);
//! - an existing output is replaced only if it is empty or it is a soig output whose every file
//!   its own manifest lists (another tool's `manifest.json`, or a user's file added to a soig
//!   output, makes it foreign), and not a mount point (a volume cannot be renamed: the run is
//!   refused and told to write into a folder inside it);
//! - the replacement is whole or nothing: the old output is moved aside (`.NAME.old-PID`), the
//!   new one moved in, and only then the old one deleted; a failed move puts the old one back,
//!   and a run killed between the two moves gets it back at the next run;
//! - a lock `.NAME.lock` keeps two runs from writing one output. It is an `flock` on that file,
//!   which the kernel releases when its holder dies however it dies, and which holds across PID
//!   namespaces (containers, a pod's PID 1) and, on NFS, across nodes; the file records the
//!   holder's PID, host name, boot id and PID namespace for the message;
//! - whoever holds the lock owns every staging directory of the output: those left by runs that
//!   were killed (`kill -9`, a lost node, a pod's PID 1 whose retry is PID 1 again) are removed,
//!   or, by [`write_resumable`], the one that its caller can resume is taken over (see
//!   `journal`).
//!
//! On Ctrl-C or SIGTERM the command line calls [`interrupt`], which removes this process's locks
//! and its staging directories, but keeps a resumable one for the next run.

use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, bail};

use super::fs;
use crate::manifest::{MANIFEST, Manifest};

/// Staging directories (with whether they are resumable) and locks (false) of this process,
/// handled by [`interrupt`].
static IN_PROGRESS: Mutex<Vec<(PathBuf, bool)>> = Mutex::new(Vec::new());

/// How a writer resumes the work of a run that was killed.
pub struct Resume<'a> {
    /// Whether a staging directory left by a dead process is one this writer can resume; an
    /// error (nothing removed) when it must be neither resumed nor discarded.
    pub matches: &'a (dyn Fn(&Path) -> anyhow::Result<bool> + Sync),
    /// Says what was resumed or removed.
    pub note: &'a dyn Fn(&str),
}

/// Write a soig output directory whole or not at all: `write` fills a hidden staging directory
/// beside `output`, which replaces `output` only when it succeeds and is deleted when it fails.
/// `keep` lists folders (the campaign's) that the output may not be or contain.
pub fn write_replacing<T>(
    output: &Path,
    keep: &[&Path],
    write: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    write_staged(output, keep, None, write)
}

/// [`write_replacing`], resuming: a staging directory of this output left by a process that is
/// gone, and that `resume` matches, becomes this run's staging directory (the others are
/// removed, and said so); an interrupt (not a failure) leaves this run's staging directory for
/// the next run to resume.
pub fn write_resumable<T>(
    output: &Path,
    keep: &[&Path],
    resume: &Resume,
    write: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    write_staged(output, keep, Some(resume), write)
}

fn write_staged<T>(
    output: &Path,
    keep: &[&Path],
    resume: Option<&Resume>,
    write: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    let target = resolve(output)?;
    refuse_protected(output, &target, keep)?;
    refuse_inside_output(output, &target)?;
    let name = target
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .context("an output directory needs a name")?;
    let parent = target
        .parent()
        .context("an output directory needs a parent")?;
    // Refused before anything is made (no lock, no folder beside a user's files), and again
    // under the lock, which may have put back an old output a killed run had moved aside.
    let exists = |t: &Path| std::fs::symlink_metadata(t).is_ok();
    if exists(&target) {
        check_replaceable(output, &target)?;
    }
    fs::create_dir_all(parent)?;

    let lock = Lock::take(parent, &name, output)?;
    restore_set_aside(parent, &name, &target, resume);
    if exists(&target) {
        check_replaceable(output, &target)?;
    }
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    let resumed = take_stale_staging(parent, &name, resume)?;
    match resumed {
        Some(old) if old != staging => fs::rename(&old, &staging)
            .with_context(|| format!("cannot take over {}", old.display()))?,
        _ => {}
    }
    register(&staging, resume.is_some());
    let cleanup = OnPanic {
        staging: &staging,
        remove: resume.is_none(),
    };
    let result = match write(&staging) {
        Ok(value) => put_in_place(&staging, &target, output, &name).map(|()| value),
        // Stopped by the user (Python's Ctrl-C): the staging stays to be resumed, as a kill
        // leaves it.
        Err(e) if resume.is_some() && e.is::<crate::progress::Interrupted>() => Err(e),
        Err(e) => {
            let _ = fs::remove_dir_all(&staging);
            Err(e)
        }
    };
    drop(cleanup);
    unregister(&staging);
    drop(lock);
    result
}

/// What a panic in a writer (a bug) leaves: nothing of a one-shot output (its staging directory
/// is removed as the panic unwinds, as a failure's is), and a resumable run's staging directory
/// for the next run to resume, as a kill leaves it.
struct OnPanic<'a> {
    staging: &'a Path,
    remove: bool,
}

impl Drop for OnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            if self.remove {
                let _ = fs::remove_dir_all(self.staging);
            }
            unregister(self.staging);
        }
    }
}

/// Move the finished `staging` directory to `target`, whole or not at all: an old output is
/// first moved aside, and moved back if the new one cannot take its place.
fn put_in_place(staging: &Path, target: &Path, output: &Path, name: &str) -> anyhow::Result<()> {
    if std::fs::symlink_metadata(target).is_err() {
        crate::journal::abort_if_testing("rename");
        return fs::rename(staging, target);
    }
    let aside = target.with_file_name(format!(".{name}.old-{}", std::process::id()));
    fs::rename(target, &aside).with_context(|| {
        format!(
            "cannot move the old {} aside (nothing was replaced; the new output is left in {})",
            output.display(),
            staging.display()
        )
    })?;
    crate::journal::abort_if_testing("rename");
    if let Err(e) = fs::rename(staging, target) {
        let restored = fs::rename(&aside, target).is_ok();
        let _ = fs::remove_dir_all(staging);
        bail!(
            "{e:#}; {}",
            if restored {
                "the old output is back in place".to_string()
            } else {
                format!("the old output is kept in {}", aside.display())
            }
        );
    }
    fs::remove_dir_all(&aside).context("cannot remove the old output")
}

/// An old output `.NAME.old-PID` left by a run killed while it replaced `target`: put back when
/// `target` is missing (the next run replaces it again, whole), else removed (the new output
/// took its place). Only soig outputs are touched.
fn restore_set_aside(parent: &Path, name: &str, target: &Path, resume: Option<&Resume>) {
    let prefix = format!(".{name}.old-");
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let path = e.path();
        let ours = e.file_name().to_string_lossy().starts_with(&prefix)
            && e.file_type().is_ok_and(|t| t.is_dir())
            && is_soig_output(&path);
        if !ours {
            continue;
        }
        let message = if std::fs::symlink_metadata(target).is_err() {
            match fs::rename(&path, target) {
                Ok(()) => format!(
                    "put back the old output {} that a killed run had moved aside",
                    target.display()
                ),
                Err(_) => continue,
            }
        } else {
            let _ = fs::remove_dir_all(&path);
            format!(
                "removed {}, an old output a killed run had already replaced",
                path.display()
            )
        };
        if let Some(r) = resume {
            (r.note)(&message);
        }
    }
}

/// Refuse to replace `target` unless it is an empty folder, or a soig output whose manifest
/// lists every file in it, and is not a mount point.
fn check_replaceable(output: &Path, target: &Path) -> anyhow::Result<()> {
    let meta = std::fs::symlink_metadata(target)
        .with_context(|| format!("cannot read {}", output.display()))?;
    if !meta.is_dir() {
        bail!(
            "{} exists and is not a folder; refusing to overwrite it",
            output.display()
        );
    }
    if is_mount_point(target) {
        bail!(
            "{} is a mount point (a volume): soig replaces an output by renaming it, which a mount point cannot be; write into a folder inside it (e.g. --out {}/run)",
            output.display(),
            output.display()
        );
    }
    if std::fs::read_dir(target)?.next().is_none() {
        return Ok(());
    }
    let m = match Manifest::read(target) {
        Ok(m) if m.tool == "soig" => m,
        _ => bail!(
            "{} exists and is not a soig output (no manifest that soig wrote); refusing to overwrite it",
            output.display()
        ),
    };
    let foreign =
        foreign_files(target, &m).with_context(|| format!("cannot list {}", output.display()))?;
    if let Some(first) = foreign.first() {
        bail!(
            "{} holds {} file(s) that its manifest does not list (e.g. {first}): they are not soig's; refusing to replace it (move them out, or choose another output)",
            output.display(),
            foreign.len()
        );
    }
    Ok(())
}

/// The files under `dir` that its manifest `m` neither lists nor names volatile.
pub fn foreign_files(dir: &Path, m: &Manifest) -> std::io::Result<Vec<String>> {
    Ok(crate::manifest::list_all_files(dir)?
        .into_iter()
        .filter(|rel| rel != MANIFEST && !m.files.contains_key(rel) && !m.volatile.contains(rel))
        .collect())
}

/// Whether `dir` is a mount point: on another device than its parent, or listed in this
/// process's mount table (a bind mount of the same device).
fn is_mount_point(dir: &Path) -> bool {
    let parent = dir.parent().unwrap_or(dir);
    let differs = match (std::fs::metadata(dir), std::fs::metadata(parent)) {
        (Ok(a), Ok(b)) => a.dev() != b.dev(),
        _ => false,
    };
    differs
        || std::fs::read_to_string("/proc/self/mountinfo").is_ok_and(|t| {
            t.lines()
                .filter_map(|l| l.split(' ').nth(4))
                .any(|m| Path::new(&unescape_mountinfo(m)) == dir)
        })
}

/// A mount point as /proc/self/mountinfo writes it: space, tab, newline and backslash as
/// three octal digits after a backslash.
fn unescape_mountinfo(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'\\'
            && i + 3 < b.len()
            && let Some(v) = std::str::from_utf8(&b[i + 1..i + 4])
                .ok()
                .and_then(|d| u8::from_str_radix(d, 8).ok())
        {
            out.push(v);
            i += 4;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Refuse an output inside another soig output: replacing or rerunning that one would delete
/// it (`soig merge --out SHARD/merged`).
fn refuse_inside_output(output: &Path, target: &Path) -> anyhow::Result<()> {
    for a in target.ancestors().skip(1) {
        if a.join(MANIFEST).is_file() && is_soig_output(a) {
            bail!(
                "refusing to write {}: it lies inside the soig output {}, which a rerun of that output would delete; choose a folder outside it",
                output.display(),
                a.display()
            );
        }
    }
    Ok(())
}

/// Refuse `output` as a folder to write into in place (`soig experiment`, `slurm`, `k8s`) if it
/// is `/`, the current directory, one of `keep` or an ancestor, or lies inside a soig output.
pub fn check_folder(output: &Path, keep: &[&Path]) -> anyhow::Result<()> {
    let target = resolve(output)?;
    refuse_protected(output, &target, keep)?;
    refuse_inside_output(output, &target)
}

/// On Ctrl-C or SIGTERM: remove this process's locks and staging directories but the
/// resumable ones, which are returned (the next run of the same command resumes them).
pub fn interrupt() -> Vec<PathBuf> {
    let paths = std::mem::take(&mut *IN_PROGRESS.lock().unwrap_or_else(|e| e.into_inner()));
    let mut kept = Vec::new();
    for (p, resumable) in paths {
        if resumable {
            // Gone when the signal came after the move into place.
            if p.is_dir() {
                kept.push(p);
            }
        } else if p.is_dir() {
            let _ = fs::remove_dir_all(&p);
        } else {
            let _ = fs::remove_file(&p);
        }
    }
    kept
}

fn register(path: &Path, resumable: bool) {
    IN_PROGRESS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((path.to_path_buf(), resumable));
}

fn unregister(path: &Path) {
    IN_PROGRESS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .retain(|(p, _)| p != path);
}

/// The absolute path of `output`, `.` and `..` taken literally (so `new/..` is the folder
/// holding `new`, whether or not `new` exists), with the symbolic links of its existing part
/// resolved.
pub fn resolve(output: &Path) -> anyhow::Result<PathBuf> {
    let absolute = std::path::absolute(output)
        .with_context(|| format!("cannot resolve {}", output.display()))?;
    let mut lexical = PathBuf::new();
    for c in absolute.components() {
        match c {
            Component::ParentDir => {
                lexical.pop();
            }
            Component::CurDir => {}
            other => lexical.push(other),
        }
    }
    // The longest existing ancestor, with its links resolved, then the rest as written.
    let mut existing = lexical.clone();
    let mut rest = Vec::new();
    while !existing.exists() {
        match existing.file_name() {
            Some(n) => rest.push(n.to_os_string()),
            None => break,
        }
        existing.pop();
    }
    let mut resolved = existing.canonicalize().unwrap_or(existing);
    for n in rest.into_iter().rev() {
        resolved.push(n);
    }
    Ok(resolved)
}

/// The folders holding `inputs` (as their real paths): the `keep` of a command that writes
/// an output from them, which that output may not be or contain.
pub fn input_folders(inputs: &[PathBuf]) -> Vec<PathBuf> {
    inputs
        .iter()
        .filter_map(|p| {
            std::fs::canonicalize(p)
                .ok()?
                .parent()
                .map(Path::to_path_buf)
        })
        .collect()
}

/// Refuse `/`, the current directory, the `keep` folders and their ancestors.
fn refuse_protected(output: &Path, target: &Path, keep: &[&Path]) -> anyhow::Result<()> {
    let mut protected: Vec<(PathBuf, &str)> = vec![(PathBuf::from("/"), "the root directory")];
    if let Ok(cwd) = std::env::current_dir() {
        protected.push((cwd.canonicalize().unwrap_or(cwd), "the current directory"));
    }
    for k in keep {
        if let Ok(p) = resolve(k) {
            protected.push((
                p,
                "an input (the campaign, a frame, a catalogue, a model, starting weights) or its folder",
            ));
        }
    }
    for (p, what) in &protected {
        if p.starts_with(target) {
            let relation = if p == target { "is" } else { "contains" };
            bail!(
                "refusing to write {}: it {relation} {what} ({}); choose another output directory",
                output.display(),
                p.display()
            );
        }
    }
    Ok(())
}

/// An output of soig: its manifest parses as soig's and names soig.
fn is_soig_output(dir: &Path) -> bool {
    Manifest::read(dir).is_ok_and(|m| m.tool == "soig")
}

/// The staging directories `.NAME.partial-*`, all left by runs that are gone (the caller holds
/// the output's lock, so no live run writes one): the one with the most work that `resume`
/// matches is returned, the others removed (and said so, when resuming).
fn take_stale_staging(
    parent: &Path,
    name: &str,
    resume: Option<&Resume>,
) -> anyhow::Result<Option<PathBuf>> {
    let prefix = format!(".{name}.partial-");
    let Ok(entries) = std::fs::read_dir(parent) else {
        return Ok(None);
    };
    let stale: Vec<PathBuf> = entries
        .flatten()
        .filter(|e| {
            e.file_name().to_string_lossy().starts_with(&prefix)
                && e.file_type().is_ok_and(|t| t.is_dir())
        })
        .map(|e| e.path())
        .collect();
    let size = |p: &PathBuf| crate::manifest::list_files(p).map_or(0, |f| f.len());
    let mut matching = Vec::new();
    if let Some(r) = resume {
        for p in &stale {
            if (r.matches)(p)? {
                matching.push(p.clone());
            }
        }
    }
    let chosen = matching.into_iter().max_by_key(size);
    for p in stale.iter().filter(|p| Some(*p) != chosen.as_ref()) {
        let _ = fs::remove_dir_all(p);
        if let Some(r) = resume {
            (r.note)(&format!(
                "removed {}, left by a soig process that is gone, which this run cannot resume",
                p.display()
            ));
        }
    }
    if let (Some(p), Some(r)) = (&chosen, resume) {
        (r.note)(&format!(
            "resuming the run killed earlier, from {} ({} files)",
            p.display(),
            size(p)
        ));
    }
    Ok(chosen)
}

/// Open `path` for reading and writing, created if missing, refusing anything but a regular
/// file (a FIFO would block, a link could point anywhere).
#[allow(clippy::disallowed_methods)] // the store's lock file: opened with its own flags
fn open_lock_file(path: &Path) -> std::io::Result<std::fs::File> {
    let f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .custom_flags(nix::libc::O_NONBLOCK | nix::libc::O_NOFOLLOW)
        .open(path)?;
    if !f.metadata()?.is_file() {
        return Err(std::io::Error::other("not a regular file"));
    }
    Ok(f)
}

/// Who holds a lock: PID, host name, boot id and PID namespace, so that a PID of another
/// machine or container is never mistaken for one of this one.
fn holder() -> String {
    let read =
        |p: &str| std::fs::read_to_string(p).map_or_else(|_| "?".into(), |t| t.trim().to_string());
    let pidns = std::fs::read_link("/proc/self/ns/pid")
        .map_or_else(|_| "?".into(), |l| l.display().to_string());
    format!(
        "pid {} on host {} (boot {}, {pidns})",
        std::process::id(),
        read("/proc/sys/kernel/hostname"),
        read("/proc/sys/kernel/random/boot_id")
    )
}

/// The lock of an output directory: an `flock` on `.NAME.lock`, released when dropped (or
/// by the kernel when the process dies).
struct Lock {
    path: PathBuf,
    _file: std::fs::File,
}

impl Lock {
    fn take(parent: &Path, name: &str, output: &Path) -> anyhow::Result<Lock> {
        use std::io::Write;
        let path = parent.join(format!(".{name}.lock"));
        // A holder removes the file as it lets go: the lock taken must be on the file that is
        // at `path` now, else try again.
        for _ in 0..10 {
            let mut file = open_lock_file(&path).with_context(|| {
                format!(
                    "cannot open the lock {} of {}",
                    path.display(),
                    output.display()
                )
            })?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let who = std::fs::read_to_string(&path).unwrap_or_default();
                    bail!(
                        "{} is being written by another soig run ({}, lock {}): wait for it to finish",
                        output.display(),
                        if who.trim().is_empty() {
                            "starting"
                        } else {
                            who.trim()
                        },
                        path.display()
                    );
                }
                Err(std::fs::TryLockError::Error(e)) => {
                    return Err(e).with_context(|| format!("cannot lock {}", path.display()));
                }
            }
            let same = std::fs::symlink_metadata(&path)
                .ok()
                .zip(file.metadata().ok())
                .is_some_and(|(a, b)| a.ino() == b.ino() && a.dev() == b.dev());
            if !same {
                continue;
            }
            // Who holds it is for the message of a run that waits; on a full disk the lock
            // holds without it (an error here would leave the file behind).
            let _ = file
                .set_len(0)
                .and_then(|()| file.write_all(holder().as_bytes()));
            register(&path, false);
            return Ok(Lock { path, _file: file });
        }
        bail!(
            "cannot take the lock {} of {}",
            path.display(),
            output.display()
        )
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        unregister(&self.path);
        let _ = fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer that panics leaves neither an output nor its staging directory, and the lock is
    /// released (a second write of the same output succeeds).
    #[test]
    fn a_panicking_writer_leaves_nothing() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        let panicked = std::panic::catch_unwind(|| {
            write_replacing(&out, &[], |dir| -> anyhow::Result<()> {
                fs::create_dir_all(dir)?;
                fs::create(&dir.join("half.txt"), "half")?;
                panic!("a writer's bug");
            })
        });
        assert!(panicked.is_err(), "{:?}", panicked.as_ref().ok());
        let left: Vec<_> = std::fs::read_dir(tmp.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(left.is_empty(), "left behind: {left:?}");
        write_replacing(&out, &[], |dir| {
            fs::create_dir_all(dir)?;
            fs::create(&dir.join("whole.txt"), "whole")
        })
        .unwrap();
        assert!(out.join("whole.txt").is_file());
    }

    #[test]
    fn mount_points_are_read_with_their_escapes() {
        assert_eq!(
            unescape_mountinfo("/data/My\\040Project"),
            "/data/My Project"
        );
        assert_eq!(unescape_mountinfo("/a\\134b"), "/a\\b");
        assert_eq!(unescape_mountinfo("/trailing\\04"), "/trailing\\04");
    }

    #[test]
    fn a_soig_output_holding_a_users_file_is_not_replaced() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        std::fs::create_dir_all(out.join("truth")).unwrap();
        std::fs::write(out.join("truth/a.json"), "{}").unwrap();
        Manifest::build(&out, "h", serde_json::json!({}), &[])
            .unwrap()
            .write(&out)
            .unwrap();
        check_replaceable(&out, &out).unwrap();
        std::fs::write(out.join("truth/notes.txt"), "mine").unwrap();
        let e = check_replaceable(&out, &out).unwrap_err().to_string();
        assert!(
            e.contains("truth/notes.txt") && e.contains("does not list"),
            "{e}"
        );
    }
}
