//! Exports of a run's output for other tools: the dataset and the detect stage's predictions as
//! COCO JSON (`coco`: Detectron2, MMDetection, torchvision, pycocotools), the truth and the
//! detections as DS9 region files over the FITS images (`ds9`), and the truth's observations
//! as a CCSDS Tracking Data Message for orbit determination (`tdm`). Both are read back from the
//! output's own files (labels, predictions, PNG sizes, truth sidecars), so `soig run` (the
//! `artifacts.coco` and `artifacts.ds9_regions` switches) and `soig export` of a finished output
//! write the same bytes.

pub mod ades;
pub mod coco;
pub mod ds9;
pub mod identity;
pub mod tdm;

use std::path::{Path, PathBuf};

use anyhow::Context;

/// Which exports to write.
#[derive(Clone, Copy, Debug)]
pub struct Formats {
    pub coco: bool,
    pub ds9: bool,
    /// The truth's observations as a CCSDS TDM (`tdm`).
    pub tdm: bool,
}

/// The folder, inside a run's output, that its own exports go to.
pub const EXPORT_DIR: &str = "export";

/// A split of the dataset as the output holds it: `train`, `val`, `test`, or `all` when the
/// campaign has no dataset stage (images and labels straight under `images/` and `labels/`).
pub struct Split {
    pub name: &'static str,
    /// Folder of the PNGs and of the label files, relative to the output.
    pub images: String,
    pub labels: String,
}

/// The splits an output holds, in the order train, val, test (or the one `all`).
pub fn splits(output: &Path) -> Vec<Split> {
    let split = |name: &'static str, sub: &str| Split {
        name,
        images: format!("images{sub}"),
        labels: format!("labels{sub}"),
    };
    if output.join("labels/train").is_dir() {
        ["train", "val", "test"]
            .into_iter()
            .map(|s| split(s, &format!("/{s}")))
            .collect()
    } else if output.join("labels").is_dir() {
        vec![split("all", "")]
    } else {
        Vec::new()
    }
}

/// The split the detect stage ran on: test, or every image when there is no split.
pub fn detected_split(splits: &[Split]) -> Option<&Split> {
    splits.iter().find(|s| s.name == "test" || s.name == "all")
}

/// The detectors whose predictions the output holds (`report/predictions/<name>/`), sorted.
pub fn detectors(output: &Path) -> anyhow::Result<Vec<String>> {
    let dir = output.join("report/predictions");
    if !dir.is_dir() {
        return Ok(Vec::new());
    }
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&dir).with_context(|| format!("reading {}", dir.display()))? {
        let entry = entry?;
        if entry.path().is_dir() {
            names.push(entry.file_name().to_string_lossy().into_owned());
        }
    }
    names.sort();
    Ok(names)
}

/// Stems of the `*.<ext>` files of `dir`, sorted.
pub fn stems(dir: &Path, ext: &str) -> anyhow::Result<Vec<String>> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let path = entry?.path();
        if path.is_file()
            && path.extension().and_then(|e| e.to_str()) == Some(ext)
            && let Some(stem) = path.file_stem().and_then(|s| s.to_str())
        {
            out.push(stem.to_string());
        }
    }
    out.sort();
    Ok(out)
}

/// The campaign image index of a soig file stem `img_NNNNNN`.
pub fn image_index(stem: &str, path: &Path) -> anyhow::Result<u64> {
    stem.strip_prefix("img_")
        .and_then(|n| n.parse().ok())
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{}: not a soig image (its name is not img_<index>)",
                path.display()
            )
        })
}

/// Write the chosen exports of the output `output`, made by the resolved `campaign`, into
/// `dest` (created); returns the files written, relative to `dest`.
pub fn write(
    output: &Path,
    campaign: &serde_json::Value,
    dest: &Path,
    formats: Formats,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if formats.coco {
        files.extend(coco::write(output, &dest.join("coco"))?);
    }
    if formats.ds9 {
        files.extend(ds9::write(output, &dest.join("ds9"))?);
    }
    if formats.tdm {
        files.extend(tdm::write(output, campaign, &dest.join("tdm"))?);
    }
    Ok(files
        .into_iter()
        .map(|f| f.strip_prefix(dest).map(Path::to_path_buf).unwrap_or(f))
        .collect())
}

/// The field of an export's manifest (its `campaign`) that names the output it exports: what
/// marks a folder as an export of soig's, which a later export may replace.
pub const EXPORT_OF: &str = "export_of";

/// `soig export`: check that `output` is a soig output whose files match its manifest, then
/// write its exports into `dest`, which must lie outside it (a file added to an output would
/// make it fail `soig verify`). `dest` is written whole or not at all, as a run's output, with
/// a manifest of its own (so `soig verify` checks it), and only where no user's file is: it
/// must not exist, be empty, or be an earlier export (its manifest lists every file in it).
pub fn export_output(output: &Path, dest: &Path, formats: Formats) -> anyhow::Result<Vec<PathBuf>> {
    let (source, problems) = crate::manifest::verify(output)?;
    if let Some(first) = problems.first() {
        anyhow::bail!(
            "{} does not verify ({} problem(s), the first: {first}); export a finished output",
            output.display(),
            problems.len()
        );
    }
    // As the store resolves them: `OUT/../OUT-export` is beside OUT, a link into OUT inside.
    if crate::output::resolve(dest)?.starts_with(crate::output::resolve(output)?) {
        anyhow::bail!(
            "--out {} lies inside the output {}: choose a folder outside it (the output would no longer verify), or set `artifacts.coco` / `artifacts.ds9_regions` in the campaign",
            dest.display(),
            output.display()
        );
    }
    refuse_another_output(dest)?;
    let record = serde_json::json!({
        EXPORT_OF: std::path::absolute(output)?,
        "digest": source.digest,
        "coco": formats.coco,
        "ds9": formats.ds9,
    });
    // An export without TDM records what it recorded before there was one (same hash).
    let mut record = record;
    if formats.tdm {
        record["tdm"] = serde_json::Value::Bool(true);
    }
    crate::output::write_replacing(dest, &[output], |dir| {
        crate::store::fs::create_dir_all(dir)?;
        let files = write(output, &source.campaign, dir, formats)?;
        let hash = crate::hash::hash_json(&record);
        crate::manifest::Manifest::build(dir, &hash, record.clone(), &[])?.write(dir)?;
        Ok(files)
    })
}

/// Refuse to replace a soig output that is not an export (a run's, a study's) with an export;
/// a user's folder is refused by the store.
fn refuse_another_output(dest: &Path) -> anyhow::Result<()> {
    match crate::manifest::Manifest::read(dest) {
        Ok(m) if m.tool == "soig" && m.campaign.get(EXPORT_OF).is_none() => anyhow::bail!(
            "--out {} is a soig output but not an export (a run's or another command's); refusing to replace it with an export: choose another folder",
            dest.display()
        ),
        _ => Ok(()),
    }
}
