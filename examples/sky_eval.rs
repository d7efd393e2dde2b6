//! Re-run the streak detector of `soig run`'s detect stage on a finished survey run's test
//! images, one thread, without rendering again: the star-trail prediction and
//! the streak detector told of them (`StreakDetector`, as the run), timed per image. Writes YOLO-format predictions (for
//! `soig eval`) and prints recall at confidence 0.5 and IoU 0.5 by angle to the star trails
//! (0-2, 2-7, 7-90 degrees), the false positives at that confidence, and the median time.
//! `SKY_EVAL_ONLY=000035,000053` runs only the images whose stems end so (to look at a few).
//!
//! ```sh
//! cargo run --release --example sky_eval -- CAMPAIGN RUN_DIR PRED_DIR [--set k=v]...
//! soig eval --labels RUN_DIR/labels/test --predictions PRED_DIR --images RUN_DIR/images/test
//! ```

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::{Path, PathBuf};
use std::time::Instant;

use soig::campaign::Campaign;
use soig::detect::detector::Frame;
use soig::detect::{Stars, StreakDetector};

// The allocator of `soig run`, whose detect stage this times (Table 6): with glibc's malloc each
// image paid the page faults of its multi-MB maps again.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut sets = Vec::new();
    let mut pos = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--set" {
            sets.push(it.next().expect("--set k=v").clone());
        } else {
            pos.push(a.clone());
        }
    }
    let [campaign, run, out] = &pos[..] else {
        anyhow::bail!("usage: sky_eval CAMPAIGN RUN_DIR PRED_DIR [--set k=v]...");
    };
    let campaign = Campaign::load_with_overrides(Path::new(campaign), &sets)?;
    let x = soig::experiment::of(&campaign);
    let inputs = soig::experiment::inputs(&campaign)?;
    let detector = StreakDetector {
        params: campaign.resolved.detect.streak.clone(),
    };
    let run = PathBuf::from(run);
    let out = PathBuf::from(out);
    std::fs::create_dir_all(&out)?;
    let mut pngs: Vec<PathBuf> = std::fs::read_dir(run.join("images/test"))?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()?;
    pngs.sort();
    let mut tally = Tally::default();
    let mut ms = Vec::new();
    for png in &pngs {
        let stem = png.file_stem().unwrap().to_string_lossy().into_owned();
        if let Ok(only) = std::env::var("SKY_EVAL_ONLY")
            && !only.split(',').any(|o| stem.ends_with(o))
        {
            continue;
        }
        let index: u64 = stem.trim_start_matches("img_").parse()?;
        let truth_path = run.join("truth").join(format!("{stem}.json"));
        let truth: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&truth_path)?)?;
        eprintln!("IMG {stem}");
        let img = image::open(png)?.to_luma8();
        let (w, h) = (img.width() as usize, img.height() as usize);
        let pixels = img.into_raw();
        let frame_kind = truth["frame"]["kind"]
            .as_str()
            .unwrap_or("original")
            .to_string();
        let trail = truth["pointing"]["trail_angle_deg"].as_f64();
        // As the run's detect stage: a rotated frame has its trails along x.
        let trail_png = trail.map(|t| if frame_kind == "rotated" { 0.0 } else { t });
        let t = Instant::now();
        let stars = soig::star_trails::of_image(&x, &inputs, index, &pixels, w, h)?;
        if let Some(dir) = std::env::var_os("SKY_EVAL_DUMP") {
            let t: Vec<(Vec<(f64, f64)>, f64)> = stars
                .iter()
                .map(|s| (s.nodes.clone(), s.electrons))
                .collect();
            std::fs::write(
                Path::new(&dir).join(format!("{stem}.json")),
                serde_json::to_string(&t)?,
            )?;
        }
        // SKY_EVAL_PLAIN=1: the angle-only detector, for comparison.
        let told = if std::env::var_os("SKY_EVAL_PLAIN").is_some() {
            Stars::told(trail_png, None)
        } else {
            Stars::told(trail_png, Some(&stars))
        };
        // As the run's record gives it: the original image's outline in a rotated or padded
        // frame (the truth holds the frame, and the run's sensor its original size).
        let footprint =
            match serde_json::from_value::<soig::geometry::Frame>(truth["frame"].clone()) {
                Ok(f) => f.footprint(x.sensor.width_px, x.sensor.height_px),
                Err(_) => None,
            };
        let frame = Frame {
            pixels: &pixels,
            width: w,
            height: h,
            footprint,
        };
        let (cands, _) = detector.detect_measuring(frame, told);
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        eprintln!("TIME {stem} {:.0}", ms[ms.len() - 1]);
        // The detect stage's lines (`soig eval` reads them back to the bit).
        let lines: String = cands
            .iter()
            .map(|c| soig::report::yolo_prediction_line(&c.detection, w, h))
            .collect();
        std::fs::write(out.join(format!("{stem}.txt")), lines)?;
        tally.add(&stem, &truth, trail, &cands);
    }
    ms.sort_by(f64::total_cmp);
    let Tally {
        found,
        total,
        tp,
        fp,
    } = tally;
    println!(
        "images {}  recall 0-2: {}/{}  2-7: {}/{}  7-90: {}/{}  TP {tp} FP {fp}  P@0.5 {:.3}  median {:.1} ms  mean {:.1} ms  max {:.1} ms",
        pngs.len(),
        found[0],
        total[0],
        found[1],
        total[1],
        found[2],
        total[2],
        tp as f64 / (tp + fp).max(1) as f64,
        ms[ms.len() / 2],
        ms.iter().sum::<f64>() / ms.len() as f64,
        ms[ms.len() - 1]
    );
    Ok(())
}

