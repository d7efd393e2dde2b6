//! The writer: one image's products as files. The noisy FITS (float32 ADU) and the
//! noise-free one (int32 electrons), both with the WCS and provenance keywords; the truth
//! sidecar and the star list; the PNG and its YOLO label in the dataset layout.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;

use crate::campaign::Artifacts;
use crate::dataset::Subset;
use crate::enhance;
use crate::fits::{self, Card, Cards, Pixels};
use crate::render::iso_utc;
use crate::render::{Exposure, Truth};
use crate::scene::{Pointing, Scene};
use crate::sensor::Sensor;
use crate::simulate::ImageProducts;
use crate::store;

/// What the FITS headers say of the run that made them.
pub struct Provenance {
    pub campaign: String,
    pub campaign_hash: String,
    pub seed: u64,
    pub observer: String,
    /// A ground observer's site (its FITS keywords, `site_cards`); None for a satellite.
    pub site: Option<crate::sky::site::Site>,
}

impl Provenance {
    /// What the files of `campaign`'s images say of where they come from (the run's `Plan` and
    /// Python's `Campaign.image` both take it from here).
    pub fn of(campaign: &crate::campaign::Campaign) -> Provenance {
        Provenance {
            campaign: campaign.resolved.name.clone(),
            campaign_hash: campaign.hash.clone(),
            seed: campaign.resolved.seed,
            observer: campaign.world.observer.name().to_string(),
            site: campaign.world.observer.ground().map(|g| g.site),
        }
    }
}

/// File stem of image i.
pub fn stem(i: u64) -> String {
    format!("img_{i:06}")
}

/// Where an image's PNG went: its path, size and label box in pixel-edge coordinates.
pub struct WrittenPng {
    pub path: PathBuf,
    pub width: usize,
    pub height: usize,
    /// One box per object with a label (none for an empty image).
    pub labels: Vec<[f64; 4]>,
    /// PNG encoding and writing time, seconds.
    pub seconds: f64,
}

/// What an image wrote: its files (paths relative to the output, '/' separated) and its PNG.
pub struct WrittenImage {
    pub files: Vec<String>,
    pub png: Option<WrittenPng>,
}

/// Write the files of image `index` into `dir` (the PNG and label into `subset`'s folders
/// when there is a split).
pub fn write_image(
    dir: &Path,
    index: u64,
    products: &ImageProducts,
    subset: Option<Subset>,
    artifacts: &Artifacts,
    provenance: &Provenance,
    sensor: &Sensor,
) -> anyhow::Result<WrittenImage> {
    let stem = stem(index);
    let mut files = Vec::new();
    let exposure = &products.exposure;
    let (w, h) = (exposure.width, exposure.height);
    let cards = provenance_cards(provenance, sensor, &products.scene, exposure);
    // Both FITS carry the same keywords but their unit.
    let mut write_fits = |file: String, pixels: Pixels, unit: &str, comment: &str| {
        let mut cards = cards.clone();
        cards.push(("BUNIT".into(), Card::Str(unit.into()), comment.into()));
        let path = dir.join("fits").join(&file);
        files.push(format!("fits/{file}"));
        fits::write_image(&path, w, h, pixels, &cards)
            .with_context(|| format!("writing {}", path.display()))
    };
    if artifacts.fits {
        write_fits(
            format!("{stem}.fits"),
            Pixels::F32(&exposure.adu),
            "adu",
            "Eq. 11: e-/gain + background + bias",
        )?;
    }
    if artifacts.noise_free_fits {
        let e = crate::product::records::clean_counts(exposure);
        write_fits(
            format!("{stem}_clean.fits"),
            Pixels::I32(&e),
            // The FITS standard has no electron unit; astropy reads `count` as `ct`.
            "count",
            "noise-free photo-electron counts",
        )?;
    }
    if artifacts.star_list {
        files.push(format!("truth/{stem}_stars.csv"));
        let path = dir.join("truth").join(format!("{stem}_stars.csv"));
        let mut w = csv::Writer::from_writer(Vec::new());
        for s in &exposure.stars {
            w.serialize(s)?;
        }
        store::fs::create(&path, w.into_inner().map_err(|e| e.into_error())?)?;
    }
    if artifacts.light_curve {
        files.push(format!("truth/{stem}_light_curve.csv"));
        let path = dir.join("truth").join(format!("{stem}_light_curve.csv"));
        store::fs::create(&path, crate::light_curve::csv(&products.scene.shown())?)?;
    }
    let truth_path = dir.join("truth").join(format!("{stem}.json"));
    let truth = serde_json::to_string_pretty(&crate::product::records::truth(products))?;
    store::fs::create(&truth_path, truth + "\n")?;

    files.push(format!("truth/{stem}.json"));
    let Some(product) = &products.product else {
        return Ok(WrittenImage { files, png: None });
    };
    let started = Instant::now();
    let frame = &product.frame;
    let label_line = crate::product::records::label_text(product);
    let (png_rel, label_rel) = dataset_paths(index, subset);
    let png_path = dir.join(&png_rel);
    store::fs::create(&png_path, enhance::png_bytes(&product.png))?;
    store::fs::create(&dir.join(&label_rel), label_line)?;
    crate::streak_labels::write(
        dir, index, subset, products, artifacts, &png_rel, &mut files,
    )?;
    files.extend([png_rel, label_rel]);
    let edges = crate::product::records::label_edges(product);
    Ok(WrittenImage {
        files,
        png: Some(WrittenPng {
            path: png_path,
            width: frame.width,
            height: frame.height,
            labels: edges,
            seconds: started.elapsed().as_secs_f64(),
        }),
    })
}

