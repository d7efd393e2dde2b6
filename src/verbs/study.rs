//! `soig study`: what each rendering approximation costs in accuracy and saves in time, on one
//! scene of a campaign. Each knob (renderer, photon merging factor and threshold, trajectory
//! samples, jitter steps) is varied alone, the others at the campaign's values, and every
//! setting is rendered over several photon seeds for one fixed jitter path. The errors are
//! measured on the noise-free photon image against the exact expected flux of a high-fidelity
//! reference (expected renderer, no merging, many trajectory samples and jitter steps), so
//! the detector noise, identical for every setting, does not hide them.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use serde::Serialize;

use crate::campaign::Campaign;
use crate::experiment::Experiment;
use crate::geometry::{BoxPx, LABEL_SHARE, flux_box};
use crate::manifest::Manifest;
use crate::render::expected::expected_flux;
use crate::render::{Jitter, RenderMethod, render_with_jitter};
use crate::rng::{PixelPurpose, pixel_stream};
use crate::scene::{self, Inputs, MAX_TRAJECTORY_SAMPLES, Scene};
use crate::store::fs;
use crate::verbs::plan::Plan;

/// The reference takes this many times the campaign's trajectory samples and jitter steps.
const REFERENCE_REFINEMENT: u32 = 10;

/// Files holding run times: they must exist but are not hashed.
const VOLATILE: [&str; 3] = ["study.csv", "study.md", "study.png"];

/// What to study.
pub struct Options {
    /// Photon seeds per setting (>= 2: the variance needs two).
    pub seeds: u32,
    /// Which image of the campaign gives the scene.
    pub image: u64,
    /// Fewer values per knob (a smoke test).
    pub quick: bool,
    /// Run even what the work estimate refuses (`work::MAX_SECONDS`).
    pub force: bool,
}

/// One setting: a knob at one value, the others at the campaign's.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub knob: String,
    pub value: String,
    /// RMS over seeds and pixels of (image - reference flux), in units of the Poisson noise
    /// of the reference (sqrt of its mean flux per pixel): 1 for an exact renderer.
    pub rms_error_noise: f64,
    /// RMS per-pixel bias of the mean image over the seeds (sampling noise subtracted), in the
    /// same units: 0 for an exact renderer.
    pub bias_noise: f64,
    /// Sum of per-pixel variances over the sum of reference fluxes: 1 for Poisson.
    pub variance_ratio: f64,
    /// Relative error of the mean total photo-electrons.
    pub flux_error: f64,
    /// Relative error of the mean debris photo-electrons.
    pub debris_flux_error: f64,
    /// Mean distance between the debris flux centroid and the reference's, pixels.
    pub centroid_error_px: f64,
    /// Mean of the largest edge difference between the label box and the reference's, px.
    pub label_box_error_px: f64,
    /// Median wall time of the scene draw (trajectory) and of one render, milliseconds.
    pub scene_ms: f64,
    pub render_ms: f64,
}

/// The errors alone (deterministic, hashed in the manifest).
#[derive(Serialize)]
struct ErrorRow<'a> {
    knob: &'a str,
    value: &'a str,
    rms_error_noise: f64,
    bias_noise: f64,
    variance_ratio: f64,
    flux_error: f64,
    debris_flux_error: f64,
    centroid_error_px: f64,
    label_box_error_px: f64,
}

/// What a finished study reports.
pub struct Summary {
    pub rows: Vec<Row>,
    pub seconds: f64,
}

/// A setting to render: its label and the experiment (the campaign's, one knob changed).
struct Setting {
    knob: &'static str,
    value: String,
    x: Experiment,
}

/// Run the study into `out`, whole or not at all.
pub fn run(campaign: &Campaign, out: &Path, opts: &Options) -> anyhow::Result<Summary> {
    let plan = Plan::new(campaign)?;
    anyhow::ensure!(
        opts.seeds >= 2,
        "--seeds must be at least 2 (got {})",
        opts.seeds
    );
    anyhow::ensure!(
        opts.image < plan.images,
        "--image {} is past the campaign's {} images",
        opts.image,
        plan.images
    );
    if !opts.force {
        check_work(&plan, opts)?;
    }
    crate::output::write_replacing(out, &[&plan.campaign_dir], |dir| study(&plan, dir, opts))
}

