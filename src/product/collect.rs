//! The manifest of each multi-frame collect (`[collect]`): `collects/collect_NNNNNN.json` lists
//! its frames in time order, each with its UTC start (the FITS `DATE-OBS`), exposure and files,
//! so a sequence can be replayed frame by frame without reading every truth.

use std::path::Path;

use anyhow::Context;
use serde::{Deserialize, Serialize};

use crate::artifacts::{dataset_paths, stem};
use crate::dataset::Subset;

/// One collect's manifest.
#[derive(Debug, Serialize, Deserialize)]
pub struct CollectManifest {
    pub collect: u64,
    /// The collect's one object, with its id over the collect's frames (the truths'
    /// `collect.track_id`), flattened into the manifest; with `[objects]`, `objects` instead.
    #[serde(flatten)]
    pub track: Option<Track>,
    /// With `[objects]`: the collect's objects, the same in each of its frames (each truth's
    /// `objects[].track_id`), in their order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub objects: Option<Vec<Track>>,
    /// The split subset of every frame (a collect is never split), when there is a dataset.
    pub subset: Option<String>,
    /// In time order.
    pub frames: Vec<FrameEntry>,
}

#[derive(Debug, Serialize, Deserialize)]
pub struct FrameEntry {
    pub frame: u64,
    pub image_index: u64,
    /// UTC start of the exposure, as the FITS `DATE-OBS`.
    pub date_obs: String,
    pub exposure_s: f64,
    /// Paths relative to the run folder; `fits` and `png` when written.
    pub truth: String,
    pub fits: Option<String>,
    pub png: Option<String>,
}

/// One object of a collect with `[objects]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Track {
    pub track_id: u64,
    pub object: String,
    pub norad: u64,
}

/// What the manifest reads of a truth sidecar: an image's (one object), or a frame's with
/// `[objects]`.
#[derive(Deserialize)]
struct Sidecar {
    object: Option<String>,
    norad: Option<u64>,
    start_utc: String,
    exposure_s: f64,
    collect: Option<Place>,
    objects: Option<Vec<Track>>,
}

/// A truth's place in its collect (with one object per image, its track id too).
#[derive(Deserialize)]
struct Place {
    collect: u64,
    frame: u64,
    track_id: Option<u64>,
}

/// Write the manifests of the collects of images `indices` in `dir`, from their truths;
/// `subset` gives each image's split subset.
pub fn write_manifests(
    dir: &Path,
    indices: &[u64],
    subset: impl Fn(u64) -> Option<Subset>,
) -> anyhow::Result<()> {
    let mut collects: std::collections::BTreeMap<u64, CollectManifest> = Default::default();
    for &i in indices {
        let rel = format!("truth/{}.json", stem(i));
        let path = dir.join(&rel);
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let t: Sidecar = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a soig truth sidecar", path.display()))?;
        let Some(k) = t.collect else {
            anyhow::bail!(
                "{}: no `collect` in a collect campaign's truth",
                path.display()
            );
        };
        let fits = format!("fits/{}.fits", stem(i));
        let png = dataset_paths(i, subset(i)).0;
        let entry = collects
            .entry(k.collect)
            .or_insert_with(|| CollectManifest {
                collect: k.collect,
                track: match (k.track_id, &t.object, t.norad) {
                    (Some(track_id), Some(object), Some(norad)) => Some(Track {
                        track_id,
                        object: object.clone(),
                        norad,
                    }),
                    _ => None,
                },
                objects: t.objects.clone(),
                subset: subset(i).map(|s| s.name().to_string()),
                frames: Vec::new(),
            });
        entry.frames.push(FrameEntry {
            frame: k.frame,
            image_index: i,
            date_obs: t.start_utc,
            exposure_s: t.exposure_s,
            truth: rel,
            fits: dir.join(&fits).is_file().then_some(fits),
            png: dir.join(&png).is_file().then_some(png),
        });
    }
    let out = dir.join("collects");
    crate::store::fs::create_dir_all(&out)?;
    for (c, mut m) in collects {
        // Frame k starts k (exposure + gap) after the first: frame order is time order.
        m.frames.sort_by_key(|f| f.frame);
        let path = out.join(format!("collect_{c:06}.json"));
        let text = serde_json::to_string_pretty(&m)? + "\n";
        crate::store::fs::create(&path, text)?;
    }
    Ok(())
}