/// The files `write_image` writes for image `index` (`png`: whether it has a PNG and label).
pub fn expected_files(
    index: u64,
    subset: Option<Subset>,
    artifacts: &Artifacts,
    png: bool,
) -> std::collections::BTreeSet<String> {
    let stem = stem(index);
    let mut files = std::collections::BTreeSet::new();
    if artifacts.fits {
        files.insert(format!("fits/{stem}.fits"));
    }
    if artifacts.noise_free_fits {
        files.insert(format!("fits/{stem}_clean.fits"));
    }
    if artifacts.star_list {
        files.insert(format!("truth/{stem}_stars.csv"));
    }
    if artifacts.light_curve {
        files.insert(format!("truth/{stem}_light_curve.csv"));
    }
    files.insert(format!("truth/{stem}.json"));
    if png {
        let (p, l) = dataset_paths(index, subset);
        files.insert(p);
        files.insert(l);
        for set in crate::streak_labels::sets(artifacts) {
            let (p, l) = crate::streak_labels::paths(set, index, subset);
            files.insert(p);
            files.insert(l);
        }
    }
    files
}

/// The PNG and label of image `index`, relative to the output: in `subset`'s folders when
/// there is a split.
pub fn dataset_paths(index: u64, subset: Option<Subset>) -> (String, String) {
    let stem = stem(index);
    match subset {
        Some(s) => (
            format!("images/{}/{stem}.png", s.name()),
            format!("labels/{}/{stem}.txt", s.name()),
        ),
        None => (format!("images/{stem}.png"), format!("labels/{stem}.txt")),
    }
}

/// WCS and provenance keywords of an image (both of its FITS carry them, with their BUNIT).
pub fn provenance_cards(
    p: &Provenance,
    sensor: &Sensor,
    scene: &Scene,
    exposure: &Exposure,
) -> Cards {
    let t = &exposure.truth;
    let [jx, jy] = t.jitter_mean_px;
    let mut cards = fits::wcs_cards(&scene.projection(sensor).shifted(jx, jy));
    let mut push =
        |k: &str, v: Card, comment: &str| cards.push((k.to_string(), v, comment.to_string()));
    identity_cards(&mut push, p, scene);
    objects_cards(&mut push, scene, t);
    observation_cards(&mut push, p, scene, t);
    pointing_cards(&mut push, sensor, scene);
    collect_cards(&mut push, scene, t);
    frame_cards(&mut push, t);
    photometry_cards(&mut push, sensor, scene, t);
    // A moving camera's WCS at the exposure's start and end (alternates S and E), so that a
    // reader of the FITS alone can place the stars over the exposure (`soig detect --catalog`).
    cards.extend(crate::fits::cards_of(crate::sky::motion::cards(
        &scene.exposure.pointing,
        &scene.projection(sensor).shifted(jx, jy),
        scene.exposure.exposure_s,
    )));
    cards
}

