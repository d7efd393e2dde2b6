//! The manifest: sha256 of every artifact, the resolved campaign and its hash, the tool version,
//! and one `digest` over all of it. `verify` recomputes everything and names each difference.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::Error;
use crate::hash::{hex, sha256_file};

pub const MANIFEST: &str = "manifest.json";
/// The journal of a run in progress (see `journal`): in a staging directory, and no artifact.
pub const JOURNAL: &str = ".soig-journal.jsonl";

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FileEntry {
    pub sha256: String,
    pub bytes: u64,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Manifest {
    pub tool: String,
    pub version: String,
    pub campaign_hash: String,
    /// The resolved campaign (every default filled in, TLE files replaced by their lines).
    pub campaign: serde_json::Value,
    /// Every artifact, by path relative to the output directory ('/' separated), sorted.
    pub files: BTreeMap<String, FileEntry>,
    /// Files that hold run-dependent figures (timing, training logs): they must exist, but
    /// are not hashed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub volatile: Vec<String>,
    /// The training run (`soig train`): model sha256, Ultralytics and torch versions, log.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub training: Option<serde_json::Value>,
    /// A shard's place in its campaign (`soig run --shard`; see `shard`): index, count, the
    /// images it holds and the campaign's folder. None for a whole campaign.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<serde_json::Value>,
    /// sha256 of each input file the run read (background frames, star catalogue, model), by
    /// its path as the campaign writes it: the campaign hash covers their names, this their
    /// content.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub inputs: BTreeMap<String, String>,
    /// Values the run resolved late from several fields (effective SNR gate, frame size,
    /// training size and batch, PSF in pixels): a function of the resolved campaign and the
    /// tool version, both hashed, so they are recorded but not part of the digest.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effective: Option<serde_json::Value>,
    /// Images per debris object (`pipeline::DebrisCount`): a summary of the truth sidecars,
    /// part of the digest like every other statement of a result.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub debris_mix: Option<serde_json::Value>,
    /// sha256 of the canonical JSON of everything above but `effective`.
    pub digest: String,
}

/// Whether `rel` is the label cache Ultralytics writes beside a split's label folder when it
/// trains on the dataset (`labels/train.cache` for `labels/train/`): derived from the labels, so
/// a dataset trained by plain `yolo train data=OUT/data.yaml` still verifies; the same in the
/// streak-shaped label sets (`obb/labels/train.cache`).
fn is_ultralytics_cache(rel: &str) -> bool {
    let rel = ["obb/", "keypoints/"]
        .iter()
        .find_map(|set| rel.strip_prefix(set))
        .unwrap_or(rel);
    rel.strip_prefix("labels/")
        .and_then(|name| name.strip_suffix(".cache"))
        .is_some_and(|split| !split.is_empty() && !split.contains('/'))
}

/// All files under `dir` except the manifest and a run's journal (a staging directory's), as
/// sorted relative paths.
pub fn list_files(dir: &Path) -> std::io::Result<Vec<String>> {
    Ok(list_all_files(dir)?
        .into_iter()
        .filter(|rel| rel != JOURNAL)
        .collect())
}

/// All files under `dir` except the manifest, as sorted relative paths: what `verify` checks
/// (a finished output holds no journal, so one there is an extra file like any other).
pub fn list_all_files(dir: &Path) -> std::io::Result<Vec<String>> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) -> std::io::Result<()> {
        for entry in std::fs::read_dir(dir)? {
            let entry = entry?;
            let path = entry.path();
            if entry.file_type()?.is_dir() {
                walk(root, &path, out)?;
            } else {
                let rel: PathBuf = path.strip_prefix(root).expect("under root").to_path_buf();
                let rel = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect::<Vec<_>>()
                    .join("/");
                // Ultralytics' label caches are derived from the labels: no artifacts.
                if rel != MANIFEST && !is_ultralytics_cache(&rel) {
                    out.push(rel);
                }
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out)?;
    out.sort();
    Ok(out)
}

fn digest_of(m: &Manifest) -> String {
    let mut v = serde_json::to_value(m).expect("manifest serialises");
    let fields = v.as_object_mut().expect("object");
    fields.remove("digest");
    fields.remove("effective");
    hex(&Sha256::digest(
        serde_json::to_string(&v).expect("json").as_bytes(),
    ))
}

impl Manifest {
    /// Hash every file in `dir` (but the `volatile` ones) and build the manifest.
    pub fn build(
        dir: &Path,
        campaign_hash: &str,
        campaign: serde_json::Value,
        volatile: &[String],
    ) -> std::io::Result<Manifest> {
        Manifest::build_knowing(dir, campaign_hash, campaign, volatile, &BTreeMap::new())
    }

    /// [`Manifest::build`], taking the sha256 of the files in `known` (relative path -> sha256,
    /// hashed by the run as it wrote them: see `journal`) rather than reading them again.
    pub fn build_knowing(
        dir: &Path,
        campaign_hash: &str,
        campaign: serde_json::Value,
        volatile: &[String],
        known: &BTreeMap<&str, &str>,
    ) -> std::io::Result<Manifest> {
        use rayon::prelude::*;
        // Hashed in parallel: a 4000-image run has ~12000 files.
        let files = list_files(dir)?
            .into_par_iter()
            .filter(|rel| !volatile.contains(rel))
            .map(|rel| {
                let path = dir.join(&rel);
                let (sha256, bytes) = match known.get(rel.as_str()) {
                    Some(sha) => (sha.to_string(), std::fs::metadata(&path)?.len()),
                    None => sha256_file(&path)?,
                };
                Ok((rel, FileEntry { sha256, bytes }))
            })
            .collect::<std::io::Result<BTreeMap<_, _>>>()?;
        let mut m = Manifest {
            tool: "soig".into(),
            version: env!("CARGO_PKG_VERSION").into(),
            campaign_hash: campaign_hash.into(),
            campaign,
            files,
            volatile: volatile.to_vec(),
            training: None,
            shard: None,
            inputs: BTreeMap::new(),
            effective: None,
            debris_mix: None,
            digest: String::new(),
        };
        m.digest = digest_of(&m);
        Ok(m)
    }

    /// Recompute the digest after a change.
    pub fn seal(&mut self) {
        self.digest = digest_of(self);
    }

    /// Write the manifest into `dir`, atomically (an output trained in place keeps a whole one).
    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        let text = serde_json::to_string_pretty(self).expect("manifest serialises") + "\n";
        super::fs::write(&dir.join(MANIFEST), text)
    }

    pub fn read(dir: &Path) -> Result<Manifest, Error> {
        let path = dir.join(MANIFEST);
        let text =
            crate::hash::read_regular_to_string(&path).map_err(|e| Error::input(&path, e))?;
        serde_json::from_str(&text)
            .map_err(|e| Error::input(&path, format!("not a soig manifest: {e}")))
    }
}

