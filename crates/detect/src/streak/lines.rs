//! Step 3, the oriented line filter: sums of the clipped map along digital straight lines of
//! every orientation and length, in sigma, the best response and its orientation kept per pixel.

use super::digital_line::slope;
use super::noise::LineNoise;
use super::params::Sanitized;

/// Best response (sigma) and best orientation index per pixel; `noise` is `p`'s (it holds the
/// filters' white-noise sd too).
#[inline(never)]
pub(super) fn line_filter(
    zc: &[f32],
    w: usize,
    h: usize,
    p: &Sanitized,
    noise: &LineNoise,
) -> (Vec<f32>, Vec<u8>) {
    let n = p.n_angles;
    let (mut flat, mut steep) = (Vec::new(), Vec::new());
    for j in (0..n).filter(|&j| p.uses(j)) {
        let (x_major, t) = slope(j, n);
        let model = noise.model_sd(j);
        let inv: Vec<f32> = model
            .iter()
            .enumerate()
            .map(|(l, &sd)| (1.0 / (sd * noise.at(j, l))) as f32)
            .collect();
        let dir = Dir { j: j as u8, t, inv };
        if x_major {
            flat.push(dir);
        } else {
            steep.push(dir);
        }
    }
    // Steep (y-major) lines advance one row per step in the image itself; flat (x-major) lines
    // advance one row per step in the transposed image. The star-aware pass runs only the
    // orientations near the trails, often of one family: the other's transposes are skipped
    // (-inf merged in changes nothing).
    let mut best = vec![f32::NEG_INFINITY; w * h];
    sweep(&p.half_lengths, &steep, zc, h, w, &mut best);
    if !flat.is_empty() {
        let mut zt = vec![0f32; w * h];
        transpose(zc, &mut zt, w, h);
        let mut best_t = vec![f32::NEG_INFINITY; w * h];
        sweep(&p.half_lengths, &flat, &zt, w, h, &mut best_t);
        // Merge the transposed results.
        transpose(&best_t, &mut zt, h, w);
        for (b, &bt) in best.iter_mut().zip(&zt) {
            *b = b.max(bt);
        }
    }
    // Unpack the orientation index.
    let arg = best.iter().map(|v| (v.to_bits() & 0xFF) as u8).collect();
    (best, arg)
}

/// Blocked transpose of a `w` x `h` row-major map into `h` x `w`: 8-column strips of the
/// source, read a row at a time, fill 8 rows of the destination, whose lines stay in the L1
/// cache (32 blocks of rows 4 KiB apart, as before, contend for L1's sets: 0.8 ms against
/// 0.5 ms for a 1024 px map here).
#[inline(never)]
pub(super) fn transpose(src: &[f32], dst: &mut [f32], w: usize, h: usize) {
    const B: usize = 8;
    for x0 in (0..w).step_by(B) {
        let xn = (w - x0).min(B);
        for y in 0..h {
            for (x, &v) in src[y * w + x0..][..xn].iter().enumerate() {
                dst[(x0 + x) * h + y] = v;
            }
        }
    }
}

/// One orientation of the line filter: its index, slope and, per length, 1 / its noise sd.
struct Dir {
    j: u8,
    t: f64,
    inv: Vec<f32>,
}

/// One length's window of one orientation: line `r` passes through (row `i`, position
/// `r + round(i t)`), and `acc[r - round(i t) + smax]`, after step `i`, sums rows `i - k + 1
/// ..= i` of it. Each step adds row `i` and takes away row `i - k`, contiguous rows.
struct Window {
    acc: Vec<f32>,
    /// The next step to take.
    next: usize,
}

avx2_dispatch! {
    /// The orientations `dirs` of the line filter over a map of `rows` rows of `m` values, for
    /// lines that advance one row per step (|t| <= 1); the best response per value into `best`,
    /// which holds no NaN (it comes filled with -inf).
    /// Values beyond the map are zero (responses within half a window of an edge are
    /// conservative). All orientations go down the map together, row by row: each output row
    /// takes its maxima over them all while it is in the L1 cache, and the rows they add are the
    /// same ones (one orientation at a time streamed the whole map, 4-8 MB, through the cache
    /// twice per orientation). Every window's sums and every maximum are taken in the order the
    /// orientation-at-a-time loop took them, so the output is the same to the bit.
    fn sweep(halves: &[usize], dirs: &[Dir], src: &[f32], rows: usize, m: usize, best: &mut [f32]) = sweep_rows
}

