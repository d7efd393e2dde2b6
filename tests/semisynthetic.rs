//! Semisynthetic backgrounds (paper 3.4, issue #10) from each real NEOSSat frame: the row
//! periodogram of a 1024 x 1024 background has no peak (no tiling period), and its rows and
//! columns show no seam.

use std::path::Path;

use soig::background::RealFrame;
use soig::imaging::robust_stats;
use soig::rng::{Purpose, stream};

const FRAMES: [&str; 3] = [
    "NEOSSAT_240__30_2020214095318.fits",
    "NEOSSAT_240__30_2026025124741.fits",
    "NEOS_SCI_2024239174545_cord.fits",
];
/// The paper's image size.
const SIZE: usize = 1024;

fn frame(name: &str) -> RealFrame {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/neossat")
        .join(name);
    RealFrame::load(&path).unwrap()
}

/// Background `i` of a frame: its own phase and block draws.
fn background(f: &RealFrame, i: u64, exposure_s: f64, phase: Option<(usize, usize)>) -> Vec<f32> {
    let mut rng = stream(17, i, Purpose::Noise);
    let phase = phase.unwrap_or((37 * i as usize + 5, 91 * i as usize + 11));
    f.background(SIZE, SIZE, exposure_s, phase, &mut rng)
}

/// Power of each frequency k = 1..n/2 (cycles per row) of the rows of an n x n image, mean
/// over every 4th row: a direct DFT (no FFT crate needed for 256 rows).
fn row_periodogram(img: &[f32], n: usize) -> Vec<f64> {
    let mut power = vec![0.0; n / 2 + 1];
    let (cos, sin): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|j| {
            let a = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
            (a.cos(), a.sin())
        })
        .unzip();
    let rows: Vec<usize> = (0..n).step_by(4).collect();
    for &y in &rows {
        let row = &img[y * n..(y + 1) * n];
        let mean = row.iter().map(|&v| v as f64).sum::<f64>() / n as f64;
        for (k, p) in power.iter_mut().enumerate().skip(1) {
            let (mut re, mut im) = (0.0, 0.0);
            for (x, &v) in row.iter().enumerate() {
                let j = (k * x) % n;
                re += (v as f64 - mean) * cos[j];
                im += (v as f64 - mean) * sin[j];
            }
            *p += (re * re + im * im) / rows.len() as f64;
        }
    }
    power
}

/// The largest ratio of a frequency's power to the median of its 16 neighbours, over k = 4..64
/// (periods of 16-256 px, where a block pitch or a tile period shows with its first harmonics;
/// below 4 the neighbourhood is one-sided). Higher frequencies are the sensor's own: the
/// calibrated frame has a 3-px pattern (k = 339, 1.8x its neighbours) in every pixel.
fn worst_peak(power: &[f64]) -> (usize, f64) {
    (4usize..=64)
        .map(|k| {
            let mut around: Vec<f64> = (k.saturating_sub(8)..(k + 9).min(power.len()))
                .filter(|&j| j != k && j > 0)
                .map(|j| power[j])
                .collect();
            around.sort_by(f64::total_cmp);
            (k, power[k] / around[around.len() / 2])
        })
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
}

/// No tiling peak: a frame's periodogram is smooth. Mean over 256 rows, each bin's power is a
/// chi-square of 512 degrees of freedom over the mean (sd ~6%; with correlated rows of a real
/// frame somewhat more): 512 bins against their neighbours stay below 1.5. The check is shown
/// to fail on a periodic tiling (the previous method) of the same frame.
#[test]
fn no_tiling_period_in_the_periodogram() {
    for name in FRAMES {
        let f = frame(name);
        let (k, ratio) = worst_peak(&row_periodogram(&background(&f, 0, 5.0, None), SIZE));
        assert!(
            ratio < 1.5,
            "{name}: power at k = {k} is {ratio} x its neighbours"
        );
        // The same frame tiled periodically (with its own width, at most half the image so the
        // pattern repeats in it) repeats: the check sees it.
        let p = f.width.min(SIZE / 2);
        let tiled: Vec<f32> = (0..SIZE * SIZE)
            .map(|i| f.pixels[(i / SIZE % f.height) * f.width + (i % SIZE) % p])
            .collect();
        let (_, tiled_ratio) = worst_peak(&row_periodogram(&tiled, SIZE));
        assert!(tiled_ratio > 2.0, "{name}: tiling not seen ({tiled_ratio})");
    }
}

/// Means and robust sigmas of each column of `n` images laid with the same phase (so the
/// block edges coincide): a seam is a column whose level or noise steps away from the rest.
fn column_stats(images: &[Vec<f32>], transpose: bool) -> Vec<(f64, f64)> {
    (0..SIZE)
        .map(|x| {
            let col: Vec<f32> = images
                .iter()
                .flat_map(|img| {
                    (0..SIZE).map(move |y| {
                        if transpose {
                            img[x * SIZE + y]
                        } else {
                            img[y * SIZE + x]
                        }
                    })
                })
                .collect();
            robust_stats(&col)
        })
        .collect()
}

/// No seam: over 4 images with the same block grid, every column's (and row's) median and
/// robust sigma sit within 6 sd of their spread over all columns; a weighted-mean cross-fade
/// fails this (module doc of `background::fill`).
#[test]
fn no_seam_at_block_edges() {
    for name in FRAMES {
        let f = frame(name);
        let images: Vec<Vec<f32>> = (0..4)
            .map(|i| background(&f, i, 5.0, Some((0, 0))))
            .collect();
        for transpose in [false, true] {
            let stats = column_stats(&images, transpose);
            let medians: Vec<f32> = stats.iter().map(|s| s.0 as f32).collect();
            let sigmas: Vec<f32> = stats.iter().map(|s| s.1 as f32).collect();
            for (what, v) in [("median", &medians), ("sigma", &sigmas)] {
                let (m, s) = robust_stats(v);
                let (at, worst) = v
                    .iter()
                    .enumerate()
                    .map(|(i, &x)| (i, (x as f64 - m).abs() / s))
                    .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
                assert!(
                    worst < 6.0,
                    "{name}: {} {at}: {what} {worst} sd off",
                    if transpose { "row" } else { "column" }
                );
            }
        }
    }
}
