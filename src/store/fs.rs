//! The file primitives every writer of soig uses: the only code that creates, replaces or
//! deletes a file or folder (clippy's `disallowed-methods`, see `clippy.toml`, refuses
//! `std::fs`'s elsewhere). Each error names the path.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::Context;

/// Write `bytes` as the whole of file `path`, atomically: a temporary file beside it, synced,
/// renamed over it; on any error (a full disk) the old file is untouched and nothing is left.
pub fn write(path: &Path, bytes: impl AsRef<[u8]>) -> anyhow::Result<()> {
    write_by(path, |temp| fill(temp, bytes.as_ref()))
}

/// [`write`], the file made executable (`rwxr-xr-x`) before it takes its place.
#[allow(clippy::disallowed_methods)] // the store's primitive: the temporary file's mode
pub fn write_executable(path: &Path, bytes: impl AsRef<[u8]>) -> anyhow::Result<()> {
    use std::os::unix::fs::PermissionsExt;
    write_by(path, |temp| {
        fill(temp, bytes.as_ref())?;
        std::fs::set_permissions(temp, std::fs::Permissions::from_mode(0o755))
            .with_context(|| format!("cannot make {} executable", temp.display()))
    })
}

/// [`write`], the temporary file made by `make` from its path (cfitsio writes through its own
/// C code, given a path); its name is `path`'s, hidden and suffixed, so as plain as `path`'s.
pub fn write_by(path: &Path, make: impl FnOnce(&Path) -> anyhow::Result<()>) -> anyhow::Result<()> {
    let temp = temporary(path)?;
    discard_stale_temporaries(path);
    let result = make(&temp).and_then(|()| sync(&temp)).and_then(|()| {
        crate::journal::abort_if_testing("write");
        rename(&temp, path)
    });
    if result.is_err() {
        discard(&temp);
    }
    result.with_context(|| format!("cannot write {}", path.display()))
}

/// Replace the user's file `path` (a README) in place, atomically as [`write`], keeping its
/// permissions; a symbolic link is followed, and the file it names replaced.
#[allow(clippy::disallowed_methods)] // the store's primitive: the temporary file's mode
pub fn replace(path: &Path, bytes: impl AsRef<[u8]>) -> anyhow::Result<()> {
    let real = std::fs::canonicalize(path)
        .with_context(|| format!("cannot resolve {}", path.display()))?;
    let permissions = std::fs::metadata(&real)
        .with_context(|| format!("cannot read {}", real.display()))?
        .permissions();
    write_by(&real, |temp| {
        fill(temp, bytes.as_ref())?;
        std::fs::set_permissions(temp, permissions)
            .with_context(|| format!("cannot set the permissions of {}", temp.display()))
    })
}

/// Write `bytes` as new file `path` inside a folder soig is filling (a staging directory,
/// moved into place whole, so the file is neither synced nor renamed): never over an existing
/// file; on error the partial file is removed.
#[allow(clippy::disallowed_methods)] // the store's primitive: a new file, never an old one
pub fn create(path: &Path, bytes: impl AsRef<[u8]>) -> anyhow::Result<()> {
    let result = std::fs::File::create_new(path).and_then(|mut f| f.write_all(bytes.as_ref()));
    if let Err(e) = result {
        if e.kind() != std::io::ErrorKind::AlreadyExists {
            discard(path);
        }
        return Err(e).with_context(|| format!("cannot write {}", path.display()));
    }
    Ok(())
}

/// Open new file `path` (an old one of soig's is truncated) for a child process's output.
#[allow(clippy::disallowed_methods)] // the store's primitive: a log another process writes
pub fn create_log(path: &Path) -> anyhow::Result<std::fs::File> {
    std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))
}

/// Create folder `path` and its missing ancestors.
#[allow(clippy::disallowed_methods)] // the store's primitive
pub fn create_dir_all(path: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(path).with_context(|| format!("cannot create {}", path.display()))
}

/// Create folder `path` and its missing ancestors; the folders made, outermost first, for
/// [`remove_empty_dirs`] to take back when what was to fill them fails (a full disk).
pub fn create_dirs(path: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let made: Vec<PathBuf> = path
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && std::fs::symlink_metadata(a).is_err())
        .map(Path::to_path_buf)
        .collect();
    create_dir_all(path)?;
    Ok(made.into_iter().rev().collect())
}

/// Remove the folders of `made` ([`create_dirs`]) that hold nothing but empty folders, the
/// innermost first: a writer that failed leaves no empty folder of its own behind.
#[allow(clippy::disallowed_methods)] // the store's primitive: only empty folders soig made
pub fn remove_empty_dirs(made: &[PathBuf]) {
    fn prune(dir: &Path) {
        if let Ok(entries) = std::fs::read_dir(dir) {
            for e in entries.flatten() {
                if e.file_type().is_ok_and(|t| t.is_dir()) {
                    prune(&e.path());
                }
            }
        }
        // Fails, as it should, on a folder that holds anything.
        let _ = std::fs::remove_dir(dir);
    }
    for d in made.iter().rev() {
        prune(d);
    }
}

/// Remove file `path`, which must be soig's (the caller knows it is).
#[allow(clippy::disallowed_methods)] // the store's primitive
pub fn remove_file(path: &Path) -> anyhow::Result<()> {
    std::fs::remove_file(path).with_context(|| format!("cannot remove {}", path.display()))
}

