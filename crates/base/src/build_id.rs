//! The build identity: sha256 of the running `soig` executable. The version string stays
//! `0.1.0` across every rebuild, so a resumed run or a merge compares this instead: a staging
//! directory or shard written by another build is refused, not mixed into one output.

use std::sync::OnceLock;

/// sha256 of `/proc/self/exe` (hashed once, ~0.2 s for the 67 MB release binary), or
/// `unknown` if it cannot be read. `SOIG_TEST_BUILD_ID` replaces it, for the tests of a
/// rebuilt binary only.
pub fn identity() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        if let Ok(id) = std::env::var("SOIG_TEST_BUILD_ID") {
            return id;
        }
        crate::hash::sha256_file(std::path::Path::new("/proc/self/exe"))
            .map_or_else(|_| "unknown".into(), |(sha, _)| sha)
    })
}
