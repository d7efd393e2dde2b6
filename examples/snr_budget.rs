//! Where a faint streak's signal-to-noise goes before the detector looks (issue #44's faint
//! limit): on each test image of a finished run with FITS (`artifacts.fits = true`, original
//! frames), the SNR a straight line at the truth's ends with a Gaussian cross-section of
//! `PSF_SIGMA_PX` reads, `sum(w z) / sqrt(sum(w^2))`, on the FITS counts and on the 8-bit
//! enhanced PNG, each made unit noise cell by cell (`unit_noise`: clipped at 4 sigma, then
//! zero mean: the PNG's stretch skews its noise and real frames' tails are one-sided), against
//! the truth's matched-filter SNR (which follows the streak's wander with the pointing jitter;
//! a straight line cannot). Prints a line an image and, by truth SNR, the medians of the ratios.
//!
//! ```sh
//! soig run results/campaigns/faint-limit-survey.toml --out /tmp/flf --set seed=9402 \
//!     --set images=150 --set 'stages=["render","enhance","dataset"]' --set artifacts.fits=true
//! cargo run --release --example snr_budget -- /tmp/flf 1.42
//! ```

// Examples read their inputs with std::fs; the product writes through the store.
#![allow(clippy::disallowed_methods)]

use std::path::PathBuf;

use anyhow::Context;

/// The unit-noise map's cell, pixels.
const MESH: usize = 64;
/// The unit-noise map is clipped to this many MAD sigmas.
const CLIP: f64 = 4.0;
/// The template reaches this many PSF sigmas from the line.
const REACH_SIGMA: f64 = 4.0;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [run, sigma] = &args[..] else {
        anyhow::bail!("usage: snr_budget RUN_DIR PSF_SIGMA_PX");
    };
    let run = PathBuf::from(run);
    let sigma: f64 = sigma.parse().context("PSF_SIGMA_PX must be a number")?;
    let mut truths: Vec<PathBuf> = std::fs::read_dir(run.join("truth"))?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()?;
    truths.retain(|p| p.extension().is_some_and(|e| e == "json"));
    truths.sort();
    println!("image,truth_snr,fits_snr,png_snr");
    let mut rows = Vec::new();
    for path in &truths {
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let png = run.join("images/test").join(format!("{stem}.png"));
        let fits = run.join("fits").join(format!("{stem}.fits"));
        if !png.exists() || !fits.exists() {
            continue;
        }
        let truth: serde_json::Value = serde_json::from_slice(&std::fs::read(path)?)?;
        let kind = truth["frame"]["kind"].as_str().unwrap_or("original");
        anyhow::ensure!(
            kind == "original",
            "{}: a {kind} frame; the PNG must be the original frame",
            path.display()
        );
        let end = |k: &str| -> anyhow::Result<[f64; 2]> {
            let v = &truth[k];
            match (v[0].as_f64(), v[1].as_f64()) {
                (Some(x), Some(y)) => Ok([x, y]),
                _ => anyhow::bail!("{}: no {k}", path.display()),
            }
        };
        let line = [end("streak_start_px")?, end("streak_end_px")?];
        let snr = truth["snr_matched_filter"]
            .as_f64()
            .with_context(|| format!("{}: no snr_matched_filter", path.display()))?;
        let (counts, w, h) =
            soig::fits::read_f32(&fits).with_context(|| format!("reading {}", fits.display()))?;
        let grey = image::open(&png)
            .with_context(|| format!("reading {}", png.display()))?
            .to_luma8();
        anyhow::ensure!(
            (grey.width() as usize, grey.height() as usize) == (w, h),
            "{}: the PNG is not the FITS's size",
            png.display()
        );
        let grey: Vec<f32> = grey.into_raw().into_iter().map(f32::from).collect();
        let f = template_snr(&unit_noise(&counts, w, h), w, h, line, sigma);
        let p = template_snr(&unit_noise(&grey, w, h), w, h, line, sigma);
        println!("{stem},{snr:.3},{f:.3},{p:.3}");
        rows.push((snr, f, p));
    }
    anyhow::ensure!(
        !rows.is_empty(),
        "{}: no test image with FITS",
        run.display()
    );
    eprintln!("truth SNR   images  fits/truth  png/truth  png/fits (medians)");
    for (lo, hi) in [
        (0.0, 9.0),
        (9.0, 13.0),
        (13.0, 20.0),
        (20.0, 40.0),
        (40.0, 1e9),
    ] {
        let inside: Vec<_> = rows.iter().filter(|r| r.0 >= lo && r.0 < hi).collect();
        if inside.is_empty() {
            continue;
        }
        let med =
            |f: &dyn Fn(&(f64, f64, f64)) -> f64| median(inside.iter().map(|r| f(r)).collect());
        eprintln!(
            "{:>10} {:>7}  {:>10.3}  {:>9.3}  {:>8.3}",
            if hi < 1e9 {
                format!("{lo}-{hi}")
            } else {
                format!(">= {lo}")
            },
            inside.len(),
            med(&|r| r.1 / r.0),
            med(&|r| r.2 / r.0),
            med(&|r| r.2 / r.1)
        );
    }
    Ok(())
}

