//! What a run, a study or an experiment will cost, said before it starts, and the limits
//! beyond which it is refused unless the user passes `--force`: a number that sets the work (a
//! zero point, a seed or replicate count, a grid) must not start hours or years of work before
//! anything is written. The work of an image is `render::cost::image`'s upper bound.

use crate::campaign::{Campaign, CampaignError};
use crate::render::cost;

/// Most seconds of one core an image may take without `--force`: the paper's images take a
/// tenth of a second; one beyond this has a sensor no telescope has (a zero point of 40).
pub const MAX_IMAGE_SECONDS: f64 = 300.0;

/// Most seconds of one core a run (or a shard of one), a study or an experiment may take
/// without `--force`: 30 days.
pub const MAX_SECONDS: f64 = 30.0 * 86_400.0;

/// Seconds as a reader says them: seconds, hours, days or years.
pub fn duration(seconds: f64) -> String {
    if seconds < 10.0 {
        format!("{seconds:.2} s")
    } else if seconds < 3600.0 {
        format!("{seconds:.0} s")
    } else if seconds < 86_400.0 {
        format!("{:.1} hours", seconds / 3600.0)
    } else if seconds < 3.15e9 {
        format!("{:.1} days", seconds / 86_400.0)
    } else {
        format!("{:.1e} years", seconds / 3.156e7)
    }
}

/// The estimated work of one image of `campaign`.
pub fn image(campaign: &Campaign) -> cost::ImageCost {
    cost::image(&crate::experiment::of(campaign))
}

/// Refuse a run of `images` images of `campaign` whose image, or whole, would take beyond the
/// limits, unless `force`; the error names the field that sets the work and the estimate.
pub fn check_run(campaign: &Campaign, images: u64, force: bool) -> Result<(), CampaignError> {
    if force {
        return Ok(());
    }
    let c = image(campaign);
    if c.seconds > MAX_IMAGE_SECONDS {
        return Err(campaign.error_at(
            "sensor.zero_point_mag",
            format!(
                "one image would take up to about {} of one core ({:.1e} photon packets: with \
                 a zero point of {} a magnitude-{} star gives {:.1e} photo-electrons in {} s), \
                 beyond the limit of {}: lower the zero point or `sensor.mag_limit`, set \
                 `render.method = \"expected\"`, or pass --force",
                duration(c.seconds),
                c.packets,
                campaign.resolved.sensor.zero_point_mag,
                campaign.resolved.visibility.brightest_star_mag,
                c.brightest_electrons,
                campaign.resolved.exposure.max_s,
                duration(MAX_IMAGE_SECONDS),
            ),
        ));
    }
    let total = c.seconds * images as f64;
    if total > MAX_SECONDS {
        return Err(campaign.error_at(
            "images",
            format!(
                "{images} images of up to about {} each would take up to {} of one core, beyond \
                 the limit of {}: fewer images, shards (`soig run --shard`), or pass --force",
                duration(c.seconds),
                duration(total),
                duration(MAX_SECONDS),
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    const ELEMENTS: &str = "elements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";

    fn load(top: &str, extra: &str) -> Campaign {
        let text = format!(
            "name = \"t\"\n{top}[observer]\nnorad = 1\n{ELEMENTS}\n[[debris]]\nnorad = 40649\n{ELEMENTS}\n{extra}"
        );
        Campaign::from_toml(&text, Path::new("/nowhere/c.toml")).unwrap()
    }

    #[test]
    fn the_papers_images_pass_and_a_zero_point_of_40_is_refused_by_field() {
        let paper = load("", "");
        let c = image(&paper);
        assert!(c.seconds < 2.0, "{c:?}");
        check_run(&paper, 4000, false).unwrap();

        let bright = load(
            "",
            "[sensor]\nwidth_px = 128\nheight_px = 128\nzero_point_mag = 40.0\n",
        );
        let e = check_run(&bright, 2, false).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("sensor.zero_point_mag"), "{e}");
        assert_eq!(e.line, Some(11), "{e}");
        assert!(e.to_string().contains("--force"), "{e}");
        check_run(&bright, 2, true).unwrap();
        // The expected-flux renderer's work does not grow with the photons.
        let expected = load(
            "",
            "[sensor]\nwidth_px = 128\nheight_px = 128\nzero_point_mag = 40.0\n[render]\nmethod = \"expected\"\n",
        );
        check_run(&expected, 2, false).unwrap();
    }

    #[test]
    fn a_run_beyond_the_total_limit_names_images() {
        let many = load("images = 10000000\n", "");
        let e = check_run(&many, 10_000_000, false).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("images"), "{e}");
        assert!(e.to_string().contains("days"), "{e}");
        check_run(&many, 1000, false).unwrap();
    }
}
