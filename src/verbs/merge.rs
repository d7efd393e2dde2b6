//! `soig merge`: shard outputs (`shard`) of one campaign become the output of a single run.
//! The shards are checked to be one campaign and soig version, every shard 0..N given once,
//! each verifying and holding exactly its block; their files are linked into one output and
//! the steps after rendering run on it (`data.yaml`, train, detect, report, manifest): the same
//! files, so the same digest, as a single run.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use crate::campaign::Campaign;
use crate::journal::Record;
use crate::manifest::{self, Manifest};
use crate::output::write_replacing;
use crate::pipeline::{self, RunSummary};
use crate::progress::Progress;
use crate::shard::{RECORDS, Section, Shard, TIMING};
use crate::store;
use crate::verbs::plan::Plan;

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
    let plan = Plan::new(&campaign)?;
    for p in &parts {
        let block = p.section.images[0]..p.section.images[1];
        let check = crate::pipeline::record_check(&plan, block);
        for r in &p.records {
            check(r).map_err(|why| {
                anyhow::anyhow!("{}: a record is not the campaign's: {why}", p.dir.display())
            })?;
        }
    }
    let inputs = plan.input_hashes()?;
    if inputs != first.manifest.inputs {
        bail!(
            "the input files beside the campaign ({}) are not those the shards were rendered from: {}",
            first.section.campaign_dir.display(),
            differing(&first.manifest.inputs, &inputs)
        );
    }
    let python = if plan.stages.train {
        Some(crate::train::find_python(python)?)
    } else {
        None
    };
    let started = std::time::Instant::now();
    let mut steps = Vec::new();
    let mut keep = plan.keep.clone();
    keep.extend(parts.iter().map(|p| p.dir.clone()));
    let keep: Vec<&Path> = keep.iter().map(PathBuf::as_path).collect();
    let (digest, mix) = write_replacing(output, &keep, |dir| {
        progress.start("merge", parts.len() as u64);
        for p in &parts {
            for rel in p.records.iter().flat_map(|r| r.files.keys()) {
                link_or_copy(&p.dir.join(rel), &dir.join(rel))?;
            }
            progress.advance();
        }
        progress.finish();
        steps.push(("merge", started.elapsed().as_secs_f64()));
        let records: Vec<Record> = parts.iter().flat_map(|p| p.records.clone()).collect();
        let (digest, mix, finished) =
            pipeline::finish(&plan, dir, &records, python.as_deref(), progress)?;
        steps.extend(finished);
        Ok((digest, mix))
    })?;
    Ok(RunSummary {
        output: output.to_path_buf(),
        digest,
        images: 0,
        resumed: parts.iter().map(|p| p.records.len()).sum(),
        seconds: started.elapsed().as_secs_f64(),
        mix,
        steps,
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
    for p in &parts[1..] {
        if p.section.build != first.section.build {
            bail!(
                "not one build: {} was rendered by the soig executable with sha256 {}, {} by {}; render every shard with one build",
                first.dir.display(),
                first.section.build,
                p.dir.display(),
                p.section.build
            );
        }
        if p.manifest.inputs != first.manifest.inputs {
            bail!(
                "not one set of inputs: {} and {} were rendered from input files (frames, catalogue, model) of different content: {}",
                first.dir.display(),
                p.dir.display(),
                differing(&first.manifest.inputs, &p.manifest.inputs)
            );
        }
    }
    if first.section.build != crate::build_id::identity() {
        bail!(
            "the shards were rendered by the soig executable with sha256 {}, this one is {}: merge them with the build that made them",
            first.section.build,
            crate::build_id::identity()
        );
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
    let text = crate::hash::read_regular_to_string(&p.dir.join(RECORDS))
        .with_context(|| format!("cannot read {}", p.dir.join(RECORDS).display()))?;
    let timing: BTreeMap<u64, f64> = crate::hash::read_regular_to_string(&p.dir.join(TIMING))
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

/// The files whose sha256 differs between two `Manifest::inputs`, for a message.
fn differing(a: &BTreeMap<String, String>, b: &BTreeMap<String, String>) -> String {
    let names: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    names
        .into_iter()
        .filter(|n| a.get(*n) != b.get(*n))
        .map(|n| n.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Hard-link `from` to `to` (no copy of a large dataset), copying across file systems.
fn link_or_copy(from: &Path, to: &Path) -> anyhow::Result<()> {
    if let Some(parent) = to.parent() {
        store::fs::create_dir_all(parent)?;
    }
    store::fs::link_or_copy(from, to)
}
