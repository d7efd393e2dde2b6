//! sha256 helpers shared by the campaign (its hash, the model's digest) and the manifest (every
//! artifact, the run's digest). Hex is lowercase; JSON is hashed in its canonical form.

use std::path::Path;

use serde::Serialize;
use sha2::{Digest, Sha256};

/// sha256 of the canonical (key-sorted, compact) JSON of a value.
pub fn hash_json<T: Serialize>(value: &T) -> String {
    let v = serde_json::to_value(value).expect("campaign serialises");
    let text = serde_json::to_string(&v).expect("json value serialises");
    hex(&Sha256::digest(text.as_bytes()))
}

pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// sha256 of a file and its length in bytes. Read in 1 MiB chunks: `io::copy`'s 8 KiB reads
/// were 1250 system calls for an image's 10 MB of files.
pub fn sha256_file(path: &Path) -> std::io::Result<(String, u64)> {
    let f = open_regular(path)?;
    let mut h = Sha256::new();
    let bytes = std::io::copy(&mut std::io::BufReader::with_capacity(1 << 20, f), &mut h)?;
    Ok((hex(&h.finalize()), bytes))
}

/// Open `path` for reading if it is a regular file (links followed); anything else (a FIFO,
/// which would block `open` and `read` forever, a device, a directory) is an error. The file is
/// opened without blocking and checked before it is read.
pub fn open_regular(path: &Path) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(nix::libc::O_NONBLOCK)
        .open(path)?;
    if !f.metadata()?.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a FIFO, device or folder)",
        ));
    }
    Ok(f)
}

/// Read `path` whole as text, if it is a regular file (see [`open_regular`]).
pub fn read_regular_to_string(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    let mut s = String::new();
    open_regular(path)?.read_to_string(&mut s)?;
    Ok(s)
}
