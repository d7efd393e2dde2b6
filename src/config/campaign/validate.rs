//! Field-level checks of a parsed campaign that need no files: ranges, units, consistency
//! between sections, the order of stages. Each failure names the field path it is about.

use super::{CampaignFile, FrameKind, LightCurve, PointingMode, Stage, Stars, defaults};

/// Most model stars a scene's star cone may hold.
const MAX_STARS_PER_CONE: f64 = 2e6;

/// Highest background or bias level, ADU (see `validate`).
pub use crate::scene::MAX_OBJECTS_PER_FRAME;

const MAX_LEVEL_ADU: f64 = 1e9;

/// Largest debris area, m^2 (see `validate`).
const MAX_AREA_M2: f64 = 1e4;

/// Field-level checks that need no files. Returns (field path, message).
pub(super) fn validate(c: &CampaignFile) -> Checked {
    top(c)?;
    exposure(c)?;
    sensor(c)?;
    photometry(c)?;
    visibility(c)?;
    enhance(c)?;
    detect(c)
}

/// The first field that fails a check: (field path, message).
type Checked = Result<(), (String, String)>;

fn check(ok: bool, field: &str, msg: &str) -> Checked {
    if ok {
        Ok(())
    } else {
        Err((field.to_string(), msg.to_string()))
    }
}

fn pos(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

fn nonneg(x: f64) -> bool {
    x.is_finite() && x >= 0.0
}

/// The campaign as a whole: its name, output, image count, collects and objects per frame.
fn top(c: &CampaignFile) -> Checked {
    check(!c.name.trim().is_empty(), "name", "must not be empty")?;
    if let Some(k) = &c.collect {
        check(
            (1..=10_000).contains(&k.frames),
            "collect.frames",
            "must be between 1 and 10000",
        )?;
        check(
            c.images.is_multiple_of(k.frames),
            "collect.frames",
            "must divide `images` (every collect has all its frames)",
        )?;
        check(
            k.gap_s.is_finite() && (0.0..=86_400.0).contains(&k.gap_s),
            "collect.gap_s",
            "must be in [0, 86400] seconds",
        )?;
    }
    check(
        c.name
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || "-_.".contains(ch)),
        "name",
        "use only letters, digits, '-', '_' and '.' (it names folders)",
    )?;
    check(
        !c.name.starts_with('.'),
        "name",
        "must not begin with '.' (`.` and `..` name the folders around the output, and a hidden \
         output is one a user does not see)",
    )?;
    // The output replaces a folder: `.`, `..` or `/` would be one that holds others (the
    // campaign's among them).
    check(
        c.output.as_ref().is_none_or(|o| {
            matches!(
                std::path::Path::new(o).components().next_back(),
                Some(std::path::Component::Normal(_))
            )
        }),
        "output",
        "must end in a folder name, not `.`, `..` or `/` (the output replaces that folder)",
    )?;
    check(
        (1..=10_000_000).contains(&c.images),
        "images",
        "must be between 1 and 10000000",
    )?;
    check(
        !c.debris.is_empty() || c.pointing.stare.is_some(),
        "debris",
        "name at least one debris object (a stare, `pointing.stare`, needs none)",
    )?;
    if let Some(o) = &c.objects {
        let (min, max) = o.per_frame.bounds();
        check(
            min <= max,
            "objects.per_frame.max",
            "must be >= objects.per_frame.min",
        )?;
        check(
            max <= MAX_OBJECTS_PER_FRAME,
            "objects.per_frame",
            &format!("must be at most {MAX_OBJECTS_PER_FRAME} objects"),
        )?;
        check(
            (0.0..=1.0).contains(&o.empty_share),
            "objects.empty_share",
            "must be in [0, 1]",
        )?;
    }
    population(c)
}