/// Refuse a study whose settings times seeds would take beyond `work::MAX_SECONDS`, saying so.
fn check_work(plan: &Plan, opts: &Options) -> anyhow::Result<()> {
    let base = &plan.experiment;
    let ref_steps = base.render.jitter_steps * REFERENCE_REFINEMENT as usize;
    let settings = settings(base, opts.quick, ref_steps);
    let per_seed: f64 = settings
        .iter()
        .map(|s| crate::render::cost::image(&s.x).seconds)
        .sum();
    let total = per_seed * f64::from(opts.seeds);
    anyhow::ensure!(
        total <= crate::work::MAX_SECONDS,
        "--seeds {}: {} settings of up to about {} a seed would take up to {} of one core, \
         beyond the limit of {}: fewer seeds, --quick, or pass --force",
        opts.seeds,
        settings.len(),
        crate::work::duration(per_seed),
        crate::work::duration(total),
        crate::work::duration(crate::work::MAX_SECONDS),
    );
    Ok(())
}

/// The study itself, its files written into `dir`.
fn study(plan: &Plan, dir: &Path, opts: &Options) -> anyhow::Result<Summary> {
    let started = Instant::now();
    let inputs = plan.inputs()?;
    let base = plan.experiment.clone();

    // The reference: exact renderer, no merging, refined trajectory and jitter path.
    let ref_samples = base
        .scene
        .trajectory_samples
        .saturating_mul(REFERENCE_REFINEMENT as usize)
        .min(MAX_TRAJECTORY_SAMPLES);
    let ref_steps = base.render.jitter_steps * REFERENCE_REFINEMENT as usize;
    let reference = with(&base, |x| {
        x.render.method = RenderMethod::Expected;
        x.render.merge_threshold = u64::MAX;
        x.scene.trajectory_samples = ref_samples;
        x.render.jitter_steps = ref_steps;
    });
    let (ref_scene, _) = draw(&reference, &inputs, opts.image)?;
    let jitter = Jitter::of_scene(
        &reference.sensor,
        &reference.render,
        &ref_scene,
        &mut pixel_stream(reference.seed, opts.image, PixelPurpose::Photons),
    );
    let flux = expected_flux(&reference.sensor, &ref_scene, &jitter);
    let mu: Vec<f64> = flux
        .stars
        .iter()
        .zip(&flux.debris)
        .map(|(s, d)| s + d)
        .collect();
    let mu_debris = flux.debris;
    let (w, h) = (flux.width, flux.height);
    let truth = Reference {
        total: mu.iter().sum(),
        debris_total: mu_debris.iter().sum(),
        centroid: centroid(&mu_debris, w),
        label_box: flux_box(&mu_debris, w, h, LABEL_SHARE),
        mu,
    };
    anyhow::ensure!(
        truth.debris_total > 0.0,
        "the debris of image {} puts no light in the image",
        opts.image
    );

    let mut rows = Vec::new();
    for s in settings(&base, opts.quick, ref_steps) {
        let (scene, scene_ms) = draw(&s.x, &inputs, opts.image)?;
        let steps = s.x.render.jitter_steps;
        let path = jitter
            .coarsened(steps)
            .with_context(|| format!("jitter steps {steps} do not divide {ref_steps}"))?;
        rows.push(measure(
            &s, &scene, &path, &truth, opts.seeds, &inputs, scene_ms,
        ));
    }
    write(dir, plan, opts, &rows, ref_samples, ref_steps)?;
    Ok(Summary {
        rows,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The reference figures every setting is compared with.
struct Reference {
    mu: Vec<f64>,
    total: f64,
    debris_total: f64,
    centroid: Option<(f64, f64)>,
    label_box: Option<BoxPx>,
}

/// A copy of an experiment, changed.
fn with(x: &Experiment, change: impl FnOnce(&mut Experiment)) -> Experiment {
    let mut x = x.clone();
    change(&mut x);
    x
}

/// The scene of the image (with the campaign's trajectory samples), and the median time of
/// three draws, milliseconds.
fn draw(x: &Experiment, inputs: &Inputs, image: u64) -> anyhow::Result<(Scene, f64)> {
    let mut times = Vec::new();
    let mut scene = None;
    for _ in 0..3 {
        let t = Instant::now();
        let s = scene::draw(&x.scene, &x.sensor, inputs, x.seed, image)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
        scene = Some(s);
    }
    Ok((scene.expect("drawn"), median(&times)))
}

/// Each knob alone over its values (the campaign's value among them).
fn settings(base: &Experiment, quick: bool, ref_steps: usize) -> Vec<Setting> {
    let pick = |full: Vec<u64>, short: Vec<u64>| if quick { short } else { full };
    let mut out = Vec::new();
    let mut add = |knob: &'static str, value: String, x: Experiment| {
        out.push(Setting { knob, value, x });
    };
    for m in [RenderMethod::PhotonMapping, RenderMethod::Expected] {
        add(
            "method",
            m.name().into(),
            with(base, |x| x.render.method = m),
        );
    }
    // The approximations of photon mapping, studied with photon mapping.
    let pm = with(base, |x| x.render.method = RenderMethod::PhotonMapping);
    for f in pick(vec![1, 2, 5, 10, 20], vec![1, 5]) {
        add(
            "merge_factor",
            f.to_string(),
            with(&pm, |x| x.render.merge_factor = f as u32),
        );
    }
    for t in pick(
        vec![1_000, 10_000, 100_000, 1_000_000, 10_000_000],
        vec![1_000],
    ) {
        add(
            "merge_threshold",
            t.to_string(),
            with(&pm, |x| x.render.merge_threshold = t),
        );
    }
    for n in pick(
        vec![10, 30, 100, 300, 1000, 2000, 5000, 20000],
        vec![10, 100],
    ) {
        add(
            "trajectory_samples",
            n.to_string(),
            with(base, |x| x.scene.trajectory_samples = n as usize),
        );
    }
    // Coarser views of the reference path: every value must divide its steps.
    let js = base.render.jitter_steps as u64;
    let steps: Vec<u64> = pick(vec![js / 100, js / 10, js, js * 10], vec![js / 10, js])
        .into_iter()
        .filter(|&n| n >= 1 && (ref_steps as u64).is_multiple_of(n))
        .collect();
    for n in steps {
        add(
            "jitter_steps",
            n.to_string(),
            with(base, |x| x.render.jitter_steps = n as usize),
        );
    }
    out
}

/// Render a setting over the seeds and compare with the reference.
fn measure(
    s: &Setting,
    scene: &Scene,
    jitter: &Jitter,
    truth: &Reference,
    seeds: u32,
    inputs: &Inputs,
    scene_ms: f64,
) -> Row {
    let n = truth.mu.len();
    let (mut sum, mut sum2) = (vec![0.0f64; n], vec![0.0f64; n]);
    let (mut sq_err, mut total, mut debris_total) = (0.0, 0.0, 0.0);
    let (mut centroid_err, mut box_err) = (Vec::new(), Vec::new());
    let mut times = Vec::new();
    let seed = s.x.seed;
    let frame = inputs.frame(scene.exposure.background);
    for k in 0..seeds as u64 {
        // Photon seeds apart from the campaign's images: (seed + 1 + k, image).
        let t = Instant::now();
        let e = render_with_jitter(
            &s.x.sensor,
            &s.x.render,
            scene,
            frame,
            jitter,
            &mut pixel_stream(
                seed.wrapping_add(1 + k),
                scene.exposure.image_index,
                PixelPurpose::Photons,
            ),
            &mut pixel_stream(
                seed.wrapping_add(1 + k),
                scene.exposure.image_index,
                PixelPurpose::Noise,
            ),
            None,
        );
        times.push(t.elapsed().as_secs_f64() * 1e3);
        for (i, &v) in e.electrons.iter().enumerate() {
            let v = v as f64;
            sum[i] += v;
            sum2[i] += v * v;
            sq_err += (v - truth.mu[i]).powi(2);
            total += v;
        }
        debris_total += e.truth.seen.rendered_debris_electrons as f64;
        let debris: Vec<f64> = e.debris_electrons.iter().map(|&v| v as f64).collect();
        if let (Some(a), Some(b)) = (centroid(&debris, e.width), truth.centroid) {
            centroid_err.push((a.0 - b.0).hypot(a.1 - b.1));
        }
        let label = flux_box(&e.debris_electrons, e.width, e.height, LABEL_SHARE);
        if let (Some(a), Some(b)) = (label, truth.label_box) {
            box_err.push(
                [
                    a.x_min - b.x_min,
                    a.y_min - b.y_min,
                    a.x_max - b.x_max,
                    a.y_max - b.y_max,
                ]
                .iter()
                .fold(0.0f64, |m, d| m.max(d.abs())),
            );
        }
    }
    let r = seeds as f64;
    let (mut bias2, mut var) = (0.0, 0.0);
    for i in 0..n {
        let m = sum[i] / r;
        let v = (sum2[i] - r * m * m).max(0.0) / (r - 1.0);
        var += v;
        // The squared bias of the mean, less the sampling variance of the mean.
        bias2 += (m - truth.mu[i]).powi(2) - v / r;
    }
    let mean = |v: &[f64]| {
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    Row {
        knob: s.knob.into(),
        value: s.value.clone(),
        rms_error_noise: (sq_err / r / truth.total).sqrt(),
        bias_noise: (bias2.max(0.0) / truth.total).sqrt(),
        variance_ratio: var / truth.total,
        flux_error: total / r / truth.total - 1.0,
        debris_flux_error: debris_total / r / truth.debris_total - 1.0,
        centroid_error_px: mean(&centroid_err),
        label_box_error_px: mean(&box_err),
        scene_ms,
        render_ms: median(&times),
    }
}

fn median(v: &[f64]) -> f64 {
    crate::report::Timing::of(v).median_s
}

/// Flux-weighted centroid (pixel centres at integers).
fn centroid(img: &[f64], width: usize) -> Option<(f64, f64)> {
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for (k, &v) in img.iter().enumerate() {
        sx += v * (k % width) as f64;
        sy += v * (k / width) as f64;
        sw += v;
    }
    (sw > 0.0).then(|| (sx / sw, sy / sw))
}

/// study.json (parameters), errors.csv (hashed), study.csv, study.md, study.png (with run
/// times: volatile), and the manifest.
fn write(
    out: &Path,
    plan: &Plan,
    opts: &Options,
    rows: &[Row],
    ref_samples: usize,
    ref_steps: usize,
) -> anyhow::Result<()> {
    fs::create_dir_all(out)?;
    let params = serde_json::json!({
        "campaign": plan.name,
        "campaign_hash": plan.hash,
        "image": opts.image,
        "seeds": opts.seeds,
        "quick": opts.quick,
        "reference": {
            "method": "expected",
            "merge": "off",
            "trajectory_samples": ref_samples,
            "jitter_steps": ref_steps,
        },
        "photon_seeds": "stream(campaign seed + 1 + k, image, photons), k < seeds",
    });
    fs::create(
        &out.join("study.json"),
        serde_json::to_string_pretty(&params)? + "\n",
    )?;
    let mut errors = csv::Writer::from_writer(Vec::new());
    for r in rows {
        errors.serialize(ErrorRow {
            knob: &r.knob,
            value: &r.value,
            rms_error_noise: r.rms_error_noise,
            bias_noise: r.bias_noise,
            variance_ratio: r.variance_ratio,
            flux_error: r.flux_error,
            debris_flux_error: r.debris_flux_error,
            centroid_error_px: r.centroid_error_px,
            label_box_error_px: r.label_box_error_px,
        })?;
    }
    fs::create(
        &out.join("errors.csv"),
        errors.into_inner().map_err(|e| e.into_error())?,
    )?;
    let mut all = csv::Writer::from_writer(Vec::new());
    for r in rows {
        all.serialize(r)?;
    }
    fs::create(
        &out.join("study.csv"),
        all.into_inner().map_err(|e| e.into_error())?,
    )?;
    fs::create(
        &out.join("study.md"),
        table(plan, opts, rows, ref_samples, ref_steps),
    )?;
    plot(&out.join("study.png"), rows)?;
    let volatile: Vec<String> = VOLATILE.iter().map(|v| v.to_string()).collect();
    let manifest = Manifest::build(out, &plan.hash, plan.resolved.clone(), &volatile)?;
    manifest.write(out)?;
    Ok(())
}

fn table(
    plan: &Plan,
    opts: &Options,
    rows: &[Row],
    ref_samples: usize,
    ref_steps: usize,
) -> String {
    let r = &plan.render;
    let mut s = format!(
        "# Render settings: error against run time\n\nCampaign `{}`, image {}, {} photon seeds per setting, one fixed jitter path. Each knob varies alone; the others stay at the campaign's values (method {}, merge_factor {}, merge_threshold {}, trajectory_samples {}, jitter_steps {}). Reference: the expected-flux renderer, no merging, {ref_samples} trajectory samples, {ref_steps} jitter steps; errors are on the noise-free photon image.\n\n",
        plan.name,
        opts.image,
        opts.seeds,
        r.method.name(),
        r.merge_factor,
        r.merge_threshold,
        r.trajectory_samples,
        r.jitter_steps
    );
    s += "- rms error: RMS of (image - reference flux) per pixel, in units of the Poisson noise (1 = exact Poisson rendering)\n";
    s += "- bias: RMS per-pixel bias of the mean image, same units (0 = unbiased; sampling noise subtracted)\n";
    s += "- var ratio: per-pixel variance over the Poisson variance (1 = Poisson)\n";
    s += "- centroid, label box: debris centroid distance and largest label-box edge difference to the reference, px\n";
    s +=
        "- time: median wall time of one render (+ scene draw, which holds the trajectory), ms\n\n";
    s += "| knob | value | rms error | bias | var ratio | flux error | debris flux error | centroid px | label box px | render ms | scene ms |\n";
    s += "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for r in rows {
        s += &format!(
            "| {} | {} | {:.3} | {:.3} | {:.2} | {:+.2e} | {:+.2e} | {:.3} | {:.2} | {:.1} | {:.1} |\n",
            r.knob,
            r.value,
            r.rms_error_noise,
            r.bias_noise,
            r.variance_ratio,
            r.flux_error,
            r.debris_flux_error,
            r.centroid_error_px,
            r.label_box_error_px,
            r.render_ms,
            r.scene_ms
        );
    }
    s += "\n![error against run time](study.png)\n";
    s
}

/// RMS error (in Poisson-noise units) against run time, one series per knob.
fn plot(path: &Path, rows: &[Row]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let time = |r: &Row| r.render_ms + r.scene_ms;
    let finite = |v: f64| v.is_finite() && v > 0.0;
    let xs: Vec<f64> = rows.iter().map(time).filter(|&v| finite(v)).collect();
    let ys: Vec<f64> = rows
        .iter()
        .map(|r| r.rms_error_noise)
        .filter(|&v| finite(v))
        .collect();
    anyhow::ensure!(
        !xs.is_empty() && !ys.is_empty(),
        "no finite figures to plot"
    );
    let (x0, x1) = bounds(&xs);
    let (y0, y1) = bounds(&ys);
    crate::plot::png(path, (800, 560), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                "Render settings: error against run time",
                ("sans-serif", 22),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("render + scene time per image, ms")
            .y_desc("RMS error / Poisson noise (1 = exact)")
            .draw()?;
        let colors = crate::plot::PALETTE;
        let mut knobs: Vec<&str> = Vec::new();
        for r in rows {
            if !knobs.contains(&r.knob.as_str()) {
                knobs.push(&r.knob);
            }
        }
        for (k, knob) in knobs.iter().enumerate() {
            let c = colors[k % colors.len()];
            let pts: Vec<(f64, f64, String)> = rows
                .iter()
                .filter(|r| r.knob == *knob && finite(time(r)) && finite(r.rms_error_noise))
                .map(|r| (time(r), r.rms_error_noise, r.value.clone()))
                .collect();
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|p| (p.0, p.1)),
                    c.stroke_width(2),
                ))?
                .label(knob.to_string())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            chart.draw_series(pts.iter().map(|p| {
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 4, c.filled())
                    + Text::new(
                        p.2.clone(),
                        (5, -14),
                        ("sans-serif", 13).into_font().color(&c),
                    )
            }))?;
        }
        crate::plot::legend(&mut chart, SeriesLabelPosition::UpperRight)
    })
}

/// A log-axis range around the values, with some room.
fn bounds(v: &[f64]) -> (f64, f64) {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo / 1.5, hi * 1.5)
}
