//! Detection efficiency: each detector's recall and precision against the debris' magnitude,
//! its integrated matched-filter SNR and its streak length, binned, and the magnitude at which
//! recall falls to 50% (the limiting magnitude an SSA sensor is judged by).
//!
//! Every soig test image holds one debris object. An image goes into the bin of its object's
//! value; the object counts as found when a detection with `score >= conf` takes it at
//! IoU >= 0.5 (`metrics::match_image`, the matching behind the report's P/R@conf), and the
//! image's detections that take no object are that bin's false positives. Images whose debris
//! left no label (no photon landed) have no object and are left out.
//!
//! Bins: magnitude in steps of 0.5 mag; SNR and length in octaves (2^k .. 2^(k+1)), since
//! both span orders of magnitude. The 50% magnitude is interpolated linearly on the isotonic
//! (never rising with magnitude) fit of recall to the magnitude bins: see [`half_recall`].

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::metrics::{ImageEval, match_image};

/// What the truth sidecar says of an image's debris, as far as efficiency needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectFacts {
    pub magnitude: f64,
    /// Integrated matched-filter SNR of the streak (`Truth::snr_matched_filter`).
    pub snr: f64,
    /// Distance between the first and last trajectory samples, pixels.
    pub length_px: f64,
    /// Angle between the streak and the star trails, degrees in [0, 90] (survey pointing; NaN
    /// under fixed pointing, where stars make no trails).
    pub trail_angle_deg: f64,
    /// Per-pixel SNR: the expected debris ADU per footprint pixel over the background's
    /// standard deviation (`Scene::snr_noise_sigma`; NaN, left out of the bins, for a sidecar
    /// older than it). A long streak can have a high matched-filter SNR and a per-pixel one
    /// well below 1: binning by both shows which a detector needs (issue #36).
    pub pixel_snr: f64,
}

/// One object of a truth sidecar, as far as efficiency needs it.
#[derive(Deserialize)]
struct Sidecar {
    magnitude: f64,
    snr_matched_filter: f64,
    #[serde(default)]
    snr_noise_sigma: Option<f64>,
    streak_start_px: [f64; 2],
    streak_end_px: [f64; 2],
    /// Whether the object has a label in the PNG (`null` when no photon of it landed).
    #[serde(default)]
    label_box_final_px: Option<serde_json::Value>,
}

impl ObjectFacts {
    /// The objects of a truth sidecar (`truth/<stem>.json`) that have a label, in the order of
    /// the image's label lines: the one object of a sidecar, or each of its `objects` list.
    pub fn read(path: &Path) -> anyhow::Result<Vec<ObjectFacts>> {
        #[derive(Deserialize)]
        struct Image {
            pointing: Pointing,
        }
        #[derive(Deserialize)]
        struct Pointing {
            trail_angle_deg: Option<f64>,
        }
        let sidecar = crate::truth_sidecar::read::<Image, Sidecar>(path)?;
        let trails = sidecar.frame.pointing.trail_angle_deg;
        Ok(sidecar
            .objects
            .into_iter()
            .filter(|s| crate::truth_sidecar::labelled(&s.label_box_final_px))
            .map(|s| {
                let [x0, y0] = s.streak_start_px;
                let [x1, y1] = s.streak_end_px;
                ObjectFacts {
                    magnitude: s.magnitude,
                    snr: s.snr_matched_filter,
                    length_px: (x1 - x0).hypot(y1 - y0),
                    trail_angle_deg: trails.map_or(f64::NAN, |t| {
                        let d = ((y1 - y0).atan2(x1 - x0).to_degrees() - t).rem_euclid(180.0);
                        d.min(180.0 - d)
                    }),
                    pixel_snr: s.snr_noise_sigma.unwrap_or(f64::NAN),
                }
            })
            .collect())
    }
}

/// The quantities efficiency is binned against.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    Magnitude,
    SnrMatchedFilter,
    StreakLengthPx,
    /// Angle to the star trails in three bands: 0-2, 2-7 and 7-90 degrees (within 7 degrees
    /// the angle alone no longer tells debris from stars, issue #30).
    TrailAngleDeg,
    SnrPerPixel,
}

/// Edges of the bands of angle to the star trails, degrees.
const TRAIL_ANGLE_EDGES: [f64; 4] = [0.0, 2.0, 7.0, 90.0];