/// `[population]` and `pointing.stare`: a catalogue scene shows where the orbits put every
/// object, so it has no placed objects, and a stare is a fixed direction of a catalogue scene.
fn population(c: &CampaignFile) -> Checked {
    if c.population.is_some() {
        // A ground site's night spans are drawn per debris object; a stare has none.
        check(
            c.observer.site.is_none(),
            "population",
            "a catalogue scene is seen from a satellite observer: drop `observer.site` or `[population]`",
        )?;
        check(
            c.objects.is_none(),
            "population",
            "a catalogue scene shows every object of the population where its orbit puts it: \
             drop `[objects]` (placed objects) or `[population]`",
        )?;
    }
    if let Some(s) = &c.pointing.stare {
        check(
            c.population.is_some(),
            "pointing.stare",
            "a stare shows the objects of a `[population]`: add one",
        )?;
        check(
            c.pointing.mode == PointingMode::Fixed,
            "pointing.stare",
            "a stare is a fixed direction: set `pointing.mode = \"fixed\"`",
        )?;
        check(
            s.ra_deg.is_finite() && (0.0..360.0).contains(&s.ra_deg),
            "pointing.stare.ra_deg",
            "must be in [0, 360) degrees",
        )?;
        check(
            s.dec_deg.is_finite() && (-90.0..=90.0).contains(&s.dec_deg),
            "pointing.stare.dec_deg",
            "must be in [-90, 90] degrees",
        )?;
    }
    Ok(())
}

/// `[exposure]`: the exposure bounds.
fn exposure(c: &CampaignFile) -> Checked {
    let e = &c.exposure;
    check(
        pos(e.min_s),
        "exposure.min_s",
        "must be a positive number of seconds",
    )?;
    check(
        pos(e.max_s),
        "exposure.max_s",
        "must be a positive number of seconds",
    )?;
    check(
        e.max_s >= e.min_s,
        "exposure.max_s",
        "must be >= exposure.min_s",
    )?;
    check(
        e.max_s <= 3600.0,
        "exposure.max_s",
        "must be at most 3600 s",
    )?;
    check(
        c.pointing.placement_fraction > 0.0 && c.pointing.placement_fraction <= 1.0,
        "pointing.placement_fraction",
        "must be in (0, 1]",
    )?;
    Ok(())
}

