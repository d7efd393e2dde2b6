//! The reference cases of `tests/reference/metrics_reference.py` (`CASES`: same names, bit-identical
//! inputs) and the figures pycocotools and Ultralytics gave for them: one test per case checks every
//! metric against them.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::{
    ImageEval, UltralyticsMetrics, UltralyticsVersion, box_det, coco, ultralytics, ultralytics_with,
};

fn bx(x: f64, y: f64, w: f64, h: f64) -> [f64; 4] {
    [x, y, x + w, y + h]
}

pub(super) fn img(truth: &[([f64; 4], u32)], dets: &[([f64; 4], f64, u32)]) -> ImageEval {
    ImageEval {
        truth: truth.iter().map(|t| t.0).collect(),
        truth_class: truth.iter().map(|t| t.1).collect(),
        detections: dets.iter().map(|&(b, s, c)| box_det(b, s, c)).collect(),
    }
}

/// splitmix64, as `SplitMix64` in tests/reference/metrics_reference.py.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (-53f64).exp2()
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

/// `random_box()` of tests/reference/metrics_reference.py: a box of 4-64 px a side with its
/// corner anywhere in 1000 x 1000, `(x1, y1, w, h)`, drawn in the order w, h, x1, y1.
fn random_box(rng: &mut SplitMix64) -> (f64, f64, f64, f64) {
    let w = 4.0 + 60.0 * rng.uniform();
    let h = 4.0 + 60.0 * rng.uniform();
    let x1 = 1000.0 * rng.uniform();
    let y1 = 1000.0 * rng.uniform();
    (x1, y1, w, h)
}

/// `stress()` of tests/reference/metrics_reference.py: objects with 0-2 jittered detections each (10 % with
/// a random class), plus 0-2 random false positives per image.
fn stress(seed: u64, n_images: usize, n_classes: u64) -> Vec<ImageEval> {
    let mut rng = SplitMix64(seed);
    let mut images = Vec::new();
    for _ in 0..n_images {
        let mut im = ImageEval::default();
        for _ in 0..rng.below(6) {
            let (x1, y1, w, h) = random_box(&mut rng);
            let c = rng.below(n_classes) as u32;
            im.truth.push([x1, y1, x1 + w, y1 + h]);
            im.truth_class.push(c);
            for _ in 0..rng.below(3) {
                let j = 0.3 * rng.uniform();
                let dx1 = (2.0 * rng.uniform() - 1.0) * j * w;
                let dy1 = (2.0 * rng.uniform() - 1.0) * j * h;
                let dx2 = (2.0 * rng.uniform() - 1.0) * j * w;
                let dy2 = (2.0 * rng.uniform() - 1.0) * j * h;
                let dc = if rng.uniform() < 0.9 {
                    c
                } else {
                    rng.below(n_classes) as u32
                };
                let score = rng.uniform();
                im.detections.push(box_det(
                    [x1 + dx1, y1 + dy1, x1 + w + dx2, y1 + h + dy2],
                    score,
                    dc,
                ));
            }
        }
        for _ in 0..rng.below(3) {
            let (x1, y1, w, h) = random_box(&mut rng);
            let dc = rng.below(n_classes) as u32;
            let score = 0.6 * rng.uniform();
            im.detections
                .push(box_det([x1, y1, x1 + w, y1 + h], score, dc));
        }
        images.push(im);
    }
    images
}

/// One image of tests/fixtures/metrics/cases.toml.
#[derive(Deserialize)]
struct CaseImage {
    /// The objects: [x1, y1, x2, y2, class].
    truth: Vec<(f64, f64, f64, f64, u32)>,
    /// [x1, y1, x2, y2, score, class].
    detections: Vec<(f64, f64, f64, f64, f64, u32)>,
}