impl Quantity {
    pub const ALL: [Quantity; 5] = [
        Quantity::Magnitude,
        Quantity::SnrMatchedFilter,
        Quantity::StreakLengthPx,
        Quantity::TrailAngleDeg,
        Quantity::SnrPerPixel,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Quantity::Magnitude => "debris magnitude",
            Quantity::SnrMatchedFilter => "matched-filter SNR",
            Quantity::StreakLengthPx => "streak length (px)",
            Quantity::TrailAngleDeg => "angle to the star trails (deg)",
            Quantity::SnrPerPixel => "per-pixel SNR",
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Quantity::Magnitude => "magnitude",
            Quantity::SnrMatchedFilter => "snr_matched_filter",
            Quantity::StreakLengthPx => "streak_length_px",
            Quantity::TrailAngleDeg => "trail_angle_deg",
            Quantity::SnrPerPixel => "snr_per_pixel",
        }
    }

    fn value(self, f: &ObjectFacts) -> f64 {
        match self {
            Quantity::Magnitude => f.magnitude,
            Quantity::SnrMatchedFilter => f.snr,
            Quantity::StreakLengthPx => f.length_px,
            Quantity::TrailAngleDeg => f.trail_angle_deg,
            Quantity::SnrPerPixel => f.pixel_snr,
        }
    }

    /// The bin index of a value (None for a value no bin holds: non-finite, or not positive
    /// on an octave scale).
    fn bin(self, v: f64) -> Option<i64> {
        let k = match self {
            Quantity::TrailAngleDeg if (0.0..=90.0).contains(&v) => {
                return TRAIL_ANGLE_EDGES[1..]
                    .iter()
                    .position(|&e| v < e)
                    .or(Some(2))
                    .map(|k| k as i64);
            }
            Quantity::TrailAngleDeg => return None,
            Quantity::Magnitude => (v / 0.5).floor(),
            _ if v > 0.0 => v.log2().floor(),
            _ => return None,
        };
        k.is_finite().then_some(k as i64)
    }

    fn edges(self, k: i64) -> (f64, f64) {
        match self {
            Quantity::Magnitude => (k as f64 * 0.5, (k + 1) as f64 * 0.5),
            Quantity::TrailAngleDeg => (
                TRAIL_ANGLE_EDGES[k as usize],
                TRAIL_ANGLE_EDGES[k as usize + 1],
            ),
            _ => (2f64.powi(k as i32), 2f64.powi(k as i32 + 1)),
        }
    }

    /// The bin's centre: arithmetic for magnitude, geometric for octaves.
    fn centre(self, lo: f64, hi: f64) -> f64 {
        match self {
            Quantity::Magnitude | Quantity::TrailAngleDeg => (lo + hi) / 2.0,
            _ => (lo * hi).sqrt(),
        }
    }
}

/// One bin of one quantity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bin {
    pub lo: f64,
    pub hi: f64,
    pub objects: usize,
    pub found: usize,
    pub false_positives: usize,
    /// found / objects.
    pub recall: f64,
    /// found / (found + false positives); None when the bin's images hold no detection.
    pub precision: Option<f64>,
}

/// Where recall crosses 50% on the magnitude scale.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum HalfRecall {
    /// Interpolated between two bin centres.
    At { magnitude: f64 },
    /// Recall is at least 50% in every bin: the limit is fainter than the faintest bin.
    FainterThan { magnitude: f64 },
    /// Recall is below 50% already in the brightest bin.
    BrighterThan { magnitude: f64 },
    /// No test image holds an object.
    NoObjects,
}

impl std::fmt::Display for HalfRecall {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HalfRecall::At { magnitude } => write!(f, "{magnitude:.2}"),
            HalfRecall::FainterThan { magnitude } => {
                write!(f, "not reached (recall >= 50% to {magnitude:.1})")
            }
            HalfRecall::BrighterThan { magnitude } => {
                write!(
                    f,
                    "brighter than the data (recall < 50% from {magnitude:.1})"
                )
            }
            HalfRecall::NoObjects => write!(f, "no objects"),
        }
    }
}

/// One detector's efficiency.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Efficiency {
    pub detector: String,
    pub conf: f64,
    pub iou: f64,
    pub half_recall: HalfRecall,
    pub curves: BTreeMap<Quantity, Vec<Bin>>,
}

