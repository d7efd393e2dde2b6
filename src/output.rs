//! Output directories written whole or not at all: a run fills a hidden staging directory
//! beside its output and moves it into place only when it succeeded.

use std::path::Path;

use anyhow::Context;

use crate::manifest::MANIFEST;

/// Write a soig output directory whole or not at all: `write` fills a hidden staging directory
/// beside `output`, which replaces `output` only when it succeeds and is deleted when it fails.
/// An existing `output` is replaced only if it is a soig output (it holds a manifest) or empty.
pub fn write_replacing<T>(
    output: &Path,
    write: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    if output.exists() {
        let is_ours = output.join(MANIFEST).is_file();
        let empty = output.is_dir() && std::fs::read_dir(output)?.next().is_none();
        if !is_ours && !empty {
            anyhow::bail!(
                "{} exists and is not a soig output (no {MANIFEST}); refusing to overwrite it",
                output.display()
            );
        }
    }
    let name = output
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "soig-out".into());
    let parent = output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent)
        .with_context(|| format!("cannot create {}", parent.display()))?;
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    if staging.exists() {
        std::fs::remove_dir_all(&staging)?;
    }
    match write(&staging) {
        Ok(value) => {
            if output.exists() {
                std::fs::remove_dir_all(output)
                    .with_context(|| format!("cannot replace {}", output.display()))?;
            }
            std::fs::rename(&staging, output).with_context(|| {
                format!("cannot move {} to {}", staging.display(), output.display())
            })?;
            Ok(value)
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            Err(e)
        }
    }
}
