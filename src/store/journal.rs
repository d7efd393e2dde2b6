//! The journal of a run in progress, which makes it resumable. A run writes `.soig-journal.jsonl`
//! into its staging directory: a header line naming what it writes (campaign hash, soig
//! version, shard), then one line per finished image, appended and synced after the image's
//! files are written, with their sha256. A run killed at any point leaves a journal whose
//! lines are all true (a torn last line is dropped); the next run of the same campaign into the
//! same output takes the staging directory over ([`Journal::open`]), keeps every image whose
//! files still hash as recorded, and renders only the rest. Each image is a function of (seed,
//! index) alone (`rng`), so the resumed run's files, and digest, are the uninterrupted run's.
//!
//! Every line ends with the sha256 of its JSON, so a damaged or edited line is dropped (its
//! image rendered again), and every record is checked against the campaign (`Check`) before it
//! is trusted: a record naming no file, an index or debris object out of range, or a
//! non-finite label is dropped in the same way, never an image of the output.
//!
//! The header names the build (sha256 of the running executable, see `build_id`) and the
//! content of the input files (frames, star catalogue, model): a staging directory of the same
//! campaign left by another build, or made from inputs that changed since, is not resumed but
//! refused, saying what differs (`--fresh` starts afresh).
//!
//! The journal is no artifact: `manifest::list_files` skips it, and the run removes it just
//! before moving the staging directory into place.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::Path;
use std::sync::Mutex;

use anyhow::Context;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sha2::Digest;

use super::fs;
use crate::hash::sha256_file;
use crate::manifest::{self, MANIFEST, Manifest};

/// The journal's file name in a staging directory.
pub const FILE: &str = manifest::JOURNAL;

/// What a staging directory is being written for: a run resumes only its own.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Identity {
    pub campaign_hash: String,
    pub version: String,
    /// sha256 of the soig executable that writes (see `build_id`).
    pub build: String,
    /// sha256 of the input files' hashes (`Campaign::input_hashes`).
    pub inputs: String,
    /// (index, count) of a shard run; None for a whole campaign.
    pub shard: Option<(u64, u64)>,
}

impl Identity {
    pub fn new(campaign_hash: &str, inputs: &str, shard: Option<(u64, u64)>) -> Identity {
        Identity {
            campaign_hash: campaign_hash.into(),
            version: env!("CARGO_PKG_VERSION").into(),
            build: crate::build_id::identity().into(),
            inputs: inputs.into(),
            shard,
        }
    }

    /// Why a staging directory of `self` cannot be resumed by a run of `other` of the same
    /// campaign and shard; None if it can, or if it is another campaign or shard's.
    pub fn conflict(&self, other: &Identity) -> Option<String> {
        if (&self.campaign_hash, self.shard) != (&other.campaign_hash, other.shard) {
            return None;
        }
        if self.version != other.version || self.build != other.build {
            Some(format!(
                "it was written by another soig build (soig {}, executable sha256 {}; this is soig {}, {})",
                self.version, self.build, other.version, other.build
            ))
        } else if self.inputs != other.inputs {
            Some(
                "its input files (background frames, star catalogue or model) have changed since it was written"
                    .into(),
            )
        } else {
            None
        }
    }
}

/// A check of a record against the campaign: why it cannot be one of its images.
pub type Check<'a> = &'a (dyn Fn(&Record) -> Result<(), String> + Sync);

/// One finished image: its files with their sha256, and what the detect stage needs of it.
/// Floats are kept as their bit patterns, so that a resumed or merged run's report is built
/// from exactly the values an uninterrupted run holds in memory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    pub index: u64,
    /// The debris object the image shows (index in the campaign's debris), for the mix.
    pub debris_index: usize,
    /// The debris objects the image shows when the campaign has `[objects]` (indices in the
    /// campaign's debris; `debris_index` is then the pointing's object, not rendered).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objects: Option<Vec<usize>>,
    /// sha256 of each file the image wrote, by path relative to the output ('/' separated).
    pub files: BTreeMap<String, String>,
    pub png: Option<PngRecord>,
    /// `f64::to_bits` of the direction of star trails in the PNG (survey pointing).
    pub trail_angle_bits: Option<u64>,
    /// `f64::to_bits` of the original image's outline in the PNG's frame (rotated and padded
    /// frames; `geometry::Frame::footprint`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub footprint_bits: Option<[[u64; 2]; 4]>,
    /// FITS -> PNG conversion time, seconds (a timing: kept out of anything hashed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub conversion_s: Option<f64>,
}

