//! Shards: a campaign's images split over machines and merged back. Shard K of N (0 <= K < N)
//! renders the contiguous block of images `K*n/N .. (K+1)*n/N` of the campaign's `n` (every
//! image in exactly one shard) exactly as a whole run would: each image is a function of
//! (seed, index), and its subset of the split is the whole campaign's (`dataset::assign` over
//! all `n`). A shard output holds its images, `shard.jsonl` (each image's files, sha256 and
//! what the detect stage needs of it), `shard-timing.json` (volatile) and a manifest whose
//! `shard` section gives K, N, the block and the campaign's folder. [`merge`] checks that a set
//! of shard outputs is one campaign, complete and without overlap, links their files into one
//! output and runs the steps after rendering (`data.yaml`, train, detect, report, manifest):
//! the same files, so the same digest, as a single run.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use serde::{Deserialize, Serialize};

use crate::campaign::{Campaign, Stage};
use crate::journal::Record;
use crate::manifest::{self, Manifest};
use crate::output::write_replacing;
use crate::pipeline::{self, RunSummary};
use crate::progress::Progress;

/// A shard's records, one JSON line per image, by index (hashed in the shard manifest).
pub const RECORDS: &str = "shard.jsonl";
/// Each image's conversion time, seconds (volatile: a timing).
pub const TIMING: &str = "shard-timing.json";

/// Shard `index` of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

/// The `shard` section of a shard manifest.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Section {
    index: u64,
    count: u64,
    /// The images of the shard, `[first, end)`.
    images: [u64; 2],
    /// The folder of the campaign file, where a merge reads its model and frames.
    campaign_dir: PathBuf,
}

impl Shard {
    /// Parse `--shard`: `K/N`; `auto` (a Slurm job array: K from `SLURM_ARRAY_TASK_ID` less
    /// `SLURM_ARRAY_TASK_MIN`, N from `SLURM_ARRAY_TASK_COUNT`); or `auto/N` (a Kubernetes
    /// Indexed Job: K from `JOB_COMPLETION_INDEX`, N its `completions`, which the pod's
    /// environment does not give; or a Slurm array of N tasks). `env` reads the environment.
    pub fn parse(spec: &str, env: impl Fn(&str) -> Option<String>) -> Result<Shard, String> {
        let (k, n) = match spec.split_once('/') {
            Some((k, n)) => (k.trim(), Some(n.trim())),
            None => (spec.trim(), None),
        };
        let number = |what: &str, text: &str| {
            text.trim()
                .parse::<u64>()
                .map_err(|_| format!("--shard {spec}: {what} `{text}` is not a whole number"))
        };
        let given = n.map(|n| number("the shard count", n)).transpose()?;
        let (index, count) = if k != "auto" {
            let count = given.ok_or_else(|| {
                format!("--shard {spec}: write K/N (shard K of N, 0 <= K < N), `auto` or `auto/N`")
            })?;
            (number("the shard index", k)?, count)
        } else if let Some(i) = env("JOB_COMPLETION_INDEX") {
            let count = given.ok_or_else(|| {
                format!(
                    "--shard {spec}: JOB_COMPLETION_INDEX is set (a Kubernetes Indexed Job), which does not say how many shards there are: write --shard auto/N, N the Job's `completions`"
                )
            })?;
            (number("JOB_COMPLETION_INDEX", &i)?, count)
        } else if let Some(id) = env("SLURM_ARRAY_TASK_ID") {
            let id = number("SLURM_ARRAY_TASK_ID", &id)?;
            let min = match env("SLURM_ARRAY_TASK_MIN") {
                Some(m) => number("SLURM_ARRAY_TASK_MIN", &m)?,
                None => 0,
            };
            if env("SLURM_ARRAY_TASK_STEP").is_some_and(|s| s.trim() != "1") {
                return Err(format!(
                    "--shard {spec}: the Slurm array has a step; submit it as --array=0-{}",
                    given.map_or("N-1".into(), |n| (n.max(1) - 1).to_string())
                ));
            }
            let count = match (env("SLURM_ARRAY_TASK_COUNT"), given) {
                (Some(c), g) => {
                    let c = number("SLURM_ARRAY_TASK_COUNT", &c)?;
                    if g.is_some_and(|g| g != c) {
                        return Err(format!(
                            "--shard {spec}: the Slurm array has {c} tasks, not {}",
                            g.unwrap_or_default()
                        ));
                    }
                    c
                }
                (None, Some(g)) => g,
                (None, None) => {
                    return Err(format!(
                        "--shard {spec}: SLURM_ARRAY_TASK_COUNT is not set; write --shard auto/N"
                    ));
                }
            };
            let index = id.checked_sub(min).ok_or_else(|| {
                format!(
                    "--shard {spec}: SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}"
                )
            })?;
            (index, count)
        } else {
            return Err(format!(
                "--shard {spec}: neither SLURM_ARRAY_TASK_ID (a Slurm job array) nor JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set; give the shard as K/N"
            ));
        };
        if index >= count {
            return Err(format!(
                "--shard {spec}: shard {index} of {count}: the index must be below the count (0 <= K < N; a Slurm array must be contiguous, --array=0-{})",
                count.max(1) - 1
            ));
        }
        Ok(Shard { index, count })
    }

