//! Benchmarks of the per-image pipeline on the quickstart scenes (`cargo bench`; criterion
//! reports the median and its confidence interval). They read the repository's copy of the TLE
//! catalogue, like the quickstart campaigns, and skip YOLO when ONNX Runtime is not installed.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use soig::campaign::Campaign;
use soig::detect::streak::{StreakParams, detect_streaks};
use soig::detect::yolo::{YoloDetector, YoloParams, find_onnxruntime};
use soig::enhance;
use soig::experiment::{self, Experiment};
use soig::render::RenderMethod;
use soig::scene::Inputs;
use soig::simulate;

/// The experiment of a committed campaign and its inputs.
fn load(name: &str) -> (Experiment, Inputs) {
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("campaigns")
        .join(name);
    let c = Campaign::load(&path).unwrap_or_else(|e| panic!("{e}"));
    (experiment::of(&c), experiment::inputs(&c).unwrap())
}

/// Scene draw and render of one image, as `soig run` does it (no 8-bit product).
fn render_image(x: &Experiment, inputs: &Inputs, i: u64) -> soig::render::Exposure {
    simulate::image(x, inputs, i).unwrap().exposure
}

fn benches(cr: &mut Criterion) {
    let (fixed_png, inputs) = load("quickstart.toml");
    let fixed = Experiment {
        product: None,
        ..fixed_png.clone()
    };
    let (mut survey, survey_inputs) = load("survey-quickstart.toml");
    survey.product = None;
    let mut expected = fixed.clone();
    expected.render.method = RenderMethod::Expected;

    let mut g = cr.benchmark_group("render");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    g.bench_function("fixed 1024px photon mapping", |b| {
        b.iter(|| render_image(&fixed, &inputs, black_box(0)))
    });
    g.bench_function("fixed 1024px expected flux", |b| {
        b.iter(|| render_image(&expected, &inputs, black_box(0)))
    });
    g.bench_function("survey 1024px photon mapping", |b| {
        b.iter(|| render_image(&survey, &survey_inputs, black_box(0)))
    });
    g.finish();

    let exposure = render_image(&fixed, &inputs, 0);
    let (w, h) = (exposure.width, exposure.height);
    let settings = &fixed_png
        .product
        .as_ref()
        .expect("quickstart enhances")
        .enhance;
    let mut g = cr.benchmark_group("enhance and detect");
    g.sample_size(20);
    g.bench_function("enhance 1024px (sqrt, log, CLAHE, gamma)", |b| {
        b.iter(|| enhance::enhance(black_box(&exposure.adu), w, h, settings))
    });
    let png = enhance::enhance(&exposure.adu, w, h, settings);
    let pixels = png.pixels;
    let params = StreakParams::default();
    g.bench_function("streak detector 1024px", |b| {
        b.iter(|| detect_streaks(black_box(&pixels), w, h, &params, None))
    });
    if find_onnxruntime().is_ok() {
        let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/soig-yolov8n-fixed.onnx");
        let mut yolo = YoloDetector::load(&model, YoloParams::default()).unwrap();
        g.bench_function("YOLOv8n at 1024 (committed model, 1 thread)", |b| {
            b.iter(|| yolo.detect(black_box(&pixels), w, h).unwrap())
        });
    } else {
        eprintln!("ONNX Runtime not installed: YOLO benchmark skipped (scripts/setup.sh)");
    }
    g.finish();
}

criterion_group!(pipeline, benches);
criterion_main!(pipeline);
