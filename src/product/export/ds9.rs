//! DS9 region files (ds9.si.edu/doc/ref/region.html, version 4.1) over each image's FITS, in
//! DS9's `image` coordinates: 1-based pixel centres, y along the FITS rows (soig's 0-based pixel
//! coordinates plus one). `truth/<image>.reg` holds the debris' streak as rendered (a line from
//! its first to its last trajectory sample, jitter included, labelled with the object and its id,
//! `NAME (NORAD n)`, or `NAME (id n)` for a generated object) and its
//! label box in the original image; `<detector>/<image>.reg` holds that detector's boxes on each
//! detected image (none, one or many), mapped back from the PNG's frame (padded or rotated) to
//! the FITS pixels through the frame the truth records: a polygon of the box's four corners,
//! labelled with its score. Coordinates are written to a thousandth of a pixel.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::{detected_split, detectors, identity, splits, stems};
use crate::geometry::{BoxPx, Frame};
use crate::metrics::read_yolo_file;

/// What the regions need of a truth sidecar: its frame and its objects (the one object of a
/// sidecar, or each of its `objects` list: none, one or many).
struct Truth {
    objects: Vec<Object>,
    frame: Option<Frame>,
}

/// What the regions need of one object of a truth sidecar.
#[derive(Deserialize)]
struct Object {
    object: String,
    norad: u64,
    #[serde(default)]
    source: Option<String>,
    streak_start_px: [f64; 2],
    streak_end_px: [f64; 2],
    label_box_px: Option<BoxPx>,
}

fn read_truth(path: &Path) -> anyhow::Result<Truth> {
    #[derive(Deserialize)]
    struct Image {
        frame: Option<Frame>,
    }
    let sidecar = crate::truth_sidecar::read::<Image, Object>(path)?;
    Ok(Truth {
        objects: sidecar.objects,
        frame: sidecar.frame.frame,
    })
}

impl Object {
    /// Its text: name and id, as the COCO annotations carry them (`identity::Identity`).
    fn label(&self) -> String {
        identity::Identity {
            object: self.object.clone(),
            id: self.norad,
            source: self.source.clone().unwrap_or_default(),
        }
        .text()
    }
}

/// The file's first lines: format, what it shows, its colour, the coordinate system.
fn header(what: &str, color: &str) -> String {
    format!("# Region file format: DS9 version 4.1\n# {what}\nglobal color={color}\nimage\n")
}

/// DS9 text is delimited by braces, so none may appear inside it.
fn text(s: &str) -> String {
    s.replace('{', "(").replace('}', ")")
}

/// The truth regions of one image.
fn truth_regions(stem: &str, t: &Truth) -> String {
    let mut s = header(
        &format!("soig truth of {stem}: debris streak (first to last sample) and label box"),
        "green",
    );
    for o in &t.objects {
        let [x0, y0] = o.streak_start_px;
        let [x1, y1] = o.streak_end_px;
        let _ = writeln!(
            s,
            "line({:.3},{:.3},{:.3},{:.3}) # text={{{}}}",
            x0 + 1.0,
            y0 + 1.0,
            x1 + 1.0,
            y1 + 1.0,
            text(&o.label())
        );
        if let Some(b) = &o.label_box_px {
            let _ = writeln!(
                s,
                "box({:.3},{:.3},{:.3},{:.3},0)",
                (b.x_min + b.x_max) / 2.0 + 1.0,
                (b.y_min + b.y_max) / 2.0 + 1.0,
                b.x_max - b.x_min,
                b.y_max - b.y_min
            );
        }
    }
    s
}

/// The regions of one detector's boxes (normalised `[x1, y1, x2, y2]` in the PNG, with scores)
/// on an image whose PNG has `frame`.
fn detection_regions(
    stem: &str,
    detector: &str,
    frame: &Frame,
    boxes: &[([f64; 4], f64)],
) -> String {
    let mut s = header(
        &format!(
            "soig {detector} detections on {stem} ({} boxes), mapped from the PNG's {} frame",
            boxes.len(),
            frame.kind.name()
        ),
        "red",
    );
    let (w, h) = (frame.width as f64, frame.height as f64);
    for (b, score) in boxes {
        // PNG pixel edges to pixel centres (pixel i spans [i - 0.5, i + 0.5)), back to the
        // original image, then DS9's 1-based pixels.
        let corners = [(b[0], b[1]), (b[2], b[1]), (b[2], b[3]), (b[0], b[3])].map(|(x, y)| {
            let (u, v) = frame.unmap(x * w - 0.5, y * h - 0.5);
            format!("{:.3},{:.3}", u + 1.0, v + 1.0)
        });
        let _ = writeln!(s, "polygon({}) # text={{{score:.3}}}", corners.join(","));
    }
    s
}