    /// Refuse more shards than the campaign has images (a shard would be empty).
    pub fn check_against(&self, images: u64) -> anyhow::Result<()> {
        if self.count > images {
            bail!(
                "--shard {}/{}: {} shards for the campaign's {images} images: at most one shard per image",
                self.index,
                self.count,
                self.count
            );
        }
        Ok(())
    }

    /// The images of this shard among `n`: a contiguous block, the blocks of shards 0..N
    /// covering 0..n once.
    pub fn images(&self, n: u64) -> Range<u64> {
        // u128: n * index overflows u64 for no campaign (images <= 1e7), but costs nothing.
        let at = |k: u64| (u128::from(n) * u128::from(k) / u128::from(self.count)) as u64;
        at(self.index)..at(self.index + 1)
    }

    /// The default output of this shard: `OUTPUT-shard-K-of-N` beside the campaign's output.
    pub fn output_dir(&self, output: &Path) -> PathBuf {
        let mut name = output.as_os_str().to_owned();
        name.push(format!("-shard-{}-of-{}", self.index, self.count));
        PathBuf::from(name)
    }
}

/// Seal shard output `dir`: its records, its timing and its manifest. Returns the digest.
pub(crate) fn seal(
    campaign: &Campaign,
    dir: &Path,
    shard: Shard,
    records: &[Record],
) -> anyhow::Result<String> {
    let mut lines = String::new();
    let mut timing = BTreeMap::new();
    for r in records {
        let mut r = r.clone();
        if let Some(t) = r.conversion_s.take() {
            timing.insert(r.index, t);
        }
        lines += &(serde_json::to_string(&r)? + "\n");
    }
    std::fs::write(dir.join(RECORDS), lines)?;
    std::fs::write(dir.join(TIMING), serde_json::to_string(&timing)? + "\n")?;
    let images = shard.images(u64::from(campaign.resolved.images));
    let campaign_dir = std::path::absolute(&campaign.base_dir)
        .with_context(|| format!("cannot resolve {}", campaign.base_dir.display()))?;
    let section = Section {
        index: shard.index,
        count: shard.count,
        images: [images.start, images.end],
        campaign_dir,
    };
    let resolved = serde_json::to_value(&campaign.resolved)?;
    let mut m = Manifest::build(dir, &campaign.hash, resolved, &[TIMING.into()])?;
    m.shard = Some(serde_json::to_value(section)?);
    m.seal();
    m.write(dir)?;
    Ok(m.digest)
}

/// One shard output, checked.
struct Part {
    dir: PathBuf,
    manifest: Manifest,
    section: Section,
    records: Vec<Record>,
}