/// `[sensor]` and the star budget it implies, and a catalogue's epoch.
fn sensor(c: &CampaignFile) -> Checked {
    let s = &c.sensor;
    check(
        (16..=16384).contains(&s.width_px),
        "sensor.width_px",
        "must be between 16 and 16384",
    )?;
    check(
        (16..=16384).contains(&s.height_px),
        "sensor.height_px",
        "must be between 16 and 16384",
    )?;
    check(
        pos(s.fov_radius_deg) && s.fov_radius_deg <= 10.0,
        "sensor.fov_radius_deg",
        "must be in (0, 10] degrees (the gnomonic projection is used)",
    )?;
    // Bounds of real instruments, with room: a zero point of 0 is a telescope that collects one
    // photo-electron per second from a magnitude-0 star, 40 one far beyond the largest built;
    // CCD and CMOS gains are 0.1-20 e-/ADU.
    check(
        (0.0..=40.0).contains(&s.zero_point_mag),
        "sensor.zero_point_mag",
        "must be a magnitude in [0, 40] (the magnitude that gives 1 e-/s)",
    )?;
    check(
        (1e-3..=1e4).contains(&s.gain_e_per_adu),
        "sensor.gain_e_per_adu",
        "must be in [0.001, 10000] e-/ADU",
    )?;
    // Levels in ADU: a 32-bit detector counts to 4.3e9, so 1e9 is beyond any real sky or
    // bias, and beyond it the noise swamps every streak (no scene passes the SNR gate).
    let adu = |x: f64| nonneg(x) && x <= MAX_LEVEL_ADU;
    check(
        adu(s.background_min_adu),
        "sensor.background_min_adu",
        "must be in [0, 1e9] ADU",
    )?;
    check(
        adu(s.background_max_adu) && s.background_max_adu >= s.background_min_adu,
        "sensor.background_max_adu",
        "must be in [sensor.background_min_adu, 1e9] ADU",
    )?;
    // The exposure the background levels are for; an image scales them by t / this, which
    // stays within the exposure bounds' 1 ms - 1 h.
    check(
        (1e-3..=3600.0).contains(&s.background_exposure_s),
        "sensor.background_exposure_s",
        "must be in [0.001, 3600] seconds",
    )?;
    check(
        adu(s.bias_min_adu),
        "sensor.bias_min_adu",
        "must be in [0, 1e9] ADU",
    )?;
    check(
        adu(s.bias_max_adu) && s.bias_max_adu >= s.bias_min_adu,
        "sensor.bias_max_adu",
        "must be in [sensor.bias_min_adu, 1e9] ADU",
    )?;
    check(
        s.mag_limit.is_finite() && s.mag_limit <= 30.0,
        "sensor.mag_limit",
        "must be a magnitude <= 30",
    )?;
    // Far below any telescope's diffraction limit (0.05" for Hubble) a streak needs more
    // samples than a scene may draw; beyond a degree the PSF is no longer a PSF.
    check(
        (0.01..=3600.0).contains(&s.psf_sigma_arcsec),
        "sensor.psf_sigma_arcsec",
        "must be in [0.01, 3600] arcsec",
    )?;
    // A pointing that wanders a degree in a second is a tumbling spacecraft, not jitter.
    check(
        nonneg(s.jitter_deg_per_sqrt_s) && s.jitter_deg_per_sqrt_s <= 1.0,
        "sensor.jitter_deg_per_sqrt_s",
        "must be in [0, 1] deg/sqrt(s)",
    )?;
    check(
        pos(c.stars.cone_radius_deg()) && c.stars.cone_radius_deg() <= 10.0,
        "stars.cone_radius_deg",
        "must be in (0, 10] degrees",
    )?;
    // The star budget: the model count of stars to the limiting magnitude in the widest cone a
    // scene loads, in the galactic plane. Beyond this an image's star query alone takes minutes.
    let cone_deg = match c.pointing.mode {
        PointingMode::Fixed => c.stars.cone_radius_deg(),
        // A tracking scene's cone is its whole path plus the field (`scene::try_draw`).
        PointingMode::Track => {
            super::MAX_SURVEY_DRIFT_DEG
                + s.fov_radius_deg * (1.0f64).hypot(s.height_px as f64 / s.width_px as f64)
        }
        PointingMode::Survey => {
            super::MAX_SURVEY_DRIFT_DEG / 2.0
                + s.fov_radius_deg * (1.0f64).hypot(s.height_px as f64 / s.width_px as f64)
        }
    };
    let stars = crate::sky::stars::cumulative_density_per_deg2(0.0, s.mag_limit)
        * std::f64::consts::PI
        * cone_deg
        * cone_deg;
    if stars > MAX_STARS_PER_CONE {
        return Err((
            "sensor.mag_limit".into(),
            format!(
                "about {stars:.1e} stars brighter than magnitude {} in a {cone_deg:.2} deg star cone \
                 (at most {MAX_STARS_PER_CONE:.0e}): lower the limiting magnitude or the cone",
                s.mag_limit
            ),
        ));
    }
    c.noise
        .check(&c.background)
        .map_err(|(field, msg)| (format!("noise.{field}"), msg))?;
    if let Stars::Catalog { epoch_jyear, .. } = c.stars {
        check(
            (1000.0..=3000.0).contains(&epoch_jyear),
            "stars.epoch_jyear",
            "must be a Julian year such as 2016.0",
        )?;
    }
    Ok(())
}

