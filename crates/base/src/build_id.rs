//! The build identity: sha256 of the file soig's code runs from (the `soig` executable, or
//! the Python extension module inside an interpreter). The version string stays `0.1.0`
//! across every rebuild, so a resumed run or a merge compares this instead: a staging
//! directory or shard written by another build is refused, not mixed into one output.

use std::path::PathBuf;
use std::sync::OnceLock;

/// sha256 of [`code_file`] (hashed once, ~0.2 s for the 67 MB release binary), or `unknown`
/// if it cannot be read. `SOIG_TEST_BUILD_ID` replaces it, for the tests of a rebuilt binary
/// only.
pub fn identity() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        if let Ok(id) = std::env::var("SOIG_TEST_BUILD_ID") {
            return id;
        }
        crate::hash::sha256_file(&code_file()).map_or_else(|_| "unknown".into(), |(sha, _)| sha)
    })
}

/// The file this code was loaded from: the mapping of `/proc/self/maps` that holds this very
/// function. In the `soig` command it is the executable; in Python it is soig's extension
/// module, not the interpreter (`/proc/self/exe`), so a module rebuilt and reinstalled under
/// the same interpreter is another build. A file replaced since it was loaded is read through
/// its mapping (`/proc/self/map_files`); without `/proc/self/maps`, `/proc/self/exe`.
pub fn code_file() -> PathBuf {
    let here = code_file as fn() -> PathBuf as usize;
    let maps = std::fs::read_to_string("/proc/self/maps").unwrap_or_default();
    for line in maps.lines() {
        let mut fields = line.split_whitespace();
        let Some((lo, hi)) = fields.next().and_then(|r| r.split_once('-')) else {
            continue;
        };
        let (Ok(a), Ok(b)) = (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16)) else {
            continue;
        };
        if !(a..b).contains(&here) {
            continue;
        }
        let path = fields.skip(4).collect::<Vec<_>>().join(" ");
        if path.ends_with(" (deleted)") || !path.starts_with('/') {
            return PathBuf::from(format!("/proc/self/map_files/{lo}-{hi}"));
        }
        return PathBuf::from(path);
    }
    PathBuf::from("/proc/self/exe")
}

#[cfg(test)]
mod tests {
    /// In a test binary the code is in the executable itself.
    #[test]
    fn the_code_file_of_an_executable_is_the_executable() {
        let exe = std::fs::canonicalize("/proc/self/exe").unwrap();
        assert_eq!(std::fs::canonicalize(super::code_file()).unwrap(), exe);
    }
}