/// `soig merge`: merge the shard outputs `shards` into `output`, which ends as a single run of
/// their campaign would (same files, same digest), report included. Refused, with the reason,
/// unless the shards are one campaign made by this soig version, each verifies and holds its
/// whole block, and every shard 0..N is given once.
pub fn merge(
    shards: &[PathBuf],
    output: &Path,
    python: Option<&Path>,
    progress: &dyn Progress,
) -> anyhow::Result<RunSummary> {
    let parts = check(shards)?;
    let same = |a: &Path, b: &Path| {
        a.canonicalize()
            .is_ok_and(|a| b.canonicalize().is_ok_and(|b| a == b))
    };
    if let Some(p) = parts.iter().find(|p| same(&p.dir, output)) {
        bail!(
            "refusing to merge into {}: it is one of the shards",
            p.dir.display()
        );
    }
    let first = &parts[0];
    let campaign = Campaign::from_resolved(&first.manifest.campaign, &first.section.campaign_dir)?;
    if campaign.hash != first.manifest.campaign_hash {
        bail!(
            "the campaign in {} resolves to hash {}, not the {} it records",
            first.dir.display(),
            campaign.hash,
            first.manifest.campaign_hash
        );
    }
    let python = if campaign.resolved.stages.contains(&Stage::Train) {
        Some(crate::train::find_python(python)?)
    } else {
        None
    };
    let started = std::time::Instant::now();
    let digest = write_replacing(output, &[&campaign.base_dir], |dir| {
        progress.start("merge", parts.len() as u64);
        for p in &parts {
            for rel in p.records.iter().flat_map(|r| r.files.keys()) {
                link_or_copy(&p.dir.join(rel), &dir.join(rel))?;
            }
            progress.advance();
        }
        progress.finish();
        let records: Vec<Record> = parts.iter().flat_map(|p| p.records.clone()).collect();
        pipeline::finish(&campaign, dir, &records, python.as_deref(), progress)
    })?;
    Ok(RunSummary {
        output: output.to_path_buf(),
        digest,
        images: 0,
        resumed: parts.iter().map(|p| p.records.len()).sum(),
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Read and check the shard outputs: one campaign and version, every shard 0..N once, each
/// verifying, its records its whole block and its manifest's files. Sorted by index.
fn check(shards: &[PathBuf]) -> anyhow::Result<Vec<Part>> {
    if shards.is_empty() {
        bail!("soig merge: no shard given");
    }
    let mut parts: Vec<Part> = Vec::new();
    for dir in shards {
        let manifest = Manifest::read(dir)?;
        let section: Section = match &manifest.shard {
            Some(s) => serde_json::from_value(s.clone())
                .with_context(|| format!("{}: unreadable shard section", dir.display()))?,
            None => bail!(
                "{} is not a shard (its manifest has no `shard` section: it was not made by `soig run --shard`)",
                dir.display()
            ),
        };
        parts.push(Part {
            dir: dir.clone(),
            manifest,
            section,
            records: Vec::new(),
        });
    }
    let first = &parts[0];
    for p in &parts[1..] {
        let (a, b) = (&first.manifest, &p.manifest);
        if (&a.campaign_hash, &a.version) != (&b.campaign_hash, &b.version) {
            bail!(
                "not one campaign: {} is a shard of campaign {} (soig {}), {} of campaign {} (soig {}); merge the shards of one campaign, made by one soig version",
                first.dir.display(),
                a.campaign_hash,
                a.version,
                p.dir.display(),
                b.campaign_hash,
                b.version
            );
        }
        if p.section.count != first.section.count {
            bail!(
                "{} is shard {} of {}, {} shard {} of {}: one campaign is split one way",
                first.dir.display(),
                first.section.index,
                first.section.count,
                p.dir.display(),
                p.section.index,
                p.section.count
            );
        }
    }
    if first.manifest.version != env!("CARGO_PKG_VERSION") {
        bail!(
            "the shards were made by soig {}, this is soig {}: merge them with the version that made them",
            first.manifest.version,
            env!("CARGO_PKG_VERSION")
        );
    }
    let count = first.section.count;
    let images = first
        .manifest
        .campaign
        .get("images")
        .and_then(|v| v.as_u64())
        .context("the shards' campaign has no image count")?;
    parts.sort_by_key(|p| p.section.index);
    for pair in parts.windows(2) {
        if pair[0].section.index == pair[1].section.index {
            bail!(
                "shard {} of {count} is given twice: {} and {}",
                pair[0].section.index,
                pair[0].dir.display(),
                pair[1].dir.display()
            );
        }
    }
    let missing: Vec<String> = (0..count)
        .filter(|k| !parts.iter().any(|p| p.section.index == *k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        bail!(
            "incomplete: shard(s) {} of {count} missing (give every shard 0..{} of the campaign)",
            missing.join(", "),
            count - 1
        );
    }
    for p in &mut parts {
        p.records = records_of(p, images)?;
    }
    Ok(parts)
}

/// The records of a shard, checked: the shard verifies, its block is its place's, its records
/// are its block's images, each once, and their files are its manifest's.
fn records_of(p: &Part, images: u64) -> anyhow::Result<Vec<Record>> {
    let shard = Shard {
        index: p.section.index,
        count: p.section.count,
    };
    let block = shard.images(images);
    if p.section.images != [block.start, block.end] {
        bail!(
            "{}: shard {} of {} holds images {}..{}, not its block {}..{}",
            p.dir.display(),
            shard.index,
            shard.count,
            p.section.images[0],
            p.section.images[1],
            block.start,
            block.end
        );
    }
    let (_, problems) = manifest::verify(&p.dir)?;
    if let Some(first) = problems.first() {
        bail!(
            "{} does not verify ({} problem(s), e.g. {first}): run that shard again",
            p.dir.display(),
            problems.len()
        );
    }
    let text = std::fs::read_to_string(p.dir.join(RECORDS))
        .with_context(|| format!("cannot read {}", p.dir.join(RECORDS).display()))?;
    let timing: BTreeMap<u64, f64> = std::fs::read_to_string(p.dir.join(TIMING))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    let mut records = Vec::new();
    for (line, t) in text.lines().enumerate() {
        let mut r: Record = serde_json::from_str(t)
            .with_context(|| format!("{}:{}", p.dir.join(RECORDS).display(), line + 1))?;
        r.conversion_s = timing.get(&r.index).copied();
        records.push(r);
    }
    let indices: Vec<u64> = records.iter().map(|r| r.index).collect();
    if indices != block.clone().collect::<Vec<_>>() {
        bail!(
            "{}: its records are not images {}..{} once each",
            p.dir.display(),
            block.start,
            block.end
        );
    }
    for r in &records {
        for (rel, sha) in &r.files {
            if p.manifest.files.get(rel).map(|e| &e.sha256) != Some(sha) {
                bail!(
                    "{}: {rel} of image {} is not the file its manifest hashes",
                    p.dir.display(),
                    r.index
                );
            }
        }
    }
    // Its records name every file of the manifest but the records themselves.
    let named = records.iter().map(|r| r.files.len()).sum::<usize>() + 1;
    if named != p.manifest.files.len() || !p.manifest.files.contains_key(RECORDS) {
        bail!(
            "{}: its manifest lists files no image record names",
            p.dir.display()
        );
    }
    Ok(records)
}

/// Hard-link `from` to `to` (no copy of a large dataset), copying across file systems.
fn link_or_copy(from: &Path, to: &Path) -> anyhow::Result<()> {
    if let Some(parent) = to.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    if std::fs::hard_link(from, to).is_err() {
        std::fs::copy(from, to)
            .with_context(|| format!("cannot copy {} to {}", from.display(), to.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |k| {
            vars.iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn blocks_cover_every_image_once() {
        for n in [1u64, 6, 7, 100, 4001] {
            for count in 1..=n.min(9) {
                let mut all = Vec::new();
                for index in 0..count {
                    let r = Shard { index, count }.images(n);
                    assert!(r.end - r.start >= n / count, "{n} {count} {index}");
                    all.extend(r);
                }
                assert_eq!(all, (0..n).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn parses_given_slurm_and_kubernetes_shards() {
        let none = env(&[]);
        assert_eq!(Shard::parse("2/7", &none), Ok(Shard { index: 2, count: 7 }));
        assert!(
            Shard::parse("7/7", &none)
                .unwrap_err()
                .contains("below the count")
        );
        assert!(Shard::parse("2", &none).unwrap_err().contains("K/N"));
        assert!(
            Shard::parse("x/3", &none)
                .unwrap_err()
                .contains("not a whole number")
        );
        assert!(Shard::parse("auto", &none).unwrap_err().contains("neither"));
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "7"),
        ]);
        assert_eq!(
            Shard::parse("auto", &slurm),
            Ok(Shard { index: 4, count: 7 })
        );
        assert!(
            Shard::parse("auto/6", &slurm)
                .unwrap_err()
                .contains("7 tasks")
        );
        let k8s = env(&[("JOB_COMPLETION_INDEX", "3")]);
        assert_eq!(
            Shard::parse("auto/4", &k8s),
            Ok(Shard { index: 3, count: 4 })
        );
        assert!(Shard::parse("auto", &k8s).unwrap_err().contains("auto/N"));
        assert!(
            Shard::parse("auto/3", &k8s)
                .unwrap_err()
                .contains("below the count")
        );
    }
}
