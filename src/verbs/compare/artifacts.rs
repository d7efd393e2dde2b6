//! Which artifacts of two run folders differ, by their manifests' sha256, and how: for PNG and
//! FITS images the pixels that differ and the largest difference, for YOLO labels the boxes
//! that moved (in pixels of the run's image when it has one, else in normalised units).

use std::fmt::Write as _;
use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;

use crate::manifest::Manifest;

/// Files added, removed and changed from the baseline to the run (volatile files excluded).
#[derive(Serialize)]
pub struct Artifacts {
    /// Files the manifests have in common.
    pub common: usize,
    pub added: Vec<String>,
    pub removed: Vec<String>,
    pub changed: Vec<Change>,
}

#[derive(Serialize)]
pub struct Change {
    pub path: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detail: Option<Detail>,
}

#[derive(Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Detail {
    /// Same size: how many pixels differ (in any channel) and by how much at most, in the
    /// image's own unit (8- or 16-bit levels for PNG, ADU or photo-electrons for FITS).
    Pixels {
        differing: usize,
        of: usize,
        largest: f64,
    },
    Size {
        baseline: [usize; 2],
        run: [usize; 2],
    },
    /// Boxes of a YOLO label file, paired by line.
    Boxes {
        moved: Vec<BoxMove>,
        baseline_boxes: usize,
        run_boxes: usize,
    },
    /// The file could not be read as what its name says.
    Unreadable { message: String },
}

/// How one box moved: its centre (dx, dy) and size (dw, dh).
#[derive(Serialize)]
pub struct BoxMove {
    /// Line of the label file, from 1.
    pub line: usize,
    pub dx: f64,
    pub dy: f64,
    pub dw: f64,
    pub dh: f64,
    /// "px", or "normalised" when the run has no image for the label.
    pub unit: &'static str,
}

/// The files manifest `a` lists and `b` does not, in `a`'s order.
fn only_in(a: &Manifest, b: &Manifest) -> Vec<String> {
    a.files
        .keys()
        .filter(|k| !b.files.contains_key(*k))
        .cloned()
        .collect()
}

/// Compare the manifests' file lists and look into the changed images and labels.
pub fn diff(
    bdir: &Path,
    baseline: &Manifest,
    rdir: &Path,
    run: &Manifest,
) -> anyhow::Result<Artifacts> {
    let added = only_in(run, baseline);
    let removed = only_in(baseline, run);
    let changed_paths: Vec<&String> = baseline
        .files
        .iter()
        .filter(|(k, e)| run.files.get(*k).is_some_and(|r| r.sha256 != e.sha256))
        .map(|(k, _)| k)
        .collect();
    let changed = changed_paths
        .into_par_iter()
        .map(|path| Change {
            path: path.clone(),
            detail: detail(&bdir.join(path), &rdir.join(path), path, rdir),
        })
        .collect();
    Ok(Artifacts {
        common: baseline
            .files
            .keys()
            .filter(|k| run.files.contains_key(*k))
            .count(),
        added,
        removed,
        changed,
    })
}

fn detail(b: &Path, r: &Path, rel: &str, rdir: &Path) -> Option<Detail> {
    let result = if rel.ends_with(".png") {
        png(b, r)
    } else if rel.ends_with(".fits") {
        fits(b, r)
    } else if rel.starts_with("labels/") && rel.ends_with(".txt") {
        labels(b, r, rel, rdir)
    } else {
        return None;
    };
    Some(result.unwrap_or_else(|message| Detail::Unreadable { message }))
}

/// Pixels that differ, and the largest difference, of two equally sized sample arrays with
/// `channels` samples per pixel.
fn pixels<T: Copy + Into<f64>>(a: &[T], b: &[T], channels: usize) -> Detail {
    let (mut differing, mut largest) = (0, 0.0f64);
    for (pa, pb) in a.chunks(channels).zip(b.chunks(channels)) {
        let mut differs = false;
        for (x, y) in pa.iter().zip(pb) {
            let (x, y): (f64, f64) = ((*x).into(), (*y).into());
            // NaN != NaN: a NaN sample counts as differing (f64::max then ignores it).
            if x != y {
                differs = true;
                largest = largest.max((x - y).abs());
            }
        }
        differing += usize::from(differs);
    }
    Detail::Pixels {
        differing,
        of: a.len() / channels,
        largest,
    }
}

fn png(b: &Path, r: &Path) -> Result<Detail, String> {
    let open = |p: &Path| image::open(p).map_err(|e| format!("{}: {e}", p.display()));
    let (ib, ir) = (open(b)?, open(r)?);
    let (sb, sr) = (
        [ib.width() as usize, ib.height() as usize],
        [ir.width() as usize, ir.height() as usize],
    );
    if sb != sr {
        return Ok(Detail::Size {
            baseline: sb,
            run: sr,
        });
    }
    let eight_bit = |i: &image::DynamicImage| {
        i.color().bytes_per_pixel() as usize == i.color().channel_count() as usize
    };
    // Both as RGBA in their own depth, so a gray image compares with a gray one level by level.
    Ok(if eight_bit(&ib) && eight_bit(&ir) {
        pixels(&ib.to_rgba8().into_raw(), &ir.to_rgba8().into_raw(), 4)
    } else {
        pixels(&ib.to_rgba16().into_raw(), &ir.to_rgba16().into_raw(), 4)
    })
}