/// Adds one card: keyword, value, comment.
type Push<'a> = dyn FnMut(&str, Card, &str) + 'a;

/// The image's origin: soig, its version, the campaign, seed and image index.
fn identity_cards(push: &mut Push, p: &Provenance, scene: &Scene) {
    push(
        "ORIGIN",
        Card::Str("soig".into()),
        "space optical image generator",
    );
    push(
        "SOIGVER",
        Card::Str(env!("CARGO_PKG_VERSION").into()),
        "soig version",
    );
    push("CAMPAIGN", Card::Str(p.campaign.clone()), "campaign name");
    push(
        "CAMPHASH",
        Card::Str(p.campaign_hash.clone()),
        "sha256 of the resolved campaign",
    );
    push("SEED", Card::Int(p.seed as i64), "campaign seed");
    push(
        "IMGINDEX",
        Card::Int(scene.exposure.image_index as i64),
        "image index in the campaign",
    );
}

/// The debris in the field: one object by name and NORAD number, or the placed objects.
fn objects_cards(push: &mut Push, scene: &Scene, t: &Truth) {
    match &scene.placed {
        None => {
            push("OBJECT", Card::Str(t.object.clone()), "debris in the field");
            push(
                "NORAD",
                Card::Int(t.norad as i64),
                "NORAD catalogue number of the debris",
            );
        }
        Some(placed) => {
            let names: Vec<&str> = placed
                .iter()
                .map(|s| s.object.debris_name.as_str())
                .collect();
            // A FITS string holds 68 characters.
            let object = match names.join(", ") {
                n if n.is_empty() => "none".to_string(),
                n if n.len() > 60 => format!("{} objects", names.len()),
                n => n,
            };
            push(
                "OBJECT",
                Card::Str(object),
                "debris in the field (truth: objects)",
            );
            push(
                "NOBJECTS",
                Card::Int(placed.len() as i64),
                "debris objects in the field",
            );
        }
    }
}

/// Who observed when: the observer, the exposure's times and the observer's state.
fn observation_cards(push: &mut Push, p: &Provenance, scene: &Scene, t: &Truth) {
    let (telescope, observer) = match p.site {
        None => (
            "satellite carrying the simulated telescope",
            "observing satellite",
        ),
        Some(_) => ("ground telescope's site", "observing site"),
    };
    push("TELESCOP", Card::Str(p.observer.clone()), telescope);
    push(
        "INSTRUME",
        Card::Str("soig simulated imager".into()),
        "sensor of the campaign's [sensor] table",
    );
    push("OBSERVER", Card::Str(p.observer.clone()), observer);
    if let Some(site) = &p.site {
        for (k, v, c) in crate::product::site_cards::site_cards(site, scene) {
            push(&k, v, &c);
        }
    }
    push(
        "DATE-OBS",
        Card::Str(t.start_utc.clone()),
        "UTC start of exposure",
    );
    push("TIMESYS", Card::Str("UTC".into()), "");
    push(
        "MJD-OBS",
        Card::Real(scene.exposure.start.to_mjd_utc_days()),
        "[d] UTC start of exposure",
    );
    // Mid-exposure and end: seconds after the start, and what each is.
    let instants = [
        ("AVG", t.exposure_s / 2.0, "UTC mid-exposure"),
        ("END", t.exposure_s, "UTC end of exposure"),
    ];
    let after = |s: f64| scene.exposure.start + hifitime::Duration::from_seconds(s);
    for (k, s, what) in instants {
        push(&format!("DATE-{k}"), Card::Str(iso_utc(after(s))), what);
    }
    // wcslib derives MJD-* from DATE-* when they are missing (astropy warns): both written.
    for (k, s, what) in instants {
        let mjd = Card::Real(after(s).to_mjd_utc_days());
        push(&format!("MJD-{k}"), mjd, &format!("[d] {what}"));
    }
    push("EXPTIME", Card::Real(t.exposure_s), "[s] exposure time");
    // The observer's state as the truth gives it: no FITS standard keyword holds a
    // spacecraft's GCRS state (OBSGEO-* are Earth-fixed).
    // A catalogue stare has no object of its own: the scene states the observer's.
    let observer = t
        .ephemeris
        .map(|e| (e.observer_gcrs_km, e.observer_gcrs_km_s))
        .or(scene.observer_gcrs);
    if let Some((position, velocity)) = observer {
        for (axis, v) in ["X", "Y", "Z"].iter().zip(position) {
            push(
                &format!("OBSPOS-{axis}"),
                Card::Real(v),
                "[km] observer GCRS position at DATE-AVG",
            );
        }
        for (axis, v) in ["X", "Y", "Z"].iter().zip(velocity) {
            push(
                &format!("OBSVEL-{axis}"),
                Card::Real(v),
                "[km/s] observer GCRS velocity at DATE-AVG",
            );
        }
    }
}