/// `[photometry]` and the debris objects' weights.
fn photometry(c: &CampaignFile) -> Checked {
    let p = &c.photometry;
    if !p.preset.is_paper() {
        for (field, set, default) in [
            (
                "photometry.rcs_mean_m2",
                p.rcs_mean_m2,
                defaults::rcs_mean(),
            ),
            ("photometry.rcs_std_m2", p.rcs_std_m2, defaults::rcs_std()),
            ("photometry.albedo", p.albedo, defaults::albedo()),
        ] {
            check(
                set == default,
                field,
                "the photometry preset sets the area and albedo: remove this field or the preset",
            )?;
        }
    }
    // The largest object in orbit, the ISS, presents a few thousand m^2.
    check(
        p.rcs_mean_m2.is_finite() && p.rcs_mean_m2.abs() <= MAX_AREA_M2,
        "photometry.rcs_mean_m2",
        "must be in [-1e4, 1e4] m^2",
    )?;
    check(
        nonneg(p.rcs_std_m2) && p.rcs_std_m2 <= MAX_AREA_M2,
        "photometry.rcs_std_m2",
        "must be in [0, 1e4] m^2",
    )?;
    check(
        p.rcs_mean_m2 != 0.0 || p.rcs_std_m2 > 0.0,
        "photometry.rcs_std_m2",
        "with rcs_mean_m2 = 0 the area is always 0: give a positive std",
    )?;
    // The diffuse sphere of Eq. 7 reflects at most what it receives.
    check(
        pos(p.albedo) && p.albedo <= 1.0,
        "photometry.albedo",
        "must be in (0, 1]",
    )?;
    if let LightCurve::Tumbling {
        period_min_s,
        period_max_s,
        amplitude_max,
    } = p.light_curve
    {
        check(
            pos(period_min_s),
            "photometry.light_curve.period_min_s",
            "must be positive",
        )?;
        check(
            pos(period_max_s) && period_max_s >= period_min_s,
            "photometry.light_curve.period_max_s",
            "must be >= period_min_s",
        )?;
        check(
            (0.0..1.0).contains(&amplitude_max),
            "photometry.light_curve.amplitude_max",
            "must be in [0, 1): the flux factor 1 + a sin(..) must stay positive",
        )?;
    }
    check(
        c.observer.weight.is_none(),
        "observer.weight",
        "only debris objects have a weight (the observer is in every image)",
    )?;
    let mut total = 0.0;
    for (i, d) in c.debris.iter().enumerate() {
        if let Some(w) = d.weight {
            check(
                pos(w),
                &format!("debris[{i}].weight"),
                "must be a positive, finite number",
            )?;
        }
        // The weights are drawn from by their running sum, which must stay finite.
        total += d.weight.unwrap_or(1.0);
        check(
            total.is_finite(),
            &format!("debris[{i}].weight"),
            "makes the debris weights sum beyond the largest number (1.8e308): give smaller weights",
        )?;
    }
    Ok(())
}

/// `[visibility]` and `[render]`.
fn visibility(c: &CampaignFile) -> Checked {
    let v = &c.visibility;
    for (f, x) in [
        ("visibility.earth_min_deg", v.earth_min_deg),
        ("visibility.sun_min_deg", v.sun_min_deg),
        ("visibility.moon_min_deg", v.moon_min_deg),
    ] {
        check(
            (0.0..=180.0).contains(&x),
            f,
            "must be an angle in [0, 180] degrees",
        )?;
    }
    check(
        nonneg(v.earth_clearance_km),
        "visibility.earth_clearance_km",
        "must be >= 0",
    )?;
    check(
        v.brightest_star_mag.is_finite(),
        "visibility.brightest_star_mag",
        "must be finite",
    )?;
    if let Some(snr) = v.snr_min {
        check(nonneg(snr), "visibility.snr_min", "must be >= 0")?;
    }
    // A scene draw takes about 0.1 ms: 1e5 draws are ~10 s per image before an impossible
    // scene is reported, where 4e9 would hang for days.
    check(
        (1..=100_000).contains(&v.max_attempts),
        "visibility.max_attempts",
        "must be between 1 and 100000",
    )?;
    let r = &c.render;
    check(
        (2..=crate::scene::MAX_TRAJECTORY_SAMPLES as u32).contains(&r.trajectory_samples),
        "render.trajectory_samples",
        "must be between 2 and 1000000",
    )?;
    check(
        r.merge_threshold >= 1,
        "render.merge_threshold",
        "must be >= 1",
    )?;
    check(
        (1..=1000).contains(&r.merge_factor),
        "render.merge_factor",
        "must be between 1 and 1000",
    )?;
    check(
        (1..=1_000_000).contains(&r.jitter_steps),
        "render.jitter_steps",
        "must be between 1 and 1000000",
    )?;
    Ok(())
}

