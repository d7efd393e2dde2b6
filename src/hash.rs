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
    let f = std::fs::File::open(path)?;
    let mut h = Sha256::new();
    let bytes = std::io::copy(&mut std::io::BufReader::with_capacity(1 << 20, f), &mut h)?;
    Ok((hex(&h.finalize()), bytes))
}
