//! Step 2, star masking: round compact sources of the smoothed map are zeroed out so that only
//! elongated structure reaches the line filter.

use std::f64::consts::PI;

use super::params::Sanitized;
use soig_image::imaging::bilinear;

/// Zero the smoothed map around round compact sources (stars): local maxima of `z` of at least
/// `star_mask_sigma` whose ring at radius 2 sqrt(2) psf_sigma (twice the smoothed PSF sigma)
/// stays below `star_ring_ratio` of the peak everywhere. A streak point has the ridge on its ring
/// and is kept. The disk zeroed reaches z = 1 of the smoothed star profile, plus 1 px.
#[inline(never)]
pub(super) fn mask_stars(z: &mut [f32], w: usize, h: usize, p: &Sanitized) -> usize {
    let thr = p.star_z as f32;
    let se = std::f64::consts::SQRT_2 * p.psf_sigma;
    let ring_r = 2.0 * se;
    const NR: usize = 16;
    let ring: Vec<(f64, f64)> = (0..NR)
        .map(|k| {
            let a = 2.0 * PI * k as f64 / NR as f64;
            (ring_r * a.cos(), ring_r * a.sin())
        })
        .collect();
    let mut stars = Vec::new();
    let (wi, hi) = (w as isize, h as isize);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let v = z[i];
            if v.is_nan() || v < thr {
                continue;
            }
            // Local maximum (neighbours inside the image); ties go to the first pixel in raster
            // order.
            let mut is_max = true;
            'nb: for dy in -1isize..=1 {
                for dx in -1isize..=1 {
                    let (xx, yy) = (x as isize + dx, y as isize + dy);
                    if (dx == 0 && dy == 0) || xx < 0 || yy < 0 || xx >= wi || yy >= hi {
                        continue;
                    }
                    let nv = z[yy as usize * w + xx as usize];
                    let earlier = dy < 0 || (dy == 0 && dx < 0);
                    if nv > v || (earlier && nv >= v) {
                        is_max = false;
                        break 'nb;
                    }
                }
            }
            if !is_max {
                continue;
            }
            // Ring points outside the image are left out (a star cut by the edge is still a
            // star); at least half of the ring must be inside.
            let (xf, yf) = (x as f64, y as f64);
            let mut ring_max = f64::NEG_INFINITY;
            let mut inside = 0;
            for &(dx, dy) in &ring {
                let (px, py) = (xf + dx, yf + dy);
                if px < 0.0 || py < 0.0 || px > (w - 1) as f64 || py > (h - 1) as f64 {
                    continue;
                }
                inside += 1;
                ring_max = ring_max.max(bilinear(z, w, h, px, py) as f64);
            }
            if inside * 2 >= NR && ring_max < p.star_ring_ratio * v as f64 {
                stars.push((x, y, v as f64));
            }
        }
    }
    for &(x, y, v) in &stars {
        let r = se * (2.0 * v.max(1.0).ln()).sqrt() + 1.0;
        let ri = r.ceil() as usize;
        for yy in y.saturating_sub(ri)..=(y + ri).min(h - 1) {
            for xx in x.saturating_sub(ri)..=(x + ri).min(w - 1) {
                let d2 = (xx as f64 - x as f64).powi(2) + (yy as f64 - y as f64).powi(2);
                if d2 <= r * r {
                    z[yy * w + xx] = 0.0;
                }
            }
        }
    }
    stars.len()
}
