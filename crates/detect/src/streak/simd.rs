//! Hot loops compiled twice: for the baseline x86-64 (SSE2) and for AVX2, chosen at run time.
//! Lane-by-lane additions, subtractions, products, comparisons and maxima are IEEE-exact at
//! any vector width, and the compiler never reorders a float sum without being told to, so
//! both give the same bits (the test below compares each AVX2 build with its baseline build,
//! and `lines`' test the sweep with its one-at-a-time reference); AVX2 does twice as many
//! lanes an instruction on nearly every x86-64 made since 2013. Where it is missing (or on
//! another architecture) the baseline build runs.

/// `fn name(args) -> R = inner`: a function that calls `inner(args)` compiled with AVX2
/// where the CPU has it (checked once per call: a cached flag), and as built elsewhere.
/// `inner` should be `#[inline(always)]` so that its loops are compiled in each.
macro_rules! avx2_dispatch {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($a:ident: $t:ty),* $(,)?) $(-> $r:ty)? = $inner:ident) => {
        $(#[$m])*
        $vis fn $name($($a: $t),*) $(-> $r)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                fn avx2($($a: $t),*) $(-> $r)? {
                    $inner($($a),*)
                }
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2 (checked on the line above).
                    return unsafe { avx2($($a),*) };
                }
            }
            $inner($($a),*)
        }
    };
}

#[cfg(test)]
mod tests {
    use super::super::gather::{axis_sum, axis_sums, contrast, contrast_at};
    use super::super::maps::Maps;
    use super::super::noise::{LineNoise, measured, measured_at};
    use super::super::params::{Sanitized, StreakParams};
    use super::super::refine::{axis_scores_at, level_axes};
    use super::super::smooth::{gaussian_kernel, smooth, smooth_at};
    use super::super::trails::{subtract_side_means, subtract_side_means_at};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// Each dispatched function (AVX2 where this CPU has it) gives the bits of its body built
    /// into this test function (baseline x86-64, no AVX2), on noise with a bright line, at
    /// sizes that leave vector remainders. (`lines::sweep` has its own reference test.)
    #[test]
    fn avx2_builds_give_the_baseline_bits() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for (w, h) in [(203, 157), (96, 300)] {
            let mut z: Vec<f32> = (0..w * h)
                .map(|_| StandardNormal.sample(&mut rng))
                .collect();
            for x in 10..w - 10 {
                z[(20 + x / 4) * w + x] += 4.0;
            }
            let k = gaussian_kernel(1.4);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&smooth(&z, w, h, &k)), bits(&smooth_at(&z, w, h, &k)));
            let (mut a, mut b) = (z.clone(), z.clone());
            subtract_side_means(&mut a, h, w, 0.37, 10, 1.4);
            subtract_side_means_at(&mut b, h, w, 0.37, 10, 1.4);
            assert_eq!(bits(&a), bits(&b));
            let p = Sanitized::new(&StreakParams::default());
            assert_eq!(measured(&z, w, h, &p, 512), measured_at(&z, w, h, &p, 512));
            let noise = LineNoise::white(&p);
            let maps = Maps {
                w,
                h,
                pixels: &vec![0; w * h],
                bg: &vec![0.0; w * h],
                z: &z,
                p: &p,
                noise: &noise,
                under_trails: None,
                removed: None,
                points: true,
                sample_corr: Default::default(),
            };
            // Contrast samples (15 taps, and fewer: padded lanes) inside, at and beyond the
            // edges.
            let taps = maps.contrast_taps();
            for (x, y) in [
                (50.3, 40.7),
                (0.2, 3.9),
                (w as f64 - 1.5, h as f64 + 3.0),
                (-9.0, -2.0),
            ] {
                for (nx, ny) in [(0.6, 0.8), (-1.0, 0.0), (0.28, -0.96)] {
                    for n in [taps.len(), 5, 1] {
                        let t = &taps[..n];
                        let a = contrast(&z, (w, h), t, (x, y), (nx, ny));
                        let b = contrast_at(&z, (w, h), t, (x, y), (nx, ny));
                        assert_eq!(a.to_bits(), b.to_bits(), "{w}x{h} at ({x}, {y}) {n} taps");
                    }
                }
            }
            // The gathered sums of a level's axes, four a vector, against one angle's axes a
            // sample at a time: axes inside, crossing the edges (clamped samples) and beside
            // the map, 1 to 9 a angle (padded lanes), every stride.
            let centres = [
                (w as f64 / 2.0, 25.0 + w as f64 / 8.0),
                (3.0, h as f64 - 2.5),
                (-4.0, 10.0),
            ];
            for (at, nu, stride) in [(centres[0], 4, 2), (centres[1], 2, 4), (centres[2], 1, 1)] {
                for theta in [0.1, 0.25, 1.3, -0.7] {
                    for nu in [0, nu] {
                        let a = axis_scores_at(&maps, at, theta, 60.0, 4.0, (0.5, nu), stride);
                        let axes = level_axes(&maps, at, &[theta], 60.0, (0.5, nu));
                        let sums = axis_sums(&z, (w, h), &axes, 4.0, stride);
                        let b: Vec<(f64, (f64, f64))> = sums
                            .iter()
                            .zip(&axes)
                            .map(|(&s, ax)| (s, (ax.x, ax.y)))
                            .collect();
                        let bits = |v: &[(f64, (f64, f64))]| {
                            v.iter()
                                .map(|(s, (x, y))| [s.to_bits(), x.to_bits(), y.to_bits()])
                                .collect::<Vec<_>>()
                        };
                        assert_eq!(
                            bits(&a),
                            bits(&b),
                            "{w}x{h} at {at:?} theta {theta} nu {nu}"
                        );
                        let one: Vec<u64> = axes
                            .iter()
                            .map(|ax| axis_sum(&z, (w, h), ax, 4.0, stride).to_bits())
                            .collect();
                        assert_eq!(one, sums.iter().map(|s| s.to_bits()).collect::<Vec<_>>());
                    }
                }
            }
        }
    }
}