#[inline(always)]
fn sweep_rows(
    halves: &[usize],
    dirs: &[Dir],
    src: &[f32],
    rows: usize,
    m: usize,
    best: &mut [f32],
) {
    // Per orientation: offset of row i's values in its windows (index = pos - s[i] + smax).
    let shifts: Vec<Vec<usize>> = dirs
        .iter()
        .map(|d| {
            let s: Vec<isize> = (0..rows)
                .map(|i| (i as f64 * d.t).round() as isize)
                .collect();
            let smax = s.iter().copied().max().unwrap_or(0).max(0);
            s.iter().map(|&v| (smax - v) as usize).collect()
        })
        .collect();
    let mut windows: Vec<Vec<Window>> = shifts
        .iter()
        .map(|shift| {
            let span = shift.iter().copied().max().unwrap_or(0) + m;
            let acc = vec![0.0; span];
            halves
                .iter()
                .map(|_| Window {
                    acc: acc.clone(),
                    next: 0,
                })
                .collect()
        })
        .collect();
    let row = |i: usize| &src[i * m..(i + 1) * m];
    for c in 0..rows {
        let brow = &mut best[c * m..(c + 1) * m];
        for ((d, shift), wins) in dirs.iter().zip(&shifts).zip(windows.iter_mut()) {
            for ((&hk, win), &f) in halves.iter().zip(wins.iter_mut()).zip(&d.inv) {
                let k = 2 * hk + 1;
                // Steps up to c + hk: the window centred on row c.
                while win.next <= c + hk {
                    let i = win.next;
                    let added = (i < rows).then(|| (shift[i], row(i)));
                    let taken = (i >= k && i - k < rows).then(|| (shift[i - k], row(i - k)));
                    match (added, taken) {
                        (Some((oa, ra)), Some((os, rs))) => add_sub(&mut win.acc, oa, ra, os, rs),
                        (Some((o, r)), None) => add(&mut win.acc[o..o + m], r),
                        (None, Some((o, r))) => sub(&mut win.acc[o..o + m], r),
                        (None, None) => {}
                    }
                    win.next += 1;
                }
                let o = shift[c];
                let j = d.j as u32;
                // The orientation index rides in the 8 low mantissa bits, so the update is a
                // plain (vectorised) max. `best` starts at -inf and only ever takes a greater
                // value, so it is never NaN, and `r > b` picks what `b.max(r)` did (b where r
                // is NaN or equal), in one instruction (`maxps`) where `max`'s NaN handling
                // took five.
                for (b, &v) in brow.iter_mut().zip(&win.acc[o..o + m]) {
                    let r = f32::from_bits(((v * f).to_bits() & !0xFF) | j);
                    *b = if r > *b { r } else { *b };
                }
            }
        }
    }
}

/// `acc[oa..][..m] += ra`, then `acc[os..][..m] -= rs` (`m` the rows' common length), in one
/// pass over `acc`: each value gets the same add, then the same subtraction, as in two
/// passes (the same bits), where the two ranges overlap read and written once.
#[inline(always)]
fn add_sub(acc: &mut [f32], oa: usize, ra: &[f32], os: usize, rs: &[f32]) {
    let m = ra.len();
    // The overlap [lo, hi) of the two ranges (empty when they lie apart).
    let (lo, hi) = (oa.max(os), (oa + m).min(os + m));
    if lo >= hi {
        add(&mut acc[oa..oa + m], ra);
        sub(&mut acc[os..os + m], rs);
        return;
    }
    // Before the overlap: one range only.
    if oa < lo {
        add(&mut acc[oa..lo], ra);
    } else {
        sub(&mut acc[os..lo], rs);
    }
    for ((a, &x), &y) in acc[lo..hi]
        .iter_mut()
        .zip(&ra[lo - oa..hi - oa])
        .zip(&rs[lo - os..hi - os])
    {
        *a = (*a + x) - y;
    }
    // After it: one range only.
    if oa + m > hi {
        add(&mut acc[hi..oa + m], &ra[hi - oa..]);
    } else {
        sub(&mut acc[hi..os + m], &rs[hi - os..]);
    }
}

/// `acc += r` and `acc -= r`, value by value over `acc`'s length (`r` may be longer).
#[inline(always)]
fn add(acc: &mut [f32], r: &[f32]) {
    for (a, &v) in acc.iter_mut().zip(r) {
        *a += v;
    }
}

#[inline(always)]
fn sub(acc: &mut [f32], r: &[f32]) {
    for (a, &v) in acc.iter_mut().zip(r) {
        *a -= v;
    }
}