/// The gain and where the sensor pointed.
fn pointing_cards(push: &mut Push, sensor: &Sensor, scene: &Scene) {
    push("GAIN", Card::Real(sensor.gain_e_per_adu), "[e-/ADU]");
    // A moving pointing: its name, what it does, its star trails' direction and its drift.
    let (mode, how, angle_deg, angle_note, drift_deg, drift_note) = match &scene.exposure.pointing {
        Pointing::Fixed { .. } => {
            push("POINTING", Card::Str("fixed".into()), "fixed or survey");
            return;
        }
        Pointing::Track(track) => (
            "track",
            "follows the debris; WCS at mid-exposure",
            track.trail_angle_deg,
            "[deg] star-trail direction from +x to +y",
            track.drift_deg,
            "[deg] boresight path over the exposure",
        ),
        Pointing::Survey(track) => (
            "survey",
            "fixed or survey; WCS at mid-exposure",
            track.trail_angle_deg,
            "[deg] star-trail direction from +x to +y (Eq. 13)",
            track.drift_deg,
            "[deg] boresight drift over the exposure",
        ),
    };
    push("POINTING", Card::Str(mode.into()), how);
    push("DRIFTANG", Card::Real(angle_deg), angle_note);
    push("DRIFT", Card::Real(drift_deg), drift_note);
}

/// A collect's frame and track.
fn collect_cards(push: &mut Push, scene: &Scene, t: &Truth) {
    if let Some(k) = &t.collect {
        push(
            "COLLECT",
            Card::Int(k.collect as i64),
            "multi-frame collect of this image",
        );
        push(
            "CFRAME",
            Card::Int(k.frame as i64),
            "0-based frame in the collect",
        );
        push(
            "CFRAMES",
            Card::Int(k.frames as i64),
            "frames in the collect",
        );
        // With [objects] each object has its own track id (in the truth), not the pointing's.
        if scene.placed.is_none() {
            push(
                "TRACKID",
                Card::Int(k.track_id as i64),
                "object id across the collect",
            );
        }
    }
}

/// The PNG's frame and its transform from the FITS pixels.
fn frame_cards(push: &mut Push, t: &Truth) {
    if let Some(f) = &t.frame {
        push(
            "GEOMETRY",
            Card::Str(f.kind.name().into()),
            "frame of the PNG and its label",
        );
        push(
            "GEOANGLE",
            Card::Real(f.angle_deg),
            "[deg] rotation undone in the PNG",
        );
        push("GEONAX1", Card::Int(f.width as i64), "PNG width");
        push("GEONAX2", Card::Int(f.height as i64), "PNG height");
        for (r, row) in f.matrix.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                push(
                    &format!("GEOA{}{}", r + 1, k + 1),
                    Card::Real(*v),
                    "PNG pixel = A (x, y, 1), 0-based",
                );
            }
        }
    }
}

/// The photometric zero point and the debris' magnitude.
fn photometry_cards(push: &mut Push, sensor: &Sensor, scene: &Scene, t: &Truth) {
    push(
        "MAGZERO",
        Card::Real(sensor.zero_point_mag),
        "magnitude of 1 e-/s",
    );
    if scene.placed.is_none() {
        push(
            "DEBMAG",
            Card::Real(t.seen.magnitude),
            "debris magnitude at mid-exposure (Eq. 6)",
        );
    }
}