/// The cases of tests/reference/metrics_reference.py (`CASES`), same names, same inputs: the
/// hand-made ones of tests/fixtures/metrics/cases.toml, which the script reads too, and the
/// random ones.
pub(super) fn case(name: &str) -> Vec<ImageEval> {
    match name {
        "stress_single" => return stress(42, 50, 1),
        "stress_multi" => return stress(7, 40, 3),
        _ => {}
    }
    let text = include_str!("../../../../tests/fixtures/metrics/cases.toml");
    let mut cases: BTreeMap<String, Vec<CaseImage>> =
        toml::from_str(text).expect("tests/fixtures/metrics/cases.toml");
    let images = cases
        .remove(name)
        .unwrap_or_else(|| panic!("unknown case {name}"));
    images
        .iter()
        .map(|im| ImageEval {
            truth: im
                .truth
                .iter()
                .map(|&(x1, y1, x2, y2, _)| [x1, y1, x2, y2])
                .collect(),
            truth_class: im.truth.iter().map(|t| t.4).collect(),
            detections: (im.detections.iter())
                .map(|&(x1, y1, x2, y2, score, class)| box_det([x1, y1, x2, y2], score, class))
                .collect(),
        })
        .collect()
}

/// `checksum()` of the reference script.
fn checksum(images: &[ImageEval]) -> f64 {
    let mut s = 0.0;
    for (k, im) in images.iter().enumerate() {
        let k1 = (k + 1) as f64;
        for (b, &c) in im.truth.iter().zip(&im.truth_class) {
            s += k1 * (b[0] + 2.0 * b[1] + 3.0 * b[2] + 4.0 * b[3] + 5.0 * c as f64);
        }
        for det in &im.detections {
            s += k1
                * (det.x1 - 2.0 * det.y1 + 3.0 * det.x2 - 4.0 * det.y2
                    + 1000.0 * det.score
                    + 7.0 * det.class as f64);
        }
    }
    s
}

#[derive(Deserialize)]
struct Curve {
    len: usize,
    mean: f64,
    samples: Vec<(usize, f64)>,
}

#[derive(Deserialize)]
struct UltraExpected {
    precision: f64,
    recall: f64,
    map50: f64,
    map50_95: f64,
    f1_conf: f64,
    ap_per_iou: [f64; 10],
    precision_curve: Curve,
    recall_curve: Curve,
    f1_curve: Curve,
    pr_curve_map50: Curve,
}

#[derive(Deserialize)]
struct CocoExpected {
    ap: f64,
    ap50: f64,
    ap75: f64,
    ar100: f64,
    /// run-length encoded: (value, count)
    precision_at_50: Vec<(f64, usize)>,
}

#[derive(Deserialize)]
struct Expected {
    name: String,
    n_truth: usize,
    n_detections: usize,
    checksum: f64,
    coco: CocoExpected,
    current: UltraExpected,
    legacy: UltraExpected,
}

/// tests/fixtures/metrics/expected.toml: the figures tests/reference/metrics_reference.py wrote
/// (its first line says with what), one `[[case]]` per case. TOML, whose floats Rust reads
/// exactly, as the script wrote them.
#[derive(Deserialize)]
struct Fixture {
    case: Vec<Expected>,
}

fn expected() -> Vec<Expected> {
    let text = include_str!("../../../../tests/fixtures/metrics/expected.toml");
    toml::from_str::<Fixture>(text)
        .expect("tests/fixtures/metrics/expected.toml")
        .case
}

const TOL: f64 = 1e-6;

thread_local! {
    /// Largest |Rust - reference| seen by `close` in this test's thread.
    static MAX_DEV: std::cell::Cell<f64> = const { std::cell::Cell::new(0.0) };
}

fn close(what: &str, got: f64, want: f64) -> Option<String> {
    let dev = (got - want).abs();
    MAX_DEV.with(|m| m.set(m.get().max(if dev.is_nan() { f64::INFINITY } else { dev })));
    (dev.is_nan() || dev > TOL).then(|| format!("{what}: got {got}, reference {want}"))
}

fn check_curve(errs: &mut Vec<String>, what: &str, got: &[f64], want: &Curve) {
    if got.len() != want.len {
        errs.push(format!(
            "{what}: length {} vs reference {}",
            got.len(),
            want.len
        ));
        return;
    }
    if !got.is_empty() {
        errs.extend(close(
            &format!("{what} mean"),
            got.iter().sum::<f64>() / got.len() as f64,
            want.mean,
        ));
    }
    for &(i, v) in &want.samples {
        errs.extend(close(&format!("{what}[{i}]"), got[i], v));
    }
}

