//! The streak-shaped label sets (`[artifacts] obb_labels`, `keypoint_labels`): each a dataset
//! of its own beside the axis-aligned one, `obb/` and `keypoints/`, in Ultralytics' layout.
//! Ultralytics finds an image's labels by turning its last `images/` into `labels/`, so each
//! set has its own `images/` folder: the PNGs hard-linked there (no copy on one file system).
//! The labels are derived in crates/image/src/streak_label.rs from the truth's streak ends and
//! each object's rendered photons (the same photons the axis-aligned box holds 99% of).

use std::path::Path;

use crate::campaign::Artifacts;
use crate::dataset::{self, Subset};
use crate::geometry::BoxPx;
use crate::psf::DebrisMap;
use crate::render::Truth;
use crate::simulate::ImageProducts;
use crate::store;
use crate::streak_label::{StreakLabel, streak_label};

/// A label set beside the axis-aligned boxes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Set {
    /// Oriented boxes, YOLO-OBB: `yolo obb`.
    Obb,
    /// The axis-aligned box and the streak's two ends, YOLO pose: `yolo pose`.
    Keypoints,
}

impl Set {
    /// The folder of the set's dataset in the output.
    pub fn dir(self) -> &'static str {
        match self {
            Set::Obb => "obb",
            Set::Keypoints => "keypoints",
        }
    }

    /// The set's `data.yaml`: the dataset's, with the keypoints' shape for pose. The ends keep
    /// their order under a horizontal flip (the first in time stays the first): `flip_idx`
    /// is the identity.
    pub fn data_yaml(self, campaign_name: &str, campaign_hash: &str) -> String {
        let yaml = dataset::data_yaml(campaign_name, campaign_hash);
        match self {
            Set::Obb => yaml,
            Set::Keypoints => yaml + "kpt_shape: [2, 3]\nflip_idx: [0, 1]\n",
        }
    }
}

/// The sets a campaign writes, none by default.
pub fn sets(artifacts: &Artifacts) -> Vec<Set> {
    let mut sets = Vec::new();
    if artifacts.obb_labels {
        sets.push(Set::Obb);
    }
    if artifacts.keypoint_labels {
        sets.push(Set::Keypoints);
    }
    sets
}

/// The PNG and label of image `index` in `set`, relative to the output.
pub fn paths(set: Set, index: u64, subset: Option<Subset>) -> (String, String) {
    let (png, label) = crate::artifacts::dataset_paths(index, subset);
    (
        format!("{}/{png}", set.dir()),
        format!("{}/{label}", set.dir()),
    )
}

/// The folders the sets' files go in (as the dataset's `images/` and `labels/`).
pub fn dirs(artifacts: &Artifacts, split: bool) -> Vec<String> {
    let subsets: Vec<String> = if split {
        [Subset::Train, Subset::Val, Subset::Test]
            .iter()
            .map(|s| format!("/{}", s.name()))
            .collect()
    } else {
        vec![String::new()]
    };
    sets(artifacts)
        .into_iter()
        .flat_map(|set| {
            subsets.iter().flat_map(move |s| {
                ["images", "labels"].map(|kind| format!("{}/{kind}{s}", set.dir()))
            })
        })
        .collect()
}

/// A lit pixel: centre x, y and photo-electrons.
type Pixel = (f64, f64, f64);

/// The lit pixels of a debris map.
fn pixels(m: &DebrisMap) -> Vec<Pixel> {
    m.counts
        .iter()
        .enumerate()
        .filter(|(_, c)| **c > 0)
        .map(|(k, &c)| {
            let (x, y) = (m.x0 + k % m.width, m.y0 + k / m.width);
            (x as f64, y as f64, c as f64)
        })
        .collect()
}

/// Each labelled object's axis-aligned box and streak label in the final frame, in the order
/// of the image's box labels (the objects on which a debris photon landed).
pub fn labels(products: &ImageProducts) -> Vec<(BoxPx, StreakLabel)> {
    let Some(product) = &products.product else {
        return Vec::new();
    };
    let exposure = &products.exposure;
    let (w, h) = (exposure.width, exposure.height);
    let objects: Vec<(&Truth, Vec<Pixel>)> = match &exposure.objects {
        Some(objects) => objects
            .iter()
            .filter(|o| o.truth.label_box_final_px.is_some())
            .map(|o| (&o.truth, pixels(&o.debris)))
            .collect(),
        None if exposure.truth.label_box_final_px.is_some() => {
            let debris = DebrisMap::crop(&exposure.debris_electrons, w);
            vec![(&exposure.truth, pixels(&debris))]
        }
        None => Vec::new(),
    };
    objects
        .into_iter()
        .filter_map(|(t, flux)| {
            let b = t.label_box_final_px?;
            let ends = (t.streak.start_px, t.streak.end_px);
            let l = streak_label(ends, &flux, (w, h), &product.frame, &b);
            Some((b, l))
        })
        .collect()
}

/// Write image `index`'s label in every set of `artifacts`, and link its PNG (`png`, relative
/// to `dir`) beside it; the files written are added to `files`.
pub fn write(
    dir: &Path,
    index: u64,
    subset: Option<Subset>,
    products: &ImageProducts,
    artifacts: &Artifacts,
    png: &str,
    files: &mut Vec<String>,
) -> anyhow::Result<()> {
    let sets = sets(artifacts);
    let Some(product) = products.product.as_ref().filter(|_| !sets.is_empty()) else {
        return Ok(());
    };
    let (w, h) = (product.frame.width, product.frame.height);
    let labels = labels(products);
    for set in sets {
        let text: String = labels
            .iter()
            .map(|(b, l)| match set {
                Set::Obb => l.obb_line(w, h),
                Set::Keypoints => l.keypoint_line(b, w, h),
            })
            .collect();
        let (png_rel, label_rel) = paths(set, index, subset);
        store::fs::link_or_copy(&dir.join(png), &dir.join(&png_rel))?;
        store::fs::create(&dir.join(&label_rel), text)?;
        files.extend([png_rel, label_rel]);
    }
    Ok(())
}