/// The efficiency of one detector: `evals` per test image and `facts` per object of each
/// (in the order of its truth boxes). Each object counts in its own bins; a false positive
/// counts in the bins of the object of its image whose box centre is nearest its own (the
/// image's object when it has one, as before several objects per image); the false positives
/// of an image with no object are in no bin (they are in the report's precision).
pub fn efficiency(
    detector: &str,
    evals: &[ImageEval],
    facts: &[Vec<ObjectFacts>],
    conf: f64,
) -> Efficiency {
    const IOU: f64 = 0.5;
    // Each object with whether it was found, and for each false positive the nearest object.
    let mut objects: Vec<(ObjectFacts, bool)> = Vec::new();
    let mut false_positives: Vec<ObjectFacts> = Vec::new();
    for (e, f) in evals.iter().zip(facts) {
        assert_eq!(e.truth.len(), f.len(), "one fact per truth box");
        if e.truth.is_empty() {
            continue;
        }
        let m = match_image(e, conf, IOU);
        objects.extend(f.iter().copied().zip(m.found.iter().copied()));
        let centre = |b: &[f64; 4]| ((b[0] + b[2]) / 2.0, (b[1] + b[3]) / 2.0);
        for d in &m.false_positive_boxes {
            let (x, y) = centre(d);
            let distance = |k: usize| {
                let (tx, ty) = centre(&e.truth[k]);
                (tx - x).hypot(ty - y)
            };
            let nearest = (1..e.truth.len()).fold(0, |best, k| {
                if distance(k) < distance(best) {
                    k
                } else {
                    best
                }
            });
            false_positives.push(f[nearest]);
        }
    }
    let curves: BTreeMap<Quantity, Vec<Bin>> = Quantity::ALL
        .into_iter()
        .map(|q| {
            let mut counts: BTreeMap<i64, (usize, usize, usize)> = BTreeMap::new();
            for (f, found) in &objects {
                if let Some(k) = q.bin(q.value(f)) {
                    let c = counts.entry(k).or_default();
                    c.0 += 1;
                    c.1 += usize::from(*found);
                }
            }
            for f in &false_positives {
                if let Some(k) = q.bin(q.value(f)) {
                    counts.entry(k).or_default().2 += 1;
                }
            }
            let bins = counts
                .into_iter()
                .map(|(k, (objects, found, fp))| {
                    let (lo, hi) = q.edges(k);
                    Bin {
                        lo,
                        hi,
                        objects,
                        found,
                        false_positives: fp,
                        recall: found as f64 / objects as f64,
                        precision: (found + fp > 0).then(|| found as f64 / (found + fp) as f64),
                    }
                })
                .collect();
            (q, bins)
        })
        .collect();
    Efficiency {
        detector: detector.to_string(),
        conf,
        iou: IOU,
        half_recall: half_recall(&curves[&Quantity::Magnitude]),
        curves,
    }
}

/// The magnitude at which recall falls to 50%, from magnitude bins in increasing magnitude.
/// Recall should not rise as debris gets fainter, but a bin of a few objects can make it look
/// so; adjacent bins that break the order are pooled first (pool-adjacent-violators, weighted by
/// their objects: the isotonic fit), so one unlucky bright bin does not set the limit.
pub fn half_recall(bins: &[Bin]) -> HalfRecall {
    let (Some(first), Some(last)) = (bins.first(), bins.last()) else {
        return HalfRecall::NoObjects;
    };
    // Pooled blocks: (objects, found, sum of bin centre x objects).
    let mut blocks: Vec<(f64, f64, f64)> = Vec::new();
    for b in bins {
        let n = b.objects as f64;
        blocks.push((
            n,
            b.found as f64,
            Quantity::Magnitude.centre(b.lo, b.hi) * n,
        ));
        while let [.., a, z] = blocks[..]
            && z.1 / z.0 > a.1 / a.0
        {
            blocks.pop();
            *blocks.last_mut().expect("two blocks") = (a.0 + z.0, a.1 + z.1, a.2 + z.2);
        }
    }
    let recall = |k: &(f64, f64, f64)| k.1 / k.0;
    let centre = |k: &(f64, f64, f64)| k.2 / k.0;
    match blocks.iter().position(|k| recall(k) < 0.5) {
        None => HalfRecall::FainterThan { magnitude: last.hi },
        Some(0) => HalfRecall::BrighterThan {
            magnitude: first.lo,
        },
        Some(i) => {
            let (a, b) = (&blocks[i - 1], &blocks[i]);
            let t = (recall(a) - 0.5) / (recall(a) - recall(b));
            HalfRecall::At {
                magnitude: centre(a) + t * (centre(b) - centre(a)),
            }
        }
    }
}

