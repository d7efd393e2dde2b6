//! Contract tests of step 7's gap and dip tests (`accept::gap`, `accept::dip`), each on a
//! small synthetic map: a bright trail beside a streak, star blobs in a row, a tumbling
//! streak's dim stretch. The maps and the `World` they are read in are `tests_stages`'.

use super::accept::{Reading, dip, gap};
use super::params::Sanitized;
use super::refine::Regime;
use super::segment::Seg;
use super::tests_stages::{H, SE, W, World, params, refined, streak_map};

/// Step 7, the gap test: a bright trail in one side band (11 px off, over 20 px) makes a gap
/// of a streak against both side bands, none against the quieter (the pass along the frame's
/// own trails); a true gap stays one.
#[test]
fn gap_against_the_quieter_side_band() {
    let mut z = streak_map(3.0, 64.0, 30, 90);
    let beside = streak_map(30.0, 75.0, 50, 70);
    z.iter_mut().zip(&beside).for_each(|(a, b)| *a += b);
    let mut world = World::new(z);
    let s = refined(&World::new(streak_map(3.0, 64.0, 30, 90)).maps()).unwrap();
    assert!(gap(&world.maps(), &s, Reading::Chunks).is_some());
    world.p.quiet_side = true;
    assert_eq!(gap(&world.maps(), &s, Reading::Chunks), None);
    // A hole of 17 px in the streak (one of its four chunks of 15 px, at its SNR) is a gap on
    // either side.
    let mut z = streak_map(3.0, 64.0, 30, 90);
    for y in 0..H {
        for x in 44..61 {
            z[y * W + x] = 0.0;
        }
    }
    let world = World {
        p: Sanitized {
            quiet_side: true,
            ..params()
        },
        ..World::new(z)
    };
    assert!(gap(&world.maps(), &s, Reading::Chunks).is_some());
}

/// A round star blob of peak `amp` at (`cx`, 64), sigma 3 px (a jitter-smeared star), added
/// into the map `z`.
fn blob(z: &mut [f32], cx: f64, amp: f64) {
    for y in 0..H {
        for x in 0..W {
            let d2 = (x as f64 - cx).powi(2) + (y as f64 - 64.0).powi(2);
            z[y * W + x] += (amp * (-d2 / (2.0 * 9.0)).exp()) as f32;
        }
    }
}

/// A segment of `length` along y = 64 centred at x = 64, of SNR 10 (a refined streak's other
/// measurements).
fn across_the_middle(length: f64) -> Seg {
    let s = refined(&World::new(streak_map(3.0, 64.0, 30, 90)).maps()).unwrap();
    Seg {
        cx: 64.0,
        cy: 64.0,
        theta: 0.0,
        length,
        snr: 10.0,
        ..s
    }
}

/// Step 7, the gap test where stars are points: three round blobs 14 px apart in a row (a
/// short "streak" of SNR 10) have dips between them that the chunks split, and only the test
/// at every window position finds; a streak of the same length and level has none.
#[test]
fn gap_between_star_blobs_in_a_row() {
    let mut z = vec![0f32; W * H];
    for cx in [50.0, 64.0, 78.0] {
        blob(&mut z, cx, 7.0);
    }
    let world = World::new(z);
    let s = across_the_middle(41.0);
    assert_eq!(gap(&world.maps(), &s, Reading::Chunks), None);
    let g = gap(
        &world.maps(),
        &s,
        Reading::of(&s, true, Regime::Resolved, false),
    )
    .expect("a gap between the blobs");
    assert!(g.level < 0.5, "{g:?}");
    let even = World::new(streak_map(5.0, 64.0, 44, 84));
    assert_eq!(
        gap(
            &even.maps(),
            &s,
            Reading::of(&s, true, Regime::Resolved, false)
        ),
        None
    );
    // A long segment is tested in its chunks only: five blobs in a row, the segment within
    // them (beyond the blobs, its ends would be gaps by any reading).
    let mut z = vec![0f32; W * H];
    for cx in [36.0, 50.0, 64.0, 78.0, 92.0] {
        blob(&mut z, cx, 7.0);
    }
    let five = World::new(z);
    let long = Seg { length: 65.0, ..s };
    let reading = Reading::of(&long, true, Regime::Resolved, false);
    assert_eq!(reading, Reading::Chunks);
    assert_eq!(gap(&five.maps(), &long, reading), None);
}