fn check_ultra(errs: &mut Vec<String>, tag: &str, got: &UltralyticsMetrics, want: &UltraExpected) {
    errs.extend(close(
        &format!("{tag} precision"),
        got.precision,
        want.precision,
    ));
    errs.extend(close(&format!("{tag} recall"), got.recall, want.recall));
    errs.extend(close(&format!("{tag} map50"), got.map50, want.map50));
    errs.extend(close(
        &format!("{tag} map50_95"),
        got.map50_95,
        want.map50_95,
    ));
    errs.extend(close(&format!("{tag} f1_conf"), got.f1_conf, want.f1_conf));
    for t in 0..10 {
        errs.extend(close(
            &format!("{tag} ap_per_iou[{t}]"),
            got.ap_per_iou[t],
            want.ap_per_iou[t],
        ));
    }
    check_curve(
        errs,
        &format!("{tag} precision_curve"),
        &got.precision_curve,
        &want.precision_curve,
    );
    check_curve(
        errs,
        &format!("{tag} recall_curve"),
        &got.recall_curve,
        &want.recall_curve,
    );
    check_curve(
        errs,
        &format!("{tag} f1_curve"),
        &got.f1_curve,
        &want.f1_curve,
    );
    check_curve(
        errs,
        &format!("{tag} pr_curve_map50"),
        &got.pr_curve_map50,
        &want.pr_curve_map50,
    );
    if got.px.len() != 1000 || got.px[0] != 0.0 || got.px[999] != 1.0 {
        errs.push(format!("{tag} px is not linspace(0, 1, 1000)"));
    }
}

fn check_case(name: &str) {
    let want = expected()
        .into_iter()
        .find(|e| e.name == name)
        .expect("case in expected.toml");
    let images = case(name);
    let mut errs = Vec::new();
    let cs = checksum(&images);
    if (cs - want.checksum).abs() > 1e-9 * want.checksum.abs().max(1.0) {
        errs.push(format!(
            "input checksum {cs} vs reference {}: the cases differ",
            want.checksum
        ));
    }
    let cur = ultralytics(&images);
    let leg = ultralytics_with(&images, UltralyticsVersion::Legacy);
    for m in [&cur, &leg] {
        if m.n_truth != want.n_truth || m.n_detections != want.n_detections {
            errs.push(format!(
                "counts {} / {} vs {} / {}",
                m.n_truth, m.n_detections, want.n_truth, want.n_detections
            ));
        }
    }
    check_ultra(&mut errs, "ultralytics", &cur, &want.current);
    check_ultra(&mut errs, "ultralytics legacy", &leg, &want.legacy);
    let c = coco(&images);
    errs.extend(close("coco ap", c.ap, want.coco.ap));
    errs.extend(close("coco ap50", c.ap50, want.coco.ap50));
    errs.extend(close("coco ap75", c.ap75, want.coco.ap75));
    errs.extend(close("coco ar100", c.ar100, want.coco.ar100));
    let p50: Vec<f64> = want
        .coco
        .precision_at_50
        .iter()
        .flat_map(|&(v, n)| std::iter::repeat_n(v, n))
        .collect();
    if c.precision_at_50.len() != 101 || p50.len() != 101 {
        errs.push(format!(
            "precision_at_50 length {} / {}",
            c.precision_at_50.len(),
            p50.len()
        ));
    } else {
        for (r, (&got, &want)) in c.precision_at_50.iter().zip(&p50).enumerate() {
            errs.extend(close(&format!("coco precision_at_50[{r}]"), got, want));
        }
    }
    eprintln!(
        "case {name}: largest deviation from the references {:.1e}",
        MAX_DEV.with(|m| m.get())
    );
    assert!(errs.is_empty(), "case {name}:\n{}", errs.join("\n"));
}

// One test per reference case; figures from tests/reference/metrics_reference.py (pycocotools 2.0.11,
// ultralytics 8.4.190 and the 8.3.0 sources, numpy 2.4.6, torch 2.15.0), in
// tests/fixtures/metrics/expected.toml.
#[test]
fn reference_no_predictions() {
    check_case("no_predictions");
}
#[test]
fn reference_no_labels() {
    check_case("no_labels");
}
#[test]
fn reference_duplicates() {
    check_case("duplicates");
}
#[test]
fn reference_perfect() {
    check_case("perfect");
}
#[test]
fn reference_ties() {
    check_case("ties");
}
#[test]
fn reference_half_recall() {
    check_case("half_recall");
}
#[test]
fn reference_mixed() {
    check_case("mixed");
}
#[test]
fn reference_multi_box() {
    check_case("multi_box");
}
#[test]
fn reference_iou_boundaries() {
    check_case("iou_boundaries");
}
#[test]
fn reference_stress_single() {
    check_case("stress_single");
}
#[test]
fn reference_stress_multi() {
    check_case("stress_multi");
}

