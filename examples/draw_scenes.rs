//! Time the scene draw alone (no render) over a campaign's images, and fingerprint the scenes it
//! accepts, so that a change to the draw can be shown to keep every accepted scene and to cost
//! less: the same fingerprint before and after means the same scenes, attempts and rejections.
//! `--set KEY=VALUE` overrides the campaign as `soig run --set` does (e.g. the gate's
//! `visibility.snr_definition="noise_sigma"`).
//!
//! ```sh
//! cargo run --release --example draw_scenes -- campaigns/paper-fixed-original-small.toml [IMAGES] [EXPOSURE_S] [--set KEY=VALUE]...
//! ```

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::Path;
use std::time::Instant;

use soig::Campaign;

fn main() -> Result<(), soig::Error> {
    let (mut args, mut sets) = (Vec::new(), Vec::new());
    let mut argv = std::env::args().skip(1);
    while let Some(a) = argv.next() {
        match a.as_str() {
            "--set" => sets.push(argv.next().expect("--set takes KEY=VALUE")),
            _ => args.push(a),
        }
    }
    let path = args
        .first()
        .map(String::as_str)
        .unwrap_or("campaigns/quickstart.toml");
    let campaign = Campaign::load_with_overrides(Path::new(path), &sets)?;
    let mut x = soig::experiment::of(&campaign);
    let images: u64 = args
        .get(1)
        .map(|s| s.parse().expect("IMAGES is a count"))
        .unwrap_or(campaign.resolved.images as u64);
    if let Some(e) = args.get(2) {
        // One exposure for every draw, to see how the draw's cost grows with it.
        let e: f64 = e.parse().expect("EXPOSURE_S is seconds");
        x.scene.exposure_min_s = e;
        x.scene.exposure_max_s = e;
    }
    let inputs = soig::experiment::inputs(&campaign)?;

    let mut fingerprint = DefaultHasher::new();
    let (mut attempts, mut failed) = (0u64, 0u64);
    // Why draws were rejected, over accepted and failed images alike.
    let mut reasons = std::collections::BTreeMap::<soig::scene::Rejection, u64>::new();
    // The draws alone are timed: fingerprinting a scene (its Debug text, stars and all) costs
    // a fifth as much again.
    let mut drawing = std::time::Duration::ZERO;
    for image in 0..images {
        let t = Instant::now();
        let drawn = soig::scene::draw(&x.scene, &x.sensor, &inputs, x.seed, image);
        drawing += t.elapsed();
        match drawn {
            Ok(s) => {
                attempts += u64::from(s.attempts);
                for (k, v) in &s.rejections {
                    *reasons.entry(*k).or_default() += u64::from(*v);
                }
                // The Debug text holds every field, floats to the last bit.
                format!("{s:?}").hash(&mut fingerprint);
            }
            Err(e) => {
                failed += 1;
                attempts += u64::from(e.attempts);
                for (k, v) in &e.rejections {
                    *reasons.entry(*k).or_default() += u64::from(*v);
                }
                format!("{:?}", e.rejections).hash(&mut fingerprint);
            }
        }
    }
    let ms = drawing.as_secs_f64() * 1e3;
    println!(
        "{path}: {images} images, {attempts} attempts ({failed} never visible), {:.2} ms per image, {:.1} us per attempt, fingerprint {:016x}",
        ms / images as f64,
        ms * 1e3 / attempts.max(1) as f64,
        fingerprint.finish()
    );
    println!("rejections: {reasons:?}");
    Ok(())
}