/// `[enhance]` and `[train]`.
fn enhance(c: &CampaignFile) -> Checked {
    let en = &c.enhance;
    check(
        nonneg(en.clahe_clip_limit),
        "enhance.clahe_clip_limit",
        "must be >= 0",
    )?;
    check(
        en.clahe_tiles
            .iter()
            .all(|t| crate::enhance::CLAHE_TILES.contains(t)),
        "enhance.clahe_tiles",
        "each must be between 1 and 64",
    )?;
    check(
        crate::enhance::GAMMA.contains(&en.gamma),
        "enhance.gamma",
        "must be in [0.05, 20]",
    )?;
    check(en.pad_px <= 4096, "enhance.pad_px", "must be at most 4096")?;
    check(
        en.geometry != FrameKind::Rotated || c.pointing.mode != PointingMode::Fixed,
        "enhance.geometry",
        "`rotated` needs survey or track pointing (fixed images have no star trails to align)",
    )?;
    let t = &c.train;
    check(
        (1..=100_000).contains(&t.epochs),
        "train.epochs",
        "must be between 1 and 100000",
    )?;
    check(
        t.batch.is_none_or(|b| b >= 1),
        "train.batch",
        "must be >= 1",
    )?;
    check(
        t.imgsz
            .is_none_or(|s| (32..=8192).contains(&s) && s % 32 == 0),
        "train.imgsz",
        "must be a multiple of 32 between 32 and 8192",
    )?;
    check(
        t.time_hours.is_none_or(|h| h > 0.0),
        "train.time_hours",
        "must be positive",
    )?;
    check(
        t.channels.is_none_or(|c| c == 1 || c == 3),
        "train.channels",
        "must be 1 (grey) or 3 (grey replicated to BGR)",
    )?;
    Ok(())
}

/// `[detect]`, `[split]` and `stages`.
fn detect(c: &CampaignFile) -> Checked {
    let d = &c.detect;
    check(
        d.conf > 0.0 && d.conf <= 1.0,
        "detect.conf",
        "must be in (0, 1]",
    )?;
    check(
        d.iou > 0.0 && d.iou <= 1.0,
        "detect.iou",
        "must be in (0, 1]",
    )?;
    check(d.max_det >= 1, "detect.max_det", "must be >= 1")?;
    d.streak
        .check()
        .map_err(|(field, msg)| (format!("detect.streak.{field}"), msg))?;
    let training = c.stages.contains(&Stage::Train);
    check(
        d.model.is_some() || training || d.classical || !c.stages.contains(&Stage::Detect),
        "detect",
        "the detect stage needs a `model`, a `train` stage or `classical = true`",
    )?;
    check(
        !(training && d.model.is_some()),
        "detect.model",
        "a campaign with a `train` stage detects with the model it trains: remove `detect.model`",
    )?;
    check(
        !c.artifacts.coco || c.stages.contains(&Stage::Enhance),
        "artifacts.coco",
        "the COCO export is of the dataset's PNGs and labels: it needs the `enhance` stage",
    )?;
    check(
        !c.artifacts.astrometry || (c.stages.contains(&Stage::Detect) && c.artifacts.fits),
        "artifacts.astrometry",
        "the astrometry is of the detect stage's detections through each image's FITS WCS: it needs the `detect` stage and `artifacts.fits`",
    )?;
    for (on, field) in [
        (c.artifacts.obb_labels, "artifacts.obb_labels"),
        (c.artifacts.keypoint_labels, "artifacts.keypoint_labels"),
    ] {
        check(
            !on || c.stages.contains(&Stage::Enhance),
            field,
            "streak-shaped labels are of the PNGs: they need the `enhance` stage",
        )?;
    }
    let sp = &c.split;
    for (f, x) in [
        ("split.train", sp.train),
        ("split.val", sp.val),
        ("split.test", sp.test),
    ] {
        check(nonneg(x) && x <= 1.0, f, "must be in [0, 1]")?;
    }
    let sum = sp.train + sp.val + sp.test;
    check(
        (sum - 1.0).abs() < 1e-9,
        "split",
        &format!("train + val + test must sum to 1 (they sum to {sum})"),
    )?;
    // `train` is optional, between dataset and detect; the others form a prefix.
    let order = [
        Stage::Render,
        Stage::Enhance,
        Stage::Dataset,
        Stage::Train,
        Stage::Detect,
    ];
    let in_order = c.stages.windows(2).all(|w| {
        let pos = |s: &Stage| order.iter().position(|o| o == s);
        pos(&w[0]) < pos(&w[1])
    });
    let core: Vec<Stage> = c
        .stages
        .iter()
        .copied()
        .filter(|s| *s != Stage::Train)
        .collect();
    check(
        !c.stages.is_empty()
            && in_order
            && core
                .iter()
                .zip(order.iter().filter(|s| **s != Stage::Train))
                .all(|(a, b)| a == b)
            && (!training || core.contains(&Stage::Dataset)),
        "stages",
        "must be a prefix of [\"render\", \"enhance\", \"dataset\", \"train\", \"detect\"], `train` optional (each stage needs the ones before it)",
    )?;
    Ok(())
}