/// The PNG of an image: its size and its label box (pixel edges, `f64::to_bits`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PngRecord {
    pub width: usize,
    pub height: usize,
    pub label_bits: Option<[u64; 4]>,
    /// The label boxes after the first, of an image with several objects.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub more_label_bits: Vec<[u64; 4]>,
}

impl PngRecord {
    /// The record of a PNG with these label boxes (pixel edges).
    pub fn new(width: usize, height: usize, labels: &[[f64; 4]]) -> PngRecord {
        let mut bits = labels.iter().map(|b| b.map(f64::to_bits));
        PngRecord {
            width,
            height,
            label_bits: bits.next(),
            more_label_bits: bits.collect(),
        }
    }

    /// Its label boxes, pixel edges.
    pub fn labels(&self) -> Vec<[f64; 4]> {
        self.label_bits
            .iter()
            .chain(&self.more_label_bits)
            .map(|b| b.map(f64::from_bits))
            .collect()
    }
}

impl Record {
    /// The debris objects the image shows (indices in the campaign's debris).
    pub fn shown(&self) -> Vec<usize> {
        match &self.objects {
            Some(objects) => objects.clone(),
            None => vec![self.debris_index],
        }
    }
}

#[derive(Serialize, Deserialize)]
struct Header {
    soig_journal: Identity,
}

/// An open journal, appended to by the rendering threads.
pub struct Journal {
    file: Mutex<std::fs::File>,
}

impl Journal {
    /// Open the journal of staging directory `dir` for `id`. When `dir` holds a journal of the
    /// same identity, its records whose files are all present and hash as recorded are kept
    /// and returned; every other file in `dir` (a half-written image, a report or manifest of a
    /// later phase) is removed, and the journal is rewritten with the kept records (written to
    /// a temporary file and renamed, so it is whole at every instant). Otherwise `dir` is
    /// emptied and a fresh journal started.
    pub fn open(dir: &Path, id: &Identity, check: Check) -> anyhow::Result<(Journal, Vec<Record>)> {
        let kept = if identity_of(dir).as_ref() == Some(id) {
            verified_records(dir, check)?
        } else {
            Vec::new()
        };
        let keep: BTreeSet<&str> = kept
            .iter()
            .flat_map(|r| r.files.keys().map(String::as_str))
            .collect();
        fs::create_dir_all(dir)?;
        let mut present =
            manifest::list_files(dir).with_context(|| format!("cannot list {}", dir.display()))?;
        present.push(MANIFEST.into());
        for rel in present.iter().filter(|rel| !keep.contains(rel.as_str())) {
            let path = dir.join(rel);
            if path.exists() {
                fs::remove_file(&path)?;
            }
        }
        let mut text = line(&Header {
            soig_journal: id.clone(),
        })?;
        for r in &kept {
            text += &line(r)?;
        }
        let path = dir.join(FILE);
        fs::write(&path, text)?;
        let file = open_to_append(&path)?;
        Ok((
            Journal {
                file: Mutex::new(file),
            },
            kept,
        ))
    }

    /// Record a finished image: one line, appended and synced to disk before returning.
    pub fn append(&self, record: &Record) -> anyhow::Result<()> {
        let line = line(record)?;
        let mut f = self.file.lock().unwrap_or_else(|e| e.into_inner());
        f.write_all(line.as_bytes())
            .and_then(|()| f.sync_data())
            .context("cannot append to the run's journal")
    }
}