/// Recall at confidence 0.5 and IoU 0.5 by angle band to the trails (0-2, 2-7, 7-90
/// degrees), and the true and false positives at that confidence.
#[derive(Default)]
struct Tally {
    found: [usize; 3],
    total: [usize; 3],
    tp: usize,
    fp: usize,
}

impl Tally {
    fn add(
        &mut self,
        stem: &str,
        truth: &serde_json::Value,
        trail: Option<f64>,
        cands: &[soig::detect::streak::Candidate],
    ) {
        // The label box and the streak's angle to the trails (as the report bins it).
        let b = &truth["label_box_final_px"];
        let label = [
            b["x_min"].as_f64().unwrap(),
            b["y_min"].as_f64().unwrap(),
            b["x_max"].as_f64().unwrap(),
            b["y_max"].as_f64().unwrap(),
        ];
        let s0 = &truth["streak_start_px"];
        let s1 = &truth["streak_end_px"];
        let (dx, dy) = (
            s1[0].as_f64().unwrap() - s0[0].as_f64().unwrap(),
            s1[1].as_f64().unwrap() - s0[1].as_f64().unwrap(),
        );
        let d = (dy.atan2(dx).to_degrees() - trail.unwrap_or(0.0)).rem_euclid(180.0);
        let angle = d.min(180.0 - d);
        let band = if angle < 2.0 {
            0
        } else if angle < 7.0 {
            1
        } else {
            2
        };
        self.total[band] += 1;
        let mut matched = false;
        for c in cands.iter().filter(|c| c.detection.score >= 0.5) {
            let d = &c.detection;
            let iou = iou(&label, &[d.x1, d.y1, d.x2, d.y2]);
            if iou >= 0.5 && !matched {
                matched = true;
                self.tp += 1;
            } else {
                self.fp += 1;
                eprintln!(
                    "FP {stem} band {band} score {:.3} iou {iou:.2} len {:.0} orient {:.1} ends {:?}",
                    d.score, c.length_px, c.orientation_deg, c.ends
                );
            }
        }
        if matched {
            self.found[band] += 1;
        } else {
            eprintln!(
                "MISS {stem} band {band} angle {angle:.2} snr {:.1}",
                truth["snr_matched_filter"]
            );
        }
    }
}

fn iou(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let ix = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let iy = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let i = ix * iy;
    i / ((a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - i)
}