#[test]
fn every_reference_case_is_tested() {
    let expected = expected();
    for e in &expected {
        let _ = case(&e.name);
    }
    assert_eq!(expected.len(), 11);
}

#[test]
fn headline_figures() {
    // perfect detector: Ultralytics 0.995, COCO 1.0
    let p = case("perfect");
    assert!((ultralytics(&p).map50 - 0.995).abs() < 1e-12);
    assert!((ultralytics_with(&p, UltralyticsVersion::Legacy).map50 - 0.995).abs() < 1e-12);
    assert!((coco(&p).ap - 1.0).abs() < 1e-12);
    // precision 1 up to recall 0.5: legacy Ultralytics 0.75, current 0.495, COCO 0.505
    let h = case("half_recall");
    assert!((ultralytics_with(&h, UltralyticsVersion::Legacy).map50 - 0.75).abs() < 1e-12);
    assert!((ultralytics(&h).map50 - 0.495).abs() < 1e-12);
    assert!((coco(&h).ap50 - 0.504_950_495_049_505).abs() < 1e-12);
    // no objects: Ultralytics zeros, pycocotools -1
    let n = case("no_labels");
    let u = ultralytics(&n);
    assert_eq!(
        (u.precision, u.recall, u.map50, u.map50_95),
        (0.0, 0.0, 0.0, 0.0)
    );
    assert!(u.precision_curve.is_empty() && u.pr_curve_map50 == vec![0.0; 1000]);
    let c = coco(&n);
    assert_eq!((c.ap, c.ap50, c.ap75, c.ar100), (-1.0, -1.0, -1.0, -1.0));
    assert!(c.precision_at_50.iter().all(|&v| v == -1.0));
    // nothing at all
    let c = coco(&[ImageEval::default()]);
    assert_eq!((c.ap, c.ar100), (-1.0, -1.0));
    let u = ultralytics(&[]);
    assert_eq!((u.map50, u.precision, u.f1_conf), (0.0, 0.0, 0.0));
}

/// Tied scores that mix hits and misses: pycocotools keeps tied detections in input order (image
/// order, then each image's own), and so does `coco`; the figures of
/// `tests/reference/coco_ties_reference.py` for the case and for it with image 1's two tied
/// detections swapped (an order that agreed by chance would fail one of them). Both to 1e-12,
/// the rounding of the same sums.
#[test]
fn coco_breaks_ties_as_pycocotools() {
    let far = bx(900., 900., 20., 20.);
    let case = |swapped: bool| {
        let mut first = vec![(bx(10., 10., 20., 20.), 0.7, 0), (far, 0.7, 0)];
        if swapped {
            first.reverse();
        }
        vec![
            img(&[(bx(10., 10., 20., 20.), 0)], &first),
            img(
                &[(bx(100., 100., 20., 20.), 0)],
                &[(far, 0.7, 0), (bx(100., 100., 20., 20.), 0.7, 0)],
            ),
            img(
                &[(bx(300., 300., 20., 20.), 0), (bx(500., 500., 20., 20.), 0)],
                &[
                    (bx(300., 300., 20., 12.), 0.5, 0),
                    (far, 0.5, 0),
                    (bx(500., 500., 20., 20.), 0.9, 0),
                ],
            ),
        ]
    };
    let pinned = [
        (
            false,
            [
                0.7079207920792079,
                0.8349834983498351,
                0.6534653465346535,
                0.825,
            ],
        ),
        (
            true,
            [
                0.6254125412541253,
                0.7524752475247526,
                0.5709570957095709,
                0.825,
            ],
        ),
    ];
    for (swapped, want) in pinned {
        let c = coco(&case(swapped));
        for (got, want) in [c.ap, c.ap50, c.ap75, c.ar100].into_iter().zip(want) {
            assert!(
                (got - want).abs() < 1e-12,
                "swapped {swapped}: {got} against {want}"
            );
        }
    }
}