/// One way an output directory differs from its manifest.
#[derive(Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Problem {
    Mismatch(String),
    Missing(String),
    Extra(String),
    Digest,
    /// The digest is consistent but not the one pinned by the user.
    Pinned {
        pinned: String,
        found: String,
    },
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Problem::Mismatch(p) => write!(f, "changed: {p} (sha256 differs from the manifest)"),
            Problem::Missing(p) => write!(f, "missing: {p}"),
            Problem::Extra(p) => write!(f, "extra: {p} (not in the manifest)"),
            Problem::Digest => write!(
                f,
                "the manifest's digest does not match its contents (manifest edited?)"
            ),
            Problem::Pinned { pinned, found } => {
                write!(f, "digest {found} is not the pinned {pinned}")
            }
        }
    }
}

/// Recompute every hash of `dir` against its manifest.
pub fn verify(dir: &Path) -> Result<(Manifest, Vec<Problem>), Error> {
    let m = Manifest::read(dir)?;
    let mut problems = Vec::new();
    if digest_of(&m) != m.digest {
        problems.push(Problem::Digest);
    }
    let present = list_all_files(dir).map_err(|e| Error::input(dir, e))?;
    for rel in &m.volatile {
        if !present.contains(rel) {
            problems.push(Problem::Missing(rel.clone()));
        }
    }
    for rel in present.iter().filter(|r| !m.volatile.contains(r)) {
        match m.files.get(rel) {
            None => problems.push(Problem::Extra(rel.clone())),
            Some(entry) => {
                let (sha, _) = sha256_file(&dir.join(rel)).map_err(|e| Error::input(rel, e))?;
                if sha != entry.sha256 {
                    problems.push(Problem::Mismatch(rel.clone()));
                }
            }
        }
    }
    for rel in m.files.keys() {
        if !present.contains(rel) {
            problems.push(Problem::Missing(rel.clone()));
        }
    }
    problems.sort();
    Ok((m, problems))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Write `bytes` to `rel` under `dir`, making its folders.
    fn put(dir: &Path, rel: &str, bytes: &[u8]) {
        let path = dir.join(rel);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }

    #[test]
    fn verify_names_each_problem() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        put(d, "a/x.txt", b"x");
        put(d, "y.txt", b"y");
        let m = Manifest::build(d, "h", serde_json::json!({"k": 1}), &[]).unwrap();
        m.write(d).unwrap();
        assert_eq!(verify(d).unwrap().1, vec![]);
        assert_eq!(
            m.digest,
            Manifest::build(d, "h", serde_json::json!({"k": 1}), &[])
                .unwrap()
                .digest
        );
        put(d, "a/x.txt", b"z");
        std::fs::remove_file(d.join("y.txt")).unwrap();
        put(d, "new.txt", b"n");
        let problems = verify(d).unwrap().1;
        assert_eq!(
            problems,
            vec![
                Problem::Mismatch("a/x.txt".into()),
                Problem::Missing("y.txt".into()),
                Problem::Extra("new.txt".into())
            ]
        );
    }

    #[test]
    fn verify_ignores_ultralytics_label_caches_only() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        put(d, "labels/train/a.txt", b"0 0.5 0.5 0.1 0.1\n");
        Manifest::build(d, "h", serde_json::json!({}), &[])
            .unwrap()
            .write(d)
            .unwrap();
        // What `yolo train` leaves: one cache per split, beside the split's folder.
        put(d, "labels/train.cache", b"c");
        put(d, "labels/val.cache", b"c");
        // And `yolo obb` / `yolo pose` on the streak-shaped label sets.
        for set in ["obb", "keypoints"] {
            put(d, &format!("{set}/labels/train.cache"), b"c");
        }
        assert_eq!(verify(d).unwrap().1, vec![]);
        // Anything else named .cache is still an extra file.
        for other in [
            "train.cache",
            "labels/train/a.cache",
            "images/train.cache",
            "obb/train.cache",
            "other/labels/train.cache",
        ] {
            put(d, other, b"c");
        }
        assert_eq!(
            verify(d).unwrap().1,
            vec![
                Problem::Extra("images/train.cache".into()),
                Problem::Extra("labels/train/a.cache".into()),
                Problem::Extra("obb/train.cache".into()),
                Problem::Extra("other/labels/train.cache".into()),
                Problem::Extra("train.cache".into()),
            ]
        );
    }
}
