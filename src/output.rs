//! Output directories written whole or not at all, and never at the cost of a user's files.
//!
//! A run fills a hidden staging directory `.NAME.partial-PID` beside its output and moves it
//! into place only when it succeeded. Before anything is written:
//!
//! - the output must not be `/`, the current directory, the campaign's folder or an ancestor of
//!   any of them (`name = ".."`, `output = "new/.."` and `--out .` resolve to those);
//! - an existing output is replaced only if it is empty or holds a manifest that soig wrote and
//!   that parses as one (another tool's `manifest.json` does not count);
//! - a lock `.NAME.lock` (holding the writer's PID) keeps two runs from writing one output: the
//!   second is refused while the first lives, and takes over a lock whose process is gone;
//! - staging directories left by runs that were killed (`kill -9`, a lost machine) are removed.
//!
//! On Ctrl-C or SIGTERM the command line calls [`abandon`], which removes this process's
//! staging directory and lock.

use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, bail};

use crate::manifest::Manifest;

/// Staging directories and locks of this process, removed by [`abandon`].
static IN_PROGRESS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Write a soig output directory whole or not at all: `write` fills a hidden staging directory
/// beside `output`, which replaces `output` only when it succeeds and is deleted when it fails.
/// `keep` lists folders (the campaign's) that the output may not be or contain.
pub fn write_replacing<T>(
    output: &Path,
    keep: &[&Path],
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
    remove_stale_staging(parent, &name);
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    if staging.exists() {
        std::fs::remove_dir_all(&staging)?;
    }
    register(&staging);
    let result = match write(&staging) {
        Ok(value) => {
            if target.exists() {
                std::fs::remove_dir_all(&target)
                    .with_context(|| format!("cannot replace {}", output.display()))?;
            }
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

/// Remove this process's staging directories and locks (on Ctrl-C or SIGTERM).
pub fn abandon() {
    let paths = std::mem::take(&mut *IN_PROGRESS.lock().unwrap_or_else(|e| e.into_inner()));
    for p in paths {
        if p.is_dir() {
            let _ = std::fs::remove_dir_all(&p);
        } else {
            let _ = std::fs::remove_file(&p);
        }
    }
}

fn register(path: &Path) {
    IN_PROGRESS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(path.to_path_buf());
}

fn unregister(path: &Path) {
    IN_PROGRESS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .retain(|p| p != path);
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

/// Refuse `/`, the current directory, the `keep` folders and their ancestors.
fn refuse_protected(output: &Path, target: &Path, keep: &[&Path]) -> anyhow::Result<()> {
    let mut protected: Vec<(PathBuf, &str)> = vec![(PathBuf::from("/"), "the root directory")];
    if let Ok(cwd) = std::env::current_dir() {
        protected.push((cwd.canonicalize().unwrap_or(cwd), "the current directory"));
    }
    for k in keep {
        if let Ok(p) = resolve(k) {
            protected.push((p, "the campaign's folder"));
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

/// Remove `.NAME.partial-PID` directories whose process is gone.
fn remove_stale_staging(parent: &Path, name: &str) {
    let prefix = format!(".{name}.partial-");
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = file
            .strip_prefix(&prefix)
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !alive(pid) {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
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
                    register(&path);
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
