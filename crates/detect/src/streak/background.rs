//! Step 1, background and noise: sigma-clipped histogram median and MAD-sigma per mesh cell,
//! the mesh 3x3 median filtered, then interpolated bilinearly between cell centres.

use super::params::Sanitized;
use super::stats::{Hist, median_of};

/// Sigma-clipped median and MAD-sigma of a cell histogram.
fn cell_stats(counts: &[u32; 256], clip: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (-1.0f64, 256.0f64);
    let mut out = None;
    for _ in 0..4 {
        let mut c = [0u32; 256];
        for v in 0..256 {
            let fv = v as f64;
            if fv >= lo && fv <= hi {
                c[v] = counts[v];
            }
        }
        let hist = Hist::new(c);
        if hist.total() == 0 {
            break;
        }
        let med = hist.quantile(0.5);
        let sig = 1.4826 * hist.mad(med);
        out = Some((med, sig));
        let s = sig.max(0.5);
        lo = med - clip * s;
        hi = med + clip * s;
    }
    out
}

/// Cell boundaries: `n` nearly equal cells of about `mesh` pixels over `len` pixels.
fn cell_edges(len: usize, mesh: usize) -> Vec<usize> {
    let n = ((len + mesh / 2) / mesh).max(1);
    (0..=n).map(|i| i * len / n).collect()
}

fn median_filter_mesh(m: &[f64], nx: usize, ny: usize) -> Vec<f64> {
    let mut out = vec![0.0; m.len()];
    let mut buf = Vec::with_capacity(9);
    for j in 0..ny {
        for i in 0..nx {
            buf.clear();
            for jj in j.saturating_sub(1)..=(j + 1).min(ny - 1) {
                for ii in i.saturating_sub(1)..=(i + 1).min(nx - 1) {
                    buf.push(m[jj * nx + ii]);
                }
            }
            out[j * nx + i] = median_of(&buf);
        }
    }
    out
}

/// Per-axis interpolation weights between cell centres: (i0, i1, f) per pixel.
fn interp_axis(edges: &[usize], len: usize) -> Vec<(usize, usize, f32)> {
    let n = edges.len() - 1;
    let centres: Vec<f64> = (0..n)
        .map(|i| 0.5 * (edges[i] + edges[i + 1]) as f64 - 0.5)
        .collect();
    (0..len)
        .map(|x| {
            let xf = x as f64;
            if n == 1 || xf <= centres[0] {
                return (0, 0, 0.0);
            }
            if xf >= centres[n - 1] {
                return (n - 1, n - 1, 0.0);
            }
            let mut i = 0;
            while i + 1 < n && centres[i + 1] < xf {
                i += 1;
            }
            let f = (xf - centres[i]) / (centres[i + 1] - centres[i]);
            (i, i + 1, f as f32)
        })
        .collect()
}

/// Background and noise maps (grey levels), full resolution.
#[inline(never)]
pub(super) fn background(pixels: &[u8], w: usize, h: usize, p: &Sanitized) -> (Vec<f32>, Vec<f32>) {
    let ex = cell_edges(w, p.mesh);
    let ey = cell_edges(h, p.mesh);
    let (nx, ny) = (ex.len() - 1, ey.len() - 1);
    let mut mb = vec![0.0; nx * ny];
    let mut ms = vec![0.0; nx * ny];
    for j in 0..ny {
        for i in 0..nx {
            let mut counts = [0u32; 256];
            for y in ey[j]..ey[j + 1] {
                for &v in &pixels[y * w + ex[i]..y * w + ex[i + 1]] {
                    counts[v as usize] += 1;
                }
            }
            let (m, s) = cell_stats(&counts, p.mesh_clip).unwrap_or((0.0, p.min_sigma));
            mb[j * nx + i] = m;
            ms[j * nx + i] = s;
        }
    }
    let mb = median_filter_mesh(&mb, nx, ny);
    let ms = median_filter_mesh(&ms, nx, ny);
    let ix = interp_axis(&ex, w);
    let iy = interp_axis(&ey, h);
    let mut bg = vec![0f32; w * h];
    let mut sg = vec![0f32; w * h];
    let min_sigma = p.min_sigma as f32;
    let mut rb = vec![0f32; nx];
    let mut rs = vec![0f32; nx];
    for (y, &(j0, j1, fy)) in iy.iter().enumerate() {
        for i in 0..nx {
            rb[i] = (1.0 - fy) * mb[j0 * nx + i] as f32 + fy * mb[j1 * nx + i] as f32;
            rs[i] = (1.0 - fy) * ms[j0 * nx + i] as f32 + fy * ms[j1 * nx + i] as f32;
        }
        let row = y * w;
        for (x, &(i0, i1, fx)) in ix.iter().enumerate() {
            bg[row + x] = (1.0 - fx) * rb[i0] + fx * rb[i1];
            sg[row + x] = ((1.0 - fx) * rs[i0] + fx * rs[i1]).max(min_sigma);
        }
    }
    (bg, sg)
}
