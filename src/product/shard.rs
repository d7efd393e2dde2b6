//! Shards: a campaign's images split over machines and merged back. Shard K of N (0 <= K < N)
//! renders the contiguous block of images `K*n/N .. (K+1)*n/N` of the campaign's `n` (every
//! image in exactly one shard) exactly as a whole run would: each image is a function of
//! (seed, index), and its subset of the split is the whole campaign's (`dataset::assign` over
//! all `n`). A shard output holds its images, `shard.jsonl` (each image's files, sha256 and
//! what the detect stage needs of it), `shard-timing.json` (volatile) and a manifest whose
//! `shard` section gives K, N, the block and the campaign's folder; `merge` makes the single
//! run's output of a whole set of them.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use serde::{Deserialize, Serialize};

use crate::journal::Record;
use crate::manifest::Manifest;

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
pub(crate) struct Section {
    pub index: u64,
    pub count: u64,
    /// The images of the shard, `[first, end)`.
    pub images: [u64; 2],
    /// The folder of the campaign file, where a merge reads its model and frames.
    pub campaign_dir: PathBuf,
    /// The build that rendered it (`build_id`): a merge takes the shards of one build only.
    #[serde(default)]
    pub build: String,
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
        // `parse` refuses these, but the library takes a `Shard` built in code too.
        if self.index >= self.count {
            bail!(
                "--shard {}/{}: the shard index must be below the shard count (0 <= K < N)",
                self.index,
                self.count
            );
        }
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

/// What a shard's manifest records of its campaign.
pub(crate) struct Seal<'a> {
    /// The campaign's hash and its resolved JSON.
    pub hash: &'a str,
    pub resolved: &'a serde_json::Value,
    /// The campaign's images, all shards together.
    pub images: u64,
    /// The campaign's folder, where a merge finds its inputs again.
    pub campaign_dir: &'a Path,
    /// The hashes of the run's input files.
    pub inputs: std::collections::BTreeMap<String, String>,
}

/// Seal shard output `dir`: its records, its timing and its manifest. Returns the digest.
pub(crate) fn seal(
    run: &Seal,
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
    crate::store::fs::create(&dir.join(RECORDS), lines)?;
    crate::store::fs::create(&dir.join(TIMING), serde_json::to_string(&timing)? + "\n")?;
    let images = shard.images(run.images);
    let campaign_dir = std::path::absolute(run.campaign_dir)
        .with_context(|| format!("cannot resolve {}", run.campaign_dir.display()))?;
    let section = Section {
        index: shard.index,
        count: shard.count,
        images: [images.start, images.end],
        campaign_dir,
        build: crate::build_id::identity().into(),
    };
    let mut m = Manifest::build(dir, run.hash, run.resolved.clone(), &[TIMING.into()])?;
    m.shard = Some(serde_json::to_value(section)?);
    m.inputs = run.inputs.clone();
    m.seal();
    m.write(dir)?;
    Ok(m.digest)
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
