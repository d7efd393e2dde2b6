//! COCO JSON (the "object detection" format of cocodataset.org/#format-data): one file per split,
//! `<split>.json`, with `images` (`file_name` relative to the run's output, which is the image
//! root), `annotations` (pixel `bbox` `[x, y, width, height]` from the top-left corner, its
//! `area`, `iscrowd` 0) and `categories`; and, for each detector of the detect stage, its
//! predictions on the detected split in COCO's results format, `detections_<detector>.json`
//! (a list of `image_id`, `category_id`, `bbox`, `score`), which `COCO.loadRes` reads.
//!
//! Boxes come from the YOLO label and prediction files scaled by each PNG's size, exactly as
//! `soig eval` scales them, so pycocotools scores these files as `soig eval --mode coco` scores
//! the text files. An image may have any number of boxes, none included. Image ids are the
//! campaign's image indices (`img_000042.png` is image 42; COCO allows 0); annotation ids count
//! from 1 in each file (pycocotools reads an id of 0 as "unmatched"). YOLO class `c` is COCO
//! category `c + 1`, as torchvision's detection models keep 0 for the background.

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::{Deserialize, Serialize};

use super::{Split, detected_split, detectors, identity, image_index, splits, stems};
use crate::metrics::read_yolo_file;

/// The classes of a soig dataset (`data.yaml`'s `names`).
const CLASSES: [&str; 1] = ["debris"];

#[derive(Serialize, Deserialize, Debug, PartialEq)]
pub struct Dataset {
    pub info: Info,
    pub images: Vec<Image>,
    pub annotations: Vec<Annotation>,
    pub categories: Vec<Category>,
}

#[derive(Serialize, Deserialize, Debug, PartialEq)]
pub struct Info {
    pub description: String,
    pub version: String,
}

#[derive(Serialize, Deserialize, Debug, PartialEq)]
pub struct Image {
    pub id: u64,
    pub file_name: String,
    pub width: u32,
    pub height: u32,
}