/// Remove folder `path` and all it holds, which must be soig's (the caller knows it is).
#[allow(clippy::disallowed_methods)] // the store's primitive
pub fn remove_dir_all(path: &Path) -> anyhow::Result<()> {
    std::fs::remove_dir_all(path).with_context(|| format!("cannot remove {}", path.display()))
}

/// Move `from` to `to` (same file system), replacing a file `to` (never a non-empty folder).
#[allow(clippy::disallowed_methods)] // the store's primitive
pub fn rename(from: &Path, to: &Path) -> anyhow::Result<()> {
    std::fs::rename(from, to)
        .with_context(|| format!("cannot move {} to {}", from.display(), to.display()))
}

/// Copy file `from` to `to`, atomically as [`write`].
#[allow(clippy::disallowed_methods)] // the store's primitive, into a temporary file
pub fn copy(from: &Path, to: &Path) -> anyhow::Result<()> {
    write_by(to, |temp| {
        std::fs::copy(from, temp)
            .map(drop)
            .with_context(|| format!("cannot copy {} to {}", from.display(), temp.display()))
    })
}

/// Hard-link file `from` as new file `to` (no copy of a large dataset), or copy it where a
/// link cannot be made (another file system).
#[allow(clippy::disallowed_methods)] // the store's primitive: a new name for a file of soig's
pub fn link_or_copy(from: &Path, to: &Path) -> anyhow::Result<()> {
    if std::fs::hard_link(from, to).is_err() {
        copy(from, to)?;
    }
    Ok(())
}

/// Remove what a failed write left at `path`, if anything: the error that made it is the one
/// to report.
fn discard(path: &Path) {
    let _ = remove_file(path);
}

/// Write `bytes` as the new temporary file `temp`.
#[allow(clippy::disallowed_methods)] // the store's primitive: a new file, never an old one
fn fill(temp: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    std::fs::File::create_new(temp)
        .and_then(|mut f| f.write_all(bytes))
        .with_context(|| format!("cannot write {}", temp.display()))
}

/// Flush `path`'s data to the disk, so that a full disk is an error before the rename.
fn sync(path: &Path) -> anyhow::Result<()> {
    crate::hash::open_regular(path)
        .and_then(|f| f.sync_all())
        .with_context(|| format!("cannot sync {}", path.display()))
}

/// Remove the temporary files of `path` ([`temporary`]) that processes which are gone left
/// (killed between the write and the rename): each names its writer's PID, and a PID of no
/// process here is a writer that is gone. One of a live writer (this process's, or any PID
/// that exists) is left alone.
fn discard_stale_temporaries(path: &Path) {
    let (Some(parent), Some(name)) = (path.parent(), path.file_name()) else {
        return;
    };
    let prefix = format!(".{}.tmp-", name.to_string_lossy());
    let parent = if parent.as_os_str().is_empty() {
        Path::new(".")
    } else {
        parent
    };
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let pid = file
            .strip_prefix(&prefix)
            .and_then(|rest| rest.split_once('-'))
            .filter(|(_, n)| n.bytes().all(|b| b.is_ascii_digit()) && !n.is_empty())
            .and_then(|(pid, _)| pid.parse::<u32>().ok());
        let gone = pid
            .is_some_and(|p| p != std::process::id() && !Path::new(&format!("/proc/{p}")).exists());
        if gone && e.file_type().is_ok_and(|t| t.is_file()) {
            discard(&e.path());
        }
    }
}

/// A name for a temporary file beside `path`, unique in this process: `.NAME.tmp-PID-N`.
fn temporary(path: &Path) -> anyhow::Result<PathBuf> {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .with_context(|| format!("{}: not a file name", path.display()))?;
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    Ok(path.with_file_name(format!(
        ".{}.tmp-{}-{n}",
        name.to_string_lossy(),
        std::process::id()
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn names(dir: &Path) -> Vec<String> {
        let mut n: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        n.sort();
        n
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("a.txt");
        write(&path, "old").unwrap();
        let e = write_by(&path, |temp| {
            fill(temp, b"half")?;
            anyhow::bail!("no space left on device")
        })
        .unwrap_err();
        assert!(format!("{e:#}").contains("a.txt"), "{e:#}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(names(tmp.path()), ["a.txt"]);
        write(&path, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(names(tmp.path()), ["a.txt"]);
    }

    #[test]
    fn a_temporary_left_by_a_dead_writer_is_removed_and_a_live_ones_kept() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("submit.sh");
        // PID 0 is never a process of /proc; this process is alive.
        let dead = tmp.path().join(".submit.sh.tmp-0-3");
        let live = tmp
            .path()
            .join(format!(".submit.sh.tmp-{}-99", std::process::id()));
        let other = tmp.path().join(".submit.sh.tmp-notes");
        for p in [&dead, &live, &other] {
            std::fs::write(p, "x").unwrap();
        }
        write(&path, "new").unwrap();
        let mut want = vec![
            "submit.sh".to_string(),
            live.file_name().unwrap().to_string_lossy().into_owned(),
            ".submit.sh.tmp-notes".to_string(),
        ];
        want.sort();
        assert_eq!(names(tmp.path()), want);
    }

    #[test]
    fn create_never_writes_over_a_file() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("mine.txt");
        create(&path, "soig").unwrap();
        assert!(create(&path, "again").is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "soig");
    }

    #[test]
    fn replace_keeps_the_permissions_and_follows_a_link() {
        let tmp = tempfile::tempdir().unwrap();
        let real = tmp.path().join("README.md");
        write(&real, "old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = tmp.path().join("link.md");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        replace(&link, "new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o640);
        assert_eq!(names(tmp.path()), ["README.md", "link.md"]);
    }
}
