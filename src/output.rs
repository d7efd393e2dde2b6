//! Output directories written whole or not at all, and never at the cost of a user's files.
//!
//! A run fills a hidden staging directory `.NAME.partial-PID` beside its output and moves it
//! into place only when it succeeded. Before anything is written:
//!
//! - the output must not be `/`, the current directory, an input's folder (the campaign's, a
//!   frame's) or an ancestor of any of them (`name = ".."`, `output = "new/.."` and `--out .`
//!   resolve to those);
//! - an existing output is replaced only if it is empty or holds a manifest that soig wrote and
//!   that parses as one (another tool's `manifest.json` does not count);
//! - a lock `.NAME.lock` (holding the writer's PID) keeps two runs from writing one output: the
//!   second is refused while the first lives, and takes over a lock whose process is gone;
//! - staging directories left by runs that were killed (`kill -9`, a lost machine) are removed,
//!   or, by [`write_resumable`], the one that its caller can resume is taken over (see
//!   `journal`).
//!
//! On Ctrl-C or SIGTERM the command line calls [`interrupt`], which removes this process's locks
//! and its staging directories, but keeps a resumable one for the next run.

use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, bail};

use crate::manifest::Manifest;

/// Staging directories (with whether they are resumable) and locks (false) of this process,
/// handled by [`interrupt`].
static IN_PROGRESS: Mutex<Vec<(PathBuf, bool)>> = Mutex::new(Vec::new());

/// How a writer resumes the work of a run that was killed.
pub struct Resume<'a> {
    /// Whether a staging directory left by a dead process is one this writer can resume.
    pub matches: &'a (dyn Fn(&Path) -> bool + Sync),
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
    if target.exists() {
        let empty = target.is_dir() && std::fs::read_dir(&target)?.next().is_none();
        if !empty && !is_soig_output(&target) {
            bail!(
                "{} exists and is not a soig output (no manifest that soig wrote); refusing to overwrite it",
                output.display()
            );
        }
    }
    let name = target
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .context("an output directory needs a name")?;
    let parent = target
        .parent()
        .context("an output directory needs a parent")?;
    std::fs::create_dir_all(parent)
        .with_context(|| format!("cannot create {}", parent.display()))?;

    let lock = Lock::take(parent, &name, output)?;
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    let resumed = take_stale_staging(parent, &name, resume);
    if staging.exists() {
        std::fs::remove_dir_all(&staging)?;
    }
    if let Some(old) = resumed {
        std::fs::rename(&old, &staging).with_context(|| {
            format!(
                "cannot take over {} as {}",
                old.display(),
                staging.display()
            )
        })?;
    }
    register(&staging, resume.is_some());
    let result = match write(&staging) {
        Ok(value) => {
            if target.exists() {
                std::fs::remove_dir_all(&target)
                    .with_context(|| format!("cannot replace {}", output.display()))?;
            }
            crate::journal::abort_if_testing("rename");
            std::fs::rename(&staging, &target).with_context(|| {
                format!("cannot move {} to {}", staging.display(), output.display())
            })?;
            Ok(value)
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            Err(e)
        }
    };
    unregister(&staging);
    drop(lock);
    result
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
            let _ = std::fs::remove_dir_all(&p);
        } else {
            let _ = std::fs::remove_file(&p);
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
fn resolve(output: &Path) -> anyhow::Result<PathBuf> {
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
            protected.push((p, "an input's folder (the campaign's, a frame's)"));
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

/// Whether a process with this PID runs on this machine.
fn alive(pid: u32) -> bool {
    Path::new("/proc").join(pid.to_string()).exists()
}

/// The staging directories `.NAME.partial-PID` whose process is gone: the one with the most
/// work that `resume` matches is returned, the others removed (and said so, when resuming).
fn take_stale_staging(parent: &Path, name: &str, resume: Option<&Resume>) -> Option<PathBuf> {
    let prefix = format!(".{name}.partial-");
    let Ok(entries) = std::fs::read_dir(parent) else {
        return None;
    };
    let stale: Vec<PathBuf> = entries
        .flatten()
        .filter(|entry| {
            let file = entry.file_name().to_string_lossy().into_owned();
            file.strip_prefix(&prefix)
                .and_then(|p| p.parse::<u32>().ok())
                .is_some_and(|pid| pid != std::process::id() && !alive(pid))
        })
        .map(|entry| entry.path())
        .collect();
    let size = |p: &PathBuf| crate::manifest::list_files(p).map_or(0, |f| f.len());
    let chosen = resume.and_then(|r| {
        stale
            .iter()
            .filter(|p| (r.matches)(p))
            .max_by_key(|p| size(p))
            .cloned()
    });
    for p in stale.iter().filter(|p| Some(*p) != chosen.as_ref()) {
        let _ = std::fs::remove_dir_all(p);
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
    chosen
}

/// The lock of an output directory, released when dropped.
struct Lock(PathBuf);

impl Lock {
    fn take(parent: &Path, name: &str, output: &Path) -> anyhow::Result<Lock> {
        use std::io::Write;
        let path = parent.join(format!(".{name}.lock"));
        // Two tries: the second after removing a lock whose process is gone.
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    write!(f, "{}", std::process::id())
                        .with_context(|| format!("cannot write {}", path.display()))?;
                    register(&path, false);
                    return Ok(Lock(path));
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let holder = std::fs::read_to_string(&path)
                        .ok()
                        .and_then(|t| t.trim().parse::<u32>().ok());
                    // A lock without a PID yet is being taken right now.
                    let fresh = std::fs::metadata(&path)
                        .and_then(|m| m.modified())
                        .is_ok_and(|t| t.elapsed().is_ok_and(|age| age.as_secs() < 5));
                    match holder {
                        None if fresh => bail!(
                            "{} is being written by another soig run (lock {}): wait for it to finish",
                            output.display(),
                            path.display()
                        ),
                        Some(pid) if alive(pid) => bail!(
                            "{} is being written by another soig run (pid {pid}, lock {}): wait for it to finish",
                            output.display(),
                            path.display()
                        ),
                        _ => {
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(e) => {
                    return Err(e).with_context(|| format!("cannot create {}", path.display()));
                }
            }
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
        unregister(&self.0);
        let _ = std::fs::remove_file(&self.0);
    }
}