/// `v` made unit noise cell by cell: each `MESH` cell in units of its MAD sigma about its
/// median, clipped to +-`CLIP` (real frames' hot pixels, cosmic rays and stars would otherwise
/// dominate a line's sum), then less its mean over its standard deviation (the clipped noise
/// of a skewed stretch or tail is no longer zero-mean).
fn unit_noise(v: &[f32], w: usize, h: usize) -> Vec<f64> {
    let mut z = vec![0.0; w * h];
    for y0 in (0..h).step_by(MESH) {
        for x0 in (0..w).step_by(MESH) {
            let (x1, y1) = ((x0 + MESH).min(w), (y0 + MESH).min(h));
            let at = |f: &mut dyn FnMut(usize)| {
                for y in y0..y1 {
                    for x in x0..x1 {
                        f(y * w + x);
                    }
                }
            };
            let mut cell = Vec::new();
            at(&mut |i| cell.push(v[i] as f64));
            let med = median(cell.clone());
            let mad = (1.4826 * median(cell.iter().map(|a| (a - med).abs()).collect())).max(1e-9);
            at(&mut |i| z[i] = ((v[i] as f64 - med) / mad).clamp(-CLIP, CLIP));
            let (mut n, mut sum, mut sq) = (0.0, 0.0, 0.0);
            at(&mut |i| {
                n += 1.0;
                sum += z[i];
                sq += z[i] * z[i];
            });
            let mean = sum / n;
            let sd = (sq / n - mean * mean).max(1e-18).sqrt();
            at(&mut |i| z[i] = (z[i] - mean) / sd);
        }
    }
    z
}

/// The SNR the straight `line` (pixel-centre coordinates, possibly beyond the image) with a
/// Gaussian cross-section of `sigma` reads on the unit-noise map `z`: each pixel weighted by
/// the Gaussian of its distance to the segment.
fn template_snr(z: &[f64], w: usize, h: usize, [a, b]: [[f64; 2]; 2], sigma: f64) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = (dx * dx + dy * dy).max(1e-12);
    let reach = REACH_SIGMA * sigma;
    // Only the pixels within `reach` of the segment's box can be within `reach` of it.
    let span = |lo: f64, hi: f64, n: usize| {
        let from = (lo - reach).floor().max(0.0) as usize;
        let to = ((hi + reach).ceil().max(-1.0) + 1.0).min(n as f64) as usize;
        from..to.max(from)
    };
    let (xs, ys) = (
        span(a[0].min(b[0]), a[0].max(b[0]), w),
        span(a[1].min(b[1]), a[1].max(b[1]), h),
    );
    let (mut sum, mut norm) = (0.0, 0.0);
    for y in ys {
        for x in xs.clone() {
            let (px, py) = (x as f64 - a[0], y as f64 - a[1]);
            let u = ((px * dx + py * dy) / len2).clamp(0.0, 1.0);
            let d2 = (px - u * dx).powi(2) + (py - u * dy).powi(2);
            if d2 > reach * reach {
                continue;
            }
            let wt = (-d2 / (2.0 * sigma * sigma)).exp();
            sum += wt * z[y * w + x];
            norm += wt * wt;
        }
    }
    if norm > 0.0 { sum / norm.sqrt() } else { 0.0 }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}
