//! Render one image in memory, without writing anything: a campaign built in code from TOML
//! text (the paper's defaults, the debris of its Table 1), its experiment, and image 0 through
//! the same per-image function `soig run` uses.
//!
//! ```sh
//! cargo run --release --example render_one
//! ```

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::Path;

use soig::Campaign;

fn main() -> Result<(), soig::Error> {
    // NORAD 40649 from the paper's Table 1 (in no public catalogue) seen by an observer on the
    // same orbit kind; everything else is the paper's, with a 256 px sensor to keep it quick.
    let orbit = "elements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";
    let observer = "elements = { period_min = 100.99, inclination_deg = 98.62, apogee_km = 815.0, perigee_km = 798.0 }";
    let text = format!(
        "name = \"render-one\"\nimages = 1\n\
         [observer]\nnorad = 1\n{observer}\n\
         [[debris]]\nnorad = 40649\n{orbit}\n\
         [sensor]\nwidth_px = 256\nheight_px = 256\nfov_radius_deg = 0.025\n"
    );
    let campaign = Campaign::from_toml(&text, Path::new("render-one.toml"))?;
    let experiment = soig::experiment::of(&campaign);
    let inputs = soig::experiment::inputs(&campaign)?;

    let image = soig::simulate::image(&experiment, &inputs, 0)?;
    let truth = &image.exposure.truth;
    println!(
        "{}: magnitude {:.2}, {:.1} s exposure from {}, SNR {:.2}, {} draws",
        truth.object,
        truth.seen.magnitude,
        truth.exposure_s,
        truth.start_utc,
        truth.seen.snr,
        truth.attempts
    );
    let adu = &image.exposure.adu;
    let mean = adu.iter().map(|&v| v as f64).sum::<f64>() / adu.len() as f64;
    println!(
        "noisy image {} x {} px, mean {mean:.1} ADU; {} stars traced",
        image.exposure.width, image.exposure.height, truth.stars_traced
    );
    if let Some(product) = &image.product {
        println!(
            "8-bit image {} x {} px ({:?} frame), label boxes {:?}",
            product.png.width, product.png.height, product.frame.kind, product.labels
        );
    }
    Ok(())
}