/// The sha256 of each of `files` (paths relative to `dir`).
pub fn hash_files(dir: &Path, files: &[String]) -> anyhow::Result<BTreeMap<String, String>> {
    files
        .iter()
        .map(|rel| {
            let (sha, _) = sha256_file(&dir.join(rel))
                .with_context(|| format!("cannot read {}", dir.join(rel).display()))?;
            Ok((rel.clone(), sha))
        })
        .collect()
}

/// Remove the journal of `dir` (the last step before the staging directory moves into place).
pub fn remove(dir: &Path) -> anyhow::Result<()> {
    fs::remove_file(&dir.join(FILE))
}

/// A journal line: the JSON of `value`, a space and the JSON's sha256.
fn line<T: Serialize>(value: &T) -> anyhow::Result<String> {
    let json = serde_json::to_string(value)?;
    let sha = crate::hash::hex(&sha2::Sha256::digest(json.as_bytes()));
    Ok(format!("{json} {sha}\n"))
}

/// The JSON of a journal line whose checksum holds.
fn checked(line: &str) -> Option<&str> {
    let (json, sha) = line.rsplit_once(' ')?;
    (crate::hash::hex(&sha2::Sha256::digest(json.as_bytes())) == sha).then_some(json)
}

/// Whether staging directory `dir`, left by a process that is gone, is one a run of `id` can
/// take over: its journal is `id`'s, or it is complete (no journal, a manifest of `id` that
/// verifies: the run was killed while moving it into place). An error when it is the same
/// campaign's but of another build or other inputs, saying what differs.
pub fn resumable(dir: &Path, id: &Identity) -> anyhow::Result<bool> {
    match identity_of(dir) {
        Some(found) => match found.conflict(id) {
            Some(why) => anyhow::bail!(
                "cannot resume {}: {why}; run again with --fresh to discard its work",
                dir.display()
            ),
            None => Ok(found == *id),
        },
        None => Ok(complete(dir, id).is_some()),
    }
}

/// The manifest of a staging directory that is complete: no journal, and a manifest of `id`
/// that verifies without a problem.
pub fn complete(dir: &Path, id: &Identity) -> Option<Manifest> {
    if dir.join(FILE).exists() {
        return None;
    }
    let (m, problems) = manifest::verify(dir).ok()?;
    let shard = m
        .shard
        .as_ref()
        .and_then(|s| Some((s.get("index")?.as_u64()?, s.get("count")?.as_u64()?)));
    (problems.is_empty()
        && m.tool == "soig"
        && crate::hash::hash_json(&m.inputs) == id.inputs
        && m.campaign_hash == id.campaign_hash
        && m.version == id.version
        && shard == id.shard)
        .then_some(m)
}

/// The identity in the header of `dir`'s journal, if it has a readable one.
fn identity_of(dir: &Path) -> Option<Identity> {
    let text = crate::hash::read_regular_to_string(&dir.join(FILE)).ok()?;
    let header: Header = serde_json::from_str(checked(text.lines().next()?)?).ok()?;
    Some(header.soig_journal)
}

/// The records of `dir`'s journal that `check` accepts and whose files all hash as recorded,
/// by index. A line whose checksum fails (the last, torn by a kill, or a damaged one) is
/// dropped, as is a record given twice: their images are rendered again.
fn verified_records(dir: &Path, check: Check) -> anyhow::Result<Vec<Record>> {
    let text = crate::hash::read_regular_to_string(&dir.join(FILE))?;
    let mut records: BTreeMap<u64, Record> = BTreeMap::new();
    let mut twice = BTreeSet::new();
    for line in text.lines().skip(1) {
        if let Some(r) = checked(line).and_then(|j| serde_json::from_str::<Record>(j).ok())
            && check(&r).is_ok()
            && let Some(old) = records.insert(r.index, r)
        {
            twice.insert(old.index);
        }
    }
    for i in twice {
        records.remove(&i);
    }
    Ok(records
        .into_values()
        .collect::<Vec<_>>()
        .into_par_iter()
        .filter(|r| {
            r.files.iter().all(|(rel, sha)| {
                safe_relative(rel)
                    && sha256_file(&dir.join(rel)).is_ok_and(|(found, _)| found == *sha)
            })
        })
        .collect())
}

