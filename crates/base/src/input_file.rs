//! The files a user names (campaigns, their bases, TLE files, models) are read only if they are
//! regular files of a sane size: a device such as `/dev/zero`, a FIFO or a socket would hang
//! soig or fill its memory, so it fails at once. Messages leave naming the path to the caller.

use std::path::Path;

/// Most bytes of a text input (a campaign, a base, a TLE file): a whole public TLE catalogue is
/// about 5 MB and a campaign a few kB, so a larger file is not one of them.
pub const MAX_TEXT_BYTES: u64 = 256 << 20;

/// The size of `path` (links followed) if it is a regular file, else why it is not.
pub fn regular(path: &Path) -> Result<u64, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot read it: {e}"))?;
    if meta.is_dir() {
        return Err("a directory, not a file".into());
    }
    if !meta.is_file() {
        return Err("not a regular file (a device, FIFO or socket)".into());
    }
    Ok(meta.len())
}

/// The text of `path`, a regular file of at most `MAX_TEXT_BYTES`.
pub fn read_text(path: &Path) -> Result<String, String> {
    let len = regular(path)?;
    if len > MAX_TEXT_BYTES {
        return Err(format!(
            "{len} bytes, more than the {MAX_TEXT_BYTES} a campaign or TLE file may hold"
        ));
    }
    std::fs::read_to_string(path).map_err(|e| format!("cannot read it: {e}"))
}