/// Write `truth/<image>.reg` for every image of `output` and `<detector>/<image>.reg` for every
/// detected image into `dest`; returns the paths written.
pub fn write(output: &Path, dest: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let truth_dir = output.join("truth");
    let mut written = Vec::new();
    let mut put = |rel: String, body: String| -> anyhow::Result<()> {
        let path = dest.join(rel);
        if let Some(parent) = path.parent() {
            crate::store::fs::create_dir_all(parent)?;
        }
        crate::store::fs::create(&path, body)?;
        written.push(path);
        Ok(())
    };
    // The image sidecars, not the star lists (`<image>_stars.csv`) beside them.
    let images: Vec<String> = stems(&truth_dir, "json")?;
    if images.is_empty() {
        anyhow::bail!("{}: no truth sidecars to export", truth_dir.display());
    }
    for stem in &images {
        let t = read_truth(&truth_dir.join(format!("{stem}.json")))?;
        put(format!("truth/{stem}.reg"), truth_regions(stem, &t))?;
    }
    let splits = splits(output);
    let Some(split) = detected_split(&splits) else {
        return Ok(written);
    };
    for detector in detectors(output)? {
        let dir = output.join("report/predictions").join(&detector);
        for stem in stems(&output.join(&split.labels), "txt")? {
            let truth_path = truth_dir.join(format!("{stem}.json"));
            let frame = read_truth(&truth_path)?.frame.ok_or_else(|| {
                anyhow::anyhow!(
                    "{}: no `frame`, but the image has a PNG",
                    truth_path.display()
                )
            })?;
            let path = dir.join(format!("{stem}.txt"));
            let boxes: Vec<([f64; 4], f64)> = if path.is_file() {
                read_yolo_file(&path, true)?
                    .into_iter()
                    .map(|(_, b, score)| (b, score))
                    .collect()
            } else {
                Vec::new()
            };
            put(
                format!("{detector}/{stem}.reg"),
                detection_regions(&stem, &detector, &frame, &boxes),
            )?;
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::FrameKind;

    #[test]
    fn a_padded_frames_box_lands_back_on_the_fits_pixels() {
        // A 16 px border: PNG pixel edges 26..36 are original pixels 10..19, DS9's 11..20,
        // whose edges are 10.5 and 20.5.
        let frame = Frame::new(FrameKind::Padded, 100, 100, 16, 0.0);
        let (w, h) = (frame.width as f64, frame.height as f64);
        let r = detection_regions(
            "img_000001",
            "streak",
            &frame,
            &[([26.0 / w, 26.0 / h, 36.0 / w, 36.0 / h], 0.5)],
        );
        assert!(
            r.ends_with(
                "polygon(10.500,10.500,20.500,10.500,20.500,20.500,10.500,20.500) # text={0.500}\n"
            ),
            "{r}"
        );
    }

    #[test]
    fn truth_is_one_based_and_its_text_has_no_braces() {
        let t = Truth {
            objects: vec![Object {
                object: "DEB {A}".into(),
                norad: 40989,
                source: None,
                streak_start_px: [0.0, 1.0],
                streak_end_px: [9.0, 4.0],
                label_box_px: Some(BoxPx {
                    x_min: -0.5,
                    y_min: 0.5,
                    x_max: 9.5,
                    y_max: 4.5,
                }),
            }],
            frame: None,
        };
        let r = truth_regions("img_000000", &t);
        assert!(
            r.contains("line(1.000,2.000,10.000,5.000) # text={DEB (A) (NORAD 40989)}\n"),
            "{r}"
        );
        assert!(r.contains("box(5.500,3.500,10.000,4.000,0)\n"), "{r}");
    }
}