/// A path inside the output: relative, no `..`, no empty part.
pub fn safe_relative(rel: &str) -> bool {
    !rel.is_empty()
        && !rel.starts_with('/')
        && rel
            .split('/')
            .all(|p| !p.is_empty() && p != "." && p != "..")
}

/// Open the journal `path` to append its lines.
#[allow(clippy::disallowed_methods)] // the store's journal: appended to, line by line
fn open_to_append(path: &Path) -> anyhow::Result<std::fs::File> {
    std::fs::OpenOptions::new()
        .append(true)
        .open(path)
        .with_context(|| format!("cannot open {}", path.display()))
}

/// Test hook, for the tests of resumption only: when the environment variable
/// `SOIG_TEST_ABORT_AT` names `phase`, the process aborts here, as a `kill -9` would stop it
/// (no clean-up, no message). Phases: `render:N` (after the N-th image this process journals),
/// `dataset` (after `data.yaml`), `manifest` (after the manifest), `rename` (after the journal
/// is removed, before the staging directory moves into place), `write` (in `fs::write_by`, the
/// first file written atomically, after its temporary file is synced and before its rename).
pub fn abort_if_testing(phase: &str) {
    if std::env::var("SOIG_TEST_ABORT_AT").is_ok_and(|p| p == phase) {
        std::process::abort();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(dir: &Path, index: u64, content: &[u8]) -> Record {
        let rel = format!("truth/img_{index:06}.json");
        std::fs::create_dir_all(dir.join("truth")).unwrap();
        std::fs::write(dir.join(&rel), content).unwrap();
        Record {
            index,
            debris_index: 0,
            objects: None,
            files: hash_files(dir, &[rel]).unwrap(),
            png: Some(PngRecord {
                width: 3,
                height: 4,
                label_bits: Some([0.1f64.to_bits(), 1, 2, 3]),
                more_label_bits: Vec::new(),
            }),
            trail_angle_bits: None,
            footprint_bits: None,
            conversion_s: Some(0.5),
        }
    }

    #[test]
    fn keeps_what_verifies_and_removes_the_rest() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        let id = Identity::new("abc", "inputs", None);
        let any = |_: &Record| Ok(());
        let (j, kept) = Journal::open(d, &id, &any).unwrap();
        assert!(kept.is_empty());
        let (r0, r1) = (record(d, 0, b"zero"), record(d, 1, b"one"));
        j.append(&r0).unwrap();
        j.append(&r1).unwrap();
        drop(j);
        // Image 1's file changes after it was journaled; image 2 was half written; a torn line.
        std::fs::write(d.join("truth/img_000001.json"), b"0ne").unwrap();
        std::fs::write(d.join("truth/img_000002.json"), b"tw").unwrap();
        std::fs::write(d.join(MANIFEST), b"{}").unwrap();
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(d.join(FILE))
            .unwrap();
        f.write_all(b"{\"index\": 2, \"fil").unwrap();
        drop(f);
        assert!(resumable(d, &id).unwrap());
        assert!(!resumable(d, &Identity::new("abc", "inputs", Some((0, 2)))).unwrap());
        // The same campaign from other inputs or another build: refused, saying why.
        let e = resumable(d, &Identity::new("abc", "changed", None)).unwrap_err();
        assert!(e.to_string().contains("input files"), "{e}");
        let mut rebuilt = id.clone();
        rebuilt.build = "another".into();
        let e = resumable(d, &rebuilt).unwrap_err();
        assert!(e.to_string().contains("another soig build"), "{e}");
        let (_, kept) = Journal::open(d, &id, &any).unwrap();
        assert_eq!(kept, vec![r0.clone()]);
        assert_eq!(
            manifest::list_files(d).unwrap(),
            vec!["truth/img_000000.json"]
        );
        // Another campaign's journal is not resumed: the directory starts afresh.
        let (_, kept) = Journal::open(d, &Identity::new("other", "inputs", None), &any).unwrap();
        assert!(kept.is_empty());
        assert!(manifest::list_files(d).unwrap().is_empty());
    }
}