#[derive(Serialize, Deserialize, Debug, PartialEq)]
pub struct Annotation {
    pub id: u64,
    pub image_id: u64,
    pub category_id: u32,
    pub bbox: [f64; 4],
    pub area: f64,
    pub iscrowd: u8,
    /// The object, its id (NORAD number, or a generated object's id) and its source
    /// (`identity::Identity`), from the image's truth sidecar: extra keys, which pycocotools
    /// keeps and ignores. Absent when the output has no sidecar for the image.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_id: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

#[derive(Serialize, Deserialize, Debug, PartialEq)]
pub struct Category {
    pub id: u32,
    pub name: String,
    pub supercategory: String,
}

/// One prediction in COCO's results format.
#[derive(Serialize, Deserialize, Debug, PartialEq)]
pub struct Result {
    pub image_id: u64,
    pub category_id: u32,
    pub bbox: [f64; 4],
    pub score: f64,
}

/// Normalised `[x1, y1, x2, y2]` to pixel `[x, y, w, h]` in an image of `w` x `h` pixels, as
/// `ImageEval::scaled` and the COCO metric's `xywh` compute it (the same floats).
fn pixel_xywh(b: [f64; 4], w: u32, h: u32) -> [f64; 4] {
    let (sx, sy) = (f64::from(w), f64::from(h));
    let (x1, y1, x2, y2) = (b[0] * sx, b[1] * sy, b[2] * sx, b[3] * sy);
    [x1, y1, x2 - x1, y2 - y1]
}

/// The COCO category of a YOLO class read from `path`.
fn category(class: u32, path: &Path) -> anyhow::Result<u32> {
    if (class as usize) < CLASSES.len() {
        Ok(class + 1)
    } else {
        anyhow::bail!(
            "{}: class {class}, but a soig dataset has {} class(es): {CLASSES:?}",
            path.display(),
            CLASSES.len()
        )
    }
}

/// An image of a split: its id, PNG (relative to the output) and size.
struct SplitImage {
    stem: String,
    image: Image,
}

/// The images of `split`: every label file with its PNG.
fn split_images(output: &Path, split: &Split) -> anyhow::Result<Vec<SplitImage>> {
    stems(&output.join(&split.labels), "txt")?
        .into_iter()
        .map(|stem| {
            let file_name = format!("{}/{stem}.png", split.images);
            let png = output.join(&file_name);
            let (width, height) = image::image_dimensions(&png)
                .with_context(|| format!("reading the size of {}", png.display()))?;
            Ok(SplitImage {
                image: Image {
                    id: image_index(&stem, &png)?,
                    file_name,
                    width,
                    height,
                },
                stem,
            })
        })
        .collect()
}

/// The COCO dataset of one split.
fn dataset(output: &Path, split: &Split) -> anyhow::Result<Dataset> {
    let images = split_images(output, split)?;
    let mut annotations = Vec::new();
    for im in &images {
        let path = output.join(&split.labels).join(format!("{}.txt", im.stem));
        let boxes = read_yolo_file(&path, false)?;
        let truth = output.join("truth").join(format!("{}.json", im.stem));
        let identities = if truth.is_file() {
            identity::of_labels(&truth, &path, boxes.len())?
                .into_iter()
                .map(Some)
                .collect()
        } else {
            vec![None; boxes.len()]
        };
        for ((class, b, _), who) in boxes.into_iter().zip(identities) {
            let bbox = pixel_xywh(b, im.image.width, im.image.height);
            annotations.push(Annotation {
                id: annotations.len() as u64 + 1,
                image_id: im.image.id,
                category_id: category(class, &path)?,
                bbox,
                area: bbox[2] * bbox[3],
                iscrowd: 0,
                object_id: who.as_ref().map(|w| w.id),
                source: who.as_ref().map(|w| w.source.clone()),
                object: who.map(|w| w.object),
            });
        }
    }
    Ok(Dataset {
        info: Info {
            description: format!(
                "soig dataset, {} split; image files relative to the run's output",
                split.name
            ),
            version: env!("CARGO_PKG_VERSION").into(),
        },
        images: images.into_iter().map(|i| i.image).collect(),
        annotations,
        categories: CLASSES
            .iter()
            .enumerate()
            .map(|(c, name)| Category {
                id: c as u32 + 1,
                name: name.to_string(),
                supercategory: "space object".into(),
            })
            .collect(),
    })
}

/// The predictions of `detector` on `split`'s images, in COCO's results format.
fn results(output: &Path, split: &Split, detector: &str) -> anyhow::Result<Vec<Result>> {
    let dir = output.join("report/predictions").join(detector);
    let images = split_images(output, split)?;
    let mut out = Vec::new();
    for stem in stems(&dir, "txt")? {
        let path = dir.join(format!("{stem}.txt"));
        let Some(im) = images.iter().find(|i| i.stem == stem) else {
            anyhow::bail!(
                "{}: predictions for an image that is not in {}",
                path.display(),
                output.join(&split.labels).display()
            );
        };
        for (class, b, score) in read_yolo_file(&path, true)? {
            out.push(Result {
                image_id: im.image.id,
                category_id: category(class, &path)?,
                bbox: pixel_xywh(b, im.image.width, im.image.height),
                score,
            });
        }
    }
    Ok(out)
}

/// Write `<split>.json` for each split of `output` and `detections_<detector>.json` for each
/// detector into `dest`; returns the paths written.
pub fn write(output: &Path, dest: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let splits = splits(output);
    if splits.is_empty() {
        anyhow::bail!(
            "{}: no labels/ folder, so no dataset to export (the campaign needs the `enhance` stage)",
            output.display()
        );
    }
    crate::store::fs::create_dir_all(dest)?;
    let mut written = Vec::new();
    let mut put = |name: String, json: String| -> anyhow::Result<()> {
        let path = dest.join(name);
        crate::store::fs::create(&path, json + "\n")?;
        written.push(path);
        Ok(())
    };
    for split in &splits {
        put(
            format!("{}.json", split.name),
            serde_json::to_string(&dataset(output, split)?)?,
        )?;
    }
    if let Some(split) = detected_split(&splits) {
        for detector in detectors(output)? {
            let r = results(output, split, &detector)?;
            put(
                format!("detections_{detector}.json"),
                serde_json::to_string(&r)?,
            )?;
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A split folder with two images: one with two boxes, one with none.
    #[test]
    fn any_number_of_boxes_per_image_none_included() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        std::fs::create_dir_all(out.join("labels")).unwrap();
        std::fs::create_dir_all(out.join("images")).unwrap();
        std::fs::create_dir_all(out.join("report/predictions/streak")).unwrap();
        for (i, labels) in ["0 0.5 0.25 0.5 0.25\n0 0.125 0.75 0.25 0.5\n", ""]
            .iter()
            .enumerate()
        {
            let stem = format!("img_{:06}", i + 7);
            std::fs::write(out.join(format!("labels/{stem}.txt")), labels).unwrap();
            image::GrayImage::new(64, 32)
                .save(out.join(format!("images/{stem}.png")))
                .unwrap();
        }
        std::fs::write(
            out.join("report/predictions/streak/img_000008.txt"),
            "0 0.5 0.5 0.25 0.25 0.75\n",
        )
        .unwrap();
        let files = write(out, &out.join("coco")).unwrap();
        assert_eq!(files.len(), 2);
        let d: Dataset =
            serde_json::from_slice(&std::fs::read(out.join("coco/all.json")).unwrap()).unwrap();
        assert_eq!(d.images.len(), 2);
        assert_eq!((d.images[0].id, d.images[0].width), (7, 64));
        assert_eq!(d.images[1].file_name, "images/img_000008.png");
        // 0.5, 0.25 of a 64 x 32 image: centre (32, 8), size 32 x 8 -> corner (16, 4).
        assert_eq!(d.annotations[0].bbox, [16.0, 4.0, 32.0, 8.0]);
        assert_eq!(d.annotations[0].area, 256.0);
        assert_eq!(d.annotations[1].bbox, [0.0, 16.0, 16.0, 16.0]);
        assert_eq!(
            d.annotations.iter().map(|a| a.id).collect::<Vec<_>>(),
            [1, 2]
        );
        assert!(d.annotations.iter().all(|a| a.image_id == 7));
        let r: Vec<Result> = serde_json::from_slice(
            &std::fs::read(out.join("coco/detections_streak.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(
            r,
            [Result {
                image_id: 8,
                category_id: 1,
                bbox: [24.0, 12.0, 16.0, 8.0],
                score: 0.75
            }]
        );
    }

    #[test]
    fn a_class_outside_the_dataset_names_the_file() {
        let e = category(3, Path::new("labels/img_000001.txt")).unwrap_err();
        assert!(
            e.to_string().contains("labels/img_000001.txt: class 3"),
            "{e}"
        );
    }
}