#[cfg(test)]
mod tests {
    use super::super::params::{Sanitized, StreakParams};
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The line filter one orientation at a time, as it was before `sweep` took them all
    /// together (commit 7eec7c3): the reference the bits are checked against.
    fn one_at_a_time(zc: &[f32], w: usize, h: usize, p: &Sanitized, noise: &LineNoise) -> Vec<f32> {
        let n = p.n_angles;
        let mut zt = vec![0f32; w * h];
        transpose(zc, &mut zt, w, h);
        let mut best = vec![f32::NEG_INFINITY; w * h];
        let mut best_t = vec![f32::NEG_INFINITY; w * h];
        for j in (0..n).filter(|&j| p.uses(j)) {
            let (x_major, t) = slope(j, n);
            let inv: Vec<f32> = noise
                .model_sd(j)
                .iter()
                .enumerate()
                .map(|(l, &sd)| (1.0 / (sd * noise.at(j, l))) as f32)
                .collect();
            let (src, rows, m, best) = match x_major {
                true => (&zt[..], w, h, &mut best_t),
                false => (zc, h, w, &mut best),
            };
            let shift: Vec<usize> = {
                let s: Vec<isize> = (0..rows).map(|i| (i as f64 * t).round() as isize).collect();
                let smax = s.iter().copied().max().unwrap_or(0).max(0);
                s.iter().map(|&v| (smax - v) as usize).collect()
            };
            let span = shift.iter().copied().max().unwrap_or(0) + m;
            let mut accs = vec![vec![0f32; span]; p.half_lengths.len()];
            let hmax = *p.half_lengths.iter().max().unwrap();
            for i in 0..rows + hmax {
                for (l, &hk) in p.half_lengths.iter().enumerate() {
                    let k = 2 * hk + 1;
                    let acc = &mut accs[l];
                    if i < rows {
                        let o = shift[i];
                        for (a, &v) in acc[o..o + m].iter_mut().zip(&src[i * m..(i + 1) * m]) {
                            *a += v;
                        }
                    }
                    if i >= k && i - k < rows {
                        let (q, o) = (i - k, shift[i - k]);
                        for (a, &v) in acc[o..o + m].iter_mut().zip(&src[q * m..(q + 1) * m]) {
                            *a -= v;
                        }
                    }
                    if i >= hk && i - hk < rows {
                        let (c, o) = (i - hk, shift[i - hk]);
                        for (b, &v) in best[c * m..(c + 1) * m].iter_mut().zip(&acc[o..o + m]) {
                            let r = f32::from_bits(((v * inv[l]).to_bits() & !0xFF) | j as u32);
                            *b = b.max(r);
                        }
                    }
                }
            }
        }
        transpose(&best_t, &mut zt, h, w);
        best.iter().zip(&zt).map(|(b, &t)| b.max(t)).collect()
    }

    /// All orientations down the map together give the orientation-at-a-time responses and
    /// orientations bit for bit: on maps wider than tall and taller than wide, maps shorter
    /// than a window (3 and 5 rows against 21 and 51 px), every orientation and only those
    /// along a trail (the star-aware pass), and lengths in either order.
    #[test]
    fn all_orientations_at_once_give_the_same_bits() {
        let mut rng = ChaCha8Rng::seed_from_u64(44);
        let mut checked = 0;
        for &(w, h) in &[(97, 64), (40, 131), (5, 70), (83, 3), (128, 128)] {
            let zc: Vec<f32> = (0..w * h).map(|_| rng.random_range(-3.0f32..3.0)).collect();
            for (along, lengths) in [
                (None, vec![21, 51]),
                (Some(30.0), vec![21, 51]),
                (Some(95.0), vec![51, 7]),
            ] {
                let base = Sanitized::new(&StreakParams {
                    line_lengths_px: lengths,
                    ..StreakParams::default()
                });
                let p = Sanitized { along, ..base };
                let noise = LineNoise::measure(&zc, w, h, &p);
                let (best, arg) = line_filter(&zc, w, h, &p, &noise);
                let want = one_at_a_time(&zc, w, h, &p, &noise);
                for ((b, a), r) in best.iter().zip(&arg).zip(&want) {
                    assert_eq!(b.to_bits(), r.to_bits(), "{w}x{h} along {along:?}");
                    assert_eq!(*a as u32, r.to_bits() & 0xFF);
                }
                checked += best.len();
            }
        }
        assert!(checked > 50_000);
    }
}