/// The bins of every detector as CSV rows, written as new file `path`.
pub fn write_csv(path: &Path, all: &[Efficiency]) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "detector",
        "quantity",
        "lo",
        "hi",
        "objects",
        "found",
        "false_positives",
        "recall",
        "precision",
    ])?;
    for e in all {
        for (q, bins) in &e.curves {
            for b in bins {
                w.write_record([
                    e.detector.clone(),
                    q.name().to_string(),
                    format!("{}", b.lo),
                    format!("{}", b.hi),
                    b.objects.to_string(),
                    b.found.to_string(),
                    b.false_positives.to_string(),
                    format!("{:.4}", b.recall),
                    b.precision.map_or(String::new(), |p| format!("{p:.4}")),
                ])?;
            }
        }
    }
    crate::store::fs::create(path, w.into_inner().map_err(|e| e.into_error())?)
}

/// Recall (solid) and precision (dashed) of each detector against each quantity, one panel
/// per quantity; SNR and length on log axes.
pub fn plot(path: &Path, all: &[Efficiency]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let colors = &crate::plot::PALETTE[..3];
    crate::plot::png(path, (2500, 460), |root| {
        let panels = root.split_evenly((1, Quantity::ALL.len()));
        for (panel, q) in panels.iter().zip(Quantity::ALL) {
            let bins = all.iter().flat_map(|e| &e.curves[&q]);
            let (lo, hi) = bins.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), b| {
                (l.min(b.lo), h.max(b.hi))
            });
            if !lo.is_finite() {
                continue;
            }
            let points = |e: &Efficiency, of: fn(&Bin) -> Option<f64>| -> Vec<(f64, f64)> {
                e.curves[&q]
                    .iter()
                    .filter_map(|b| of(b).map(|y| (q.centre(b.lo, b.hi), y)))
                    .collect()
            };
            let title = format!("Efficiency against {}", q.label());
            let mut builder = ChartBuilder::on(panel);
            builder
                .caption(title, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(45);
            // One body for both axis kinds: plotters' linear and log ranges are different types.
            macro_rules! draw {
                ($chart:expr) => {{
                    let mut chart = $chart;
                    chart
                        .configure_mesh()
                        .x_labels(6)
                        .x_label_formatter(&|v| {
                            format!("{v:.4}")
                                .trim_end_matches('0')
                                .trim_end_matches('.')
                                .to_string()
                        })
                        .light_line_style(WHITE)
                        .x_desc(q.label())
                        .y_desc("recall (solid), precision (dashed)")
                        .draw()?;
                    for (k, e) in all.iter().enumerate() {
                        let c = colors[k % colors.len()];
                        let recall = points(e, |b| Some(b.recall));
                        chart
                            .draw_series(LineSeries::new(recall.clone(), c.stroke_width(2)))?
                            .label(e.detector.clone())
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                            });
                        chart.draw_series(recall.iter().map(|&p| Circle::new(p, 3, c.filled())))?;
                        chart.draw_series(DashedLineSeries::new(
                            points(e, |b| b.precision),
                            5,
                            4,
                            c.stroke_width(1),
                        ))?;
                    }
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(lo, 0.5), (hi, 0.5)],
                        BLACK.mix(0.3),
                    )))?;
                    crate::plot::legend(&mut chart, SeriesLabelPosition::LowerLeft)?;
                }};
            }
            match q {
                Quantity::Magnitude | Quantity::TrailAngleDeg => {
                    draw!(builder.build_cartesian_2d(lo..hi, 0.0..1.05)?)
                }
                _ => draw!(builder.build_cartesian_2d((lo..hi).log_scale(), 0.0..1.05)?),
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::Detection;

    /// Each bin's (lo, hi, objects, found, false positives).
    fn counts(bins: &[Bin]) -> Vec<(f64, f64, usize, usize, usize)> {
        bins.iter()
            .map(|b| (b.lo, b.hi, b.objects, b.found, b.false_positives))
            .collect()
    }

    fn image(found: bool, extra_fp: usize) -> ImageEval {
        let truth = [100.0, 100.0, 140.0, 110.0];
        let mut detections = Vec::new();
        if found {
            detections.push(Detection {
                x1: 100.0,
                y1: 100.0,
                x2: 140.0,
                y2: 110.0,
                score: 0.9,
                class: 0,
            });
        }
        for i in 0..extra_fp {
            detections.push(Detection {
                x1: 500.0 + 20.0 * i as f64,
                y1: 500.0,
                x2: 510.0 + 20.0 * i as f64,
                y2: 510.0,
                score: 0.8,
                class: 0,
            });
        }
        // A low-score detection on the object never counts: conf 0.5 filters it out.
        detections.push(Detection {
            x1: 100.0,
            y1: 100.0,
            x2: 140.0,
            y2: 110.0,
            score: 0.2,
            class: 0,
        });
        ImageEval {
            truth: vec![truth],
            truth_class: vec![0],
            detections,
        }
    }

    /// One object per image.
    fn each(f: &[ObjectFacts]) -> Vec<Vec<ObjectFacts>> {
        f.iter().map(|&x| vec![x]).collect()
    }

    fn facts(magnitude: f64, snr: f64, length_px: f64) -> ObjectFacts {
        ObjectFacts {
            magnitude,
            snr,
            length_px,
            trail_angle_deg: f64::NAN,
            // An object of 100 footprint pixels: per-pixel SNR a tenth of the integrated one.
            pixel_snr: snr / 10.0,
        }
    }

    #[test]
    fn bins_count_objects_found_and_false_positives() {
        // Magnitudes 10.1, 10.4 (bin 10.0-10.5), 11.2 (11.0-11.5) and 12.7 (12.5-13.0).
        let evals = [
            image(true, 0),
            image(true, 1),
            image(false, 0),
            image(false, 2),
        ];
        let f = [
            facts(10.1, 30.0, 40.0),
            facts(10.4, 17.0, 70.0),
            facts(11.2, 9.0, 3.0),
            facts(12.7, 1.5, 200.0),
        ];
        let e = efficiency("d", &evals, &each(&f), 0.5);
        let m = &e.curves[&Quantity::Magnitude];
        assert_eq!(
            counts(m),
            [
                (10.0, 10.5, 2, 2, 1),
                (11.0, 11.5, 1, 0, 0),
                (12.5, 13.0, 1, 0, 2)
            ]
        );
        assert_eq!(m[0].recall, 1.0);
        assert_eq!(m[0].precision, Some(2.0 / 3.0));
        assert_eq!(m[1].precision, None);
        assert_eq!(m[2].precision, Some(0.0));
        // Octaves: SNR 30 and 17 share 16-32, 9 is in 8-16, 1.5 in 1-2.
        let s: Vec<_> = e.curves[&Quantity::SnrMatchedFilter]
            .iter()
            .map(|b| (b.lo, b.hi, b.objects))
            .collect();
        assert_eq!(s, [(1.0, 2.0, 1), (8.0, 16.0, 1), (16.0, 32.0, 2)]);
        // Per-pixel SNR 3, 1.7, 0.9 and 0.15: octaves below 1 too (0.15 in 0.125-0.25).
        let p: Vec<_> = e.curves[&Quantity::SnrPerPixel]
            .iter()
            .map(|b| (b.lo, b.hi, b.objects))
            .collect();
        assert_eq!(
            p,
            [
                (0.125, 0.25, 1),
                (0.5, 1.0, 1),
                (1.0, 2.0, 1),
                (2.0, 4.0, 1)
            ]
        );
        let l: Vec<_> = e.curves[&Quantity::StreakLengthPx]
            .iter()
            .map(|b| (b.lo, b.objects))
            .collect();
        assert_eq!(l, [(2.0, 1), (32.0, 1), (64.0, 1), (128.0, 1)]);
        // Recall 1 at centre 10.25, 0 at 11.25: 50% half way, 10.75.
        assert_eq!(e.half_recall, HalfRecall::At { magnitude: 10.75 });
    }

    #[test]
    fn half_recall_interpolates_and_says_when_it_is_not_reached() {
        let bin = |lo: f64, recall: f64| Bin {
            lo,
            hi: lo + 0.5,
            objects: 10,
            found: (recall * 10.0) as usize,
            false_positives: 0,
            recall,
            precision: None,
        };
        // 0.9 at 12.25, 0.7 at 12.75, 0.3 at 13.25: crosses a half of the way from 12.75.
        let bins = [bin(12.0, 0.9), bin(12.5, 0.7), bin(13.0, 0.3)];
        assert_eq!(half_recall(&bins), HalfRecall::At { magnitude: 13.0 });
        assert_eq!(
            half_recall(&bins[..2]),
            HalfRecall::FainterThan { magnitude: 13.0 }
        );
        assert_eq!(
            half_recall(&bins[2..]),
            HalfRecall::BrighterThan { magnitude: 13.0 }
        );
        assert_eq!(half_recall(&[]), HalfRecall::NoObjects);
        // 1.0, 0.2, 1.0, 0: the middle two pool to 0.6 at 11.0, so 50% falls a sixth of the way
        // from 11.0 to 11.75, at 11.125 (not beside the lone 0.2 bin, at 10.4).
        let bins = [
            bin(10.0, 1.0),
            bin(10.5, 0.2),
            bin(11.0, 1.0),
            bin(11.5, 0.0),
        ];
        let HalfRecall::At { magnitude } = half_recall(&bins) else {
            panic!("{:?}", half_recall(&bins))
        };
        assert!((magnitude - 11.125).abs() < 1e-12, "{magnitude}");
    }

    /// Several objects per image and an empty one (#34), by hand: image 1 shows A (magnitude
    /// 10.1, found) and B (12.2, missed), with a false positive whose centre (100, 100) is
    /// nearer B's (105, 105) than A's (5, 5); image 2 shows C (11.3, found) with a false
    /// positive far from it (its only object: its bin); image 3 shows nothing and has a false
    /// positive (in no bin). Bins: 10.0-10.5 one object found; 11.0-11.5 one found, one FP;
    /// 12.0-12.5 one missed, one FP.
    #[test]
    fn several_objects_count_in_their_own_bins_and_a_false_positive_in_the_nearest() {
        let det = |b: [f64; 4], score: f64| Detection {
            x1: b[0],
            y1: b[1],
            x2: b[2],
            y2: b[3],
            score,
            class: 0,
        };
        let (a, b, c) = (
            [0., 0., 10., 10.],
            [100., 100., 110., 110.],
            [0., 0., 20., 20.],
        );
        let evals = [
            ImageEval {
                truth: vec![a, b],
                truth_class: vec![0, 0],
                detections: vec![det(a, 0.9), det([95., 95., 105., 105.], 0.8)],
            },
            ImageEval {
                truth: vec![c],
                truth_class: vec![0],
                detections: vec![det(c, 0.7), det([500., 500., 510., 510.], 0.6)],
            },
            ImageEval {
                truth: vec![],
                truth_class: vec![],
                detections: vec![det([50., 50., 60., 60.], 0.85)],
            },
        ];
        let f = [
            vec![facts(10.1, 30.0, 40.0), facts(12.2, 3.0, 40.0)],
            vec![facts(11.3, 9.0, 40.0)],
            vec![],
        ];
        let e = efficiency("d", &evals, &f, 0.5);
        assert_eq!(
            counts(&e.curves[&Quantity::Magnitude]),
            [
                (10.0, 10.5, 1, 1, 0),
                (11.0, 11.5, 1, 1, 1),
                (12.0, 12.5, 1, 0, 1)
            ]
        );
    }

    #[test]
    fn images_without_an_object_are_left_out() {
        let empty = ImageEval {
            truth: vec![],
            truth_class: vec![],
            detections: vec![],
        };
        let e = efficiency(
            "d",
            &[empty, image(true, 0)],
            &[vec![], vec![facts(9.2, 10.0, 10.0)]],
            0.5,
        );
        let m = &e.curves[&Quantity::Magnitude];
        assert_eq!((m.len(), m[0].objects), (1, 1));
    }

    #[test]
    fn recall_by_angle_to_the_trails_in_three_bands() {
        let mut f = vec![facts(10.0, 20.0, 100.0); 4];
        for (x, a) in f.iter_mut().zip([0.5, 1.99, 5.0, 45.0]) {
            x.trail_angle_deg = a;
        }
        let evals = [
            image(true, 0),
            image(false, 0),
            image(true, 0),
            image(true, 0),
        ];
        let e = efficiency("d", &evals, &each(&f), 0.5);
        let bins: Vec<(f64, f64, usize, usize)> = e.curves[&Quantity::TrailAngleDeg]
            .iter()
            .map(|b| (b.lo, b.hi, b.objects, b.found))
            .collect();
        assert_eq!(
            bins,
            vec![(0.0, 2.0, 2, 1), (2.0, 7.0, 1, 1), (7.0, 90.0, 1, 1)]
        );
        // Fixed pointing: no trails, no angle bins.
        let e = efficiency("d", &evals, &each(&[facts(10.0, 20.0, 100.0); 4]), 0.5);
        assert!(e.curves[&Quantity::TrailAngleDeg].is_empty());
    }
}