/// Step 7, the gap test where stars are points, on a resolved segment longer than
/// `TUMBLE_MIN_PX`: a tumbling streak's dim stretch (0.4 of its level) is no gap, a hole is;
/// elsewhere (stars as trails, a full-line segment, a line along the frame's outline) the dim
/// stretch stays one.
#[test]
fn a_tumbling_streaks_dim_stretch_is_no_gap_where_stars_are_points() {
    let (w, h) = (320usize, 100usize);
    // A streak along row 50 from x 20 to 299 at 3 (unit noise), x 150..205 at `dim`.
    let map = |dim: f64| -> Vec<f32> {
        let mut z = vec![0f32; w * h];
        for y in 0..h {
            let d = y as f64 - 50.0;
            for x in 20..300 {
                let amp = if (150..205).contains(&x) { dim } else { 3.0 };
                z[y * w + x] = (amp * (-d * d / (2.0 * SE * SE)).exp()) as f32;
            }
        }
        z
    };
    let gap_of = |z: Vec<f32>, points: bool, regime: Regime, along_edge: bool| {
        let s = Seg {
            cx: 159.5,
            cy: 50.0,
            theta: 0.0,
            length: 280.0,
            snr: 12.0,
            flux: 0.0,
            elongation: 10.0,
            contrast: true,
        };
        let world = World::sized(z, w, h);
        gap(
            &world.maps(),
            &s,
            Reading::of(&s, points, regime, along_edge),
        )
    };
    let dim = || map(1.2);
    assert_eq!(gap_of(dim(), true, Regime::Resolved, false), None);
    assert!(gap_of(dim(), false, Regime::Resolved, false).is_some());
    assert!(gap_of(dim(), true, Regime::SubNoise { min: 100 }, false).is_some());
    assert!(gap_of(map(0.0), true, Regime::Resolved, false).is_some());
    // Along the frame's outline a long line is the frame's edge, read against its level.
    assert!(gap_of(dim(), true, Regime::Resolved, true).is_some());
}

/// Step 7, the dip test where stars are points: two round blobs 10 px apart (their dip at
/// about 0.45 of their peaks, but above half the pair's median level, which the dip itself
/// pulls down) are a gap; a streak whose brightness doubles along it, with no dip, is none.
#[test]
fn dip_between_two_close_star_blobs() {
    let mut z = vec![0f32; W * H];
    blob(&mut z, 59.0, 7.0);
    blob(&mut z, 69.0, 7.0);
    let pair = World::new(z);
    let s = across_the_middle(24.0);
    let g = gap(
        &pair.maps(),
        &s,
        Reading::of(&s, true, Regime::Resolved, false),
    )
    .expect("a dip between the blobs");
    assert!(g.level > 0.3 && g.level < 0.55, "{g:?}");
    // A streak from x 44 to 84 brightening twofold along it.
    let mut z = vec![0f32; W * H];
    for x in 44..84 {
        let amp = 3.0 + 3.0 * (x - 44) as f64 / 39.0;
        for y in 0..H {
            let d2 = (y as f64 - 64.0).powi(2);
            z[y * W + x] += (amp * (-d2 / (2.0 * SE * SE)).exp()) as f32;
        }
    }
    assert_eq!(
        gap(
            &World::new(z).maps(),
            &s,
            Reading::of(&s, true, Regime::Resolved, false)
        ),
        None
    );
    // The dip alone, on profiles: two bumps at 0.37 of their peaks between them are a gap where
    // the dip is significant, not where the noise is as large; an even profile with a ripple
    // has none.
    let bumps: Vec<f64> = (0..30)
        .map(|i| {
            let b = |c: f64| 8.0 * (-(i as f64 - c).powi(2) / 18.0).exp();
            b(9.0) + b(20.0)
        })
        .collect();
    let g = dip(&bumps, 0.5).expect("a dip");
    assert!(g.level < 0.55 && g.sigma > 2.5, "{g:?}");
    assert_eq!(dip(&bumps, 5.0), None);
    let even: Vec<f64> = (0..30).map(|i| 6.0 + 0.3 * (i as f64).sin()).collect();
    assert_eq!(dip(&even, 0.5), None);
}