fn fits(b: &Path, r: &Path) -> Result<Detail, String> {
    let read = |p: &Path| crate::fits::read_f64(p).map_err(|e| format!("{}: {e}", p.display()));
    let ((pb, hb, wb), (pr, hr, wr)) = (read(b)?, read(r)?);
    if (hb, wb) != (hr, wr) {
        return Ok(Detail::Size {
            baseline: [wb, hb],
            run: [wr, hr],
        });
    }
    Ok(pixels(&pb, &pr, 1))
}

/// `cls xc yc w h` rows of a YOLO label file.
fn boxes(p: &Path) -> Result<Vec<[f64; 4]>, String> {
    let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(i, l)| {
            let v: Vec<f64> = l
                .split_whitespace()
                .skip(1)
                .map(|f| f.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|e| format!("{} line {}: {e}", p.display(), i + 1))?;
            match v[..] {
                [xc, yc, w, h, ..] => Ok([xc, yc, w, h]),
                _ => Err(format!(
                    "{} line {}: expected `cls xc yc w h`",
                    p.display(),
                    i + 1
                )),
            }
        })
        .collect()
}

fn labels(b: &Path, r: &Path, rel: &str, rdir: &Path) -> Result<Detail, String> {
    let (bb, br) = (boxes(b)?, boxes(r)?);
    // labels/<split>/<stem>.txt labels images/<split>/<stem>.png.
    let image = rdir.join(
        rel.replacen("labels/", "images/", 1)
            .trim_end_matches(".txt")
            .to_string()
            + ".png",
    );
    let (scale, unit) = match image::image_dimensions(&image) {
        Ok((w, h)) => ([w as f64, h as f64], "px"),
        Err(_) => ([1.0, 1.0], "normalised"),
    };
    let moved = bb
        .iter()
        .zip(&br)
        .enumerate()
        .filter(|(_, (x, y))| x != y)
        .map(|(i, (x, y))| BoxMove {
            line: i + 1,
            dx: (y[0] - x[0]) * scale[0],
            dy: (y[1] - x[1]) * scale[1],
            dw: (y[2] - x[2]) * scale[0],
            dh: (y[3] - x[3]) * scale[1],
            unit,
        })
        .collect();
    Ok(Detail::Boxes {
        moved,
        baseline_boxes: bb.len(),
        run_boxes: br.len(),
    })
}

/// The artifacts part of `soig compare`'s text.
pub fn text(s: &mut String, a: &Artifacts) {
    let _ = writeln!(
        s,
        "artifacts: {} changed, {} added, {} removed (of {} in common)",
        a.changed.len(),
        a.added.len(),
        a.removed.len(),
        a.common
    );
    // What changed in content first (pixels, boxes), then the files added and removed, then
    // other changed files, and last the images whose pixels are the same (a header changed).
    let mut lines: Vec<(u8, String)> = a
        .changed
        .iter()
        .map(|c| match &c.detail {
            None => (2, format!("changed {}", c.path)),
            Some(d) => (rank(d), format!("changed {}: {}", c.path, describe(d))),
        })
        .collect();
    lines.extend(a.added.iter().map(|p| (1, format!("added {p}"))));
    lines.extend(a.removed.iter().map(|p| (1, format!("removed {p}"))));
    lines.sort_by_key(|(rank, _)| *rank);
    let lines: Vec<String> = lines.into_iter().map(|(_, l)| l).collect();
    super::list(s, &lines);
}

/// 0 when the content differs, 3 when only what lies around it does.
fn rank(d: &Detail) -> u8 {
    match d {
        Detail::Pixels { differing: 0, .. } => 3,
        Detail::Boxes {
            moved,
            baseline_boxes,
            run_boxes,
        } if moved.is_empty() && baseline_boxes == run_boxes => 3,
        _ => 0,
    }
}

fn describe(d: &Detail) -> String {
    match d {
        Detail::Pixels {
            differing,
            of,
            largest,
        } => match differing {
            0 => format!("same {of} pixels (the header or metadata differs)"),
            _ => format!("{differing} of {of} pixels differ, largest difference {largest}"),
        },
        Detail::Size { baseline, run } => format!(
            "size {}x{} -> {}x{}",
            baseline[0], baseline[1], run[0], run[1]
        ),
        Detail::Boxes {
            moved,
            baseline_boxes,
            run_boxes,
        } => {
            let mut s = if baseline_boxes == run_boxes {
                String::new()
            } else {
                format!("{baseline_boxes} -> {run_boxes} boxes; ")
            };
            let moves: Vec<String> = moved
                .iter()
                .map(|m| {
                    format!(
                        "box {} moved by ({:+.3}, {:+.3}), size by ({:+.3}, {:+.3}) {}",
                        m.line, m.dx, m.dy, m.dw, m.dh, m.unit
                    )
                })
                .collect();
            s.push_str(&moves.join("; "));
            s
        }
        Detail::Unreadable { message } => format!("unreadable: {message}"),
    }
}
