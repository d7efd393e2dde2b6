//! Resolution of a validated campaign: the window's instants, each object's propagator (a
//! `tle_file` replaced by the TLE lines it holds, so the hash covers the orbit, not a path),
//! objects that cannot propagate refused, frames, catalogue and model checked (the model's
//! sha256 recorded, so the hash pins it), and the survey drift bounded.

use std::path::Path;

use hifitime::Epoch;

use super::ground::{ground_gate, ground_of, no_debris_sites};
use super::{
    Background, Body, CampaignFile, GroundGate, ObjectSpec, Observer, PointingMode, Stars,
};
use crate::hash::sha256_file;
use crate::sky::orbit::{self, OrbitalElements, Propagator, Tle};

pub use crate::scene::MAX_SURVEY_DRIFT_DEG;

/// What a campaign resolves to besides its file: the bodies, the ground site and the window
/// the scenes are drawn from.
#[derive(Debug)]
pub struct World {
    pub observer: Observer,
    pub debris: Vec<Body>,
    /// The objects of `[population]` (empty without), the observer left out.
    pub population: Vec<Body>,
    /// A ground observer's site, night and the spans where each object can be seen.
    pub ground: Option<GroundGate>,
    pub window_start: Epoch,
    pub window_end: Epoch,
}

/// Resolve `file`, reading its files relative to `base_dir`: the file its hash covers, and
/// its world. Errors: (field path, message).
pub(super) fn resolve(
    file: &CampaignFile,
    base_dir: &Path,
) -> Result<(CampaignFile, World), (String, String)> {
    let window_start = parse_epoch(&file.window.start).map_err(|m| fail("window.start", m))?;
    let window_end = parse_epoch(&file.window.end).map_err(|m| fail("window.end", m))?;
    if window_end <= window_start {
        return Err(fail(
            "window.end",
            format!("must be after window.start ({})", file.window.start),
        ));
    }
    // Every frame of a collect starts inside the window (`judge_later_frames`): a collect
    // longer than the window could never be drawn.
    if let Some(k) = &file.collect {
        let span_s = (window_end - window_start).to_seconds();
        let collect_s = (k.frames.saturating_sub(1)) as f64 * (file.exposure.min_s + k.gap_s);
        if collect_s >= span_s {
            return Err(fail(
                "collect.gap_s",
                format!(
                    "{} frames {} s apart span {collect_s} s, beyond the window's {span_s} s: every frame must start inside the window",
                    k.frames,
                    file.exposure.min_s + k.gap_s
                ),
            ));
        }
    }

    let mut resolved = file.clone();
    let ground = ground_of(&file.observer).map_err(|(f, m)| fail(&format!("observer{f}"), m))?;
    let observer = match ground {
        Some(g) => Observer::Ground(g),
        None => Observer::Orbit(Box::new(
            resolve_object(&mut resolved.observer, base_dir, window_start)
                .map_err(|(f, m)| fail(&format!("observer{f}"), m))?,
        )),
    };
    no_debris_sites(file)?;
    let mut debris = Vec::new();
    for (i, spec) in resolved.debris.iter_mut().enumerate() {
        debris.push(
            resolve_object(spec, base_dir, window_start)
                .map_err(|(f, m)| fail(&format!("debris[{i}]{f}"), m))?,
        );
    }
    if !file.allow_duplicates {
        duplicates(&debris)?;
    }
    let orbit = observer.orbit();
    // The observer cannot observe itself: every draw would fail its geometry.
    if let Some(i) = orbit.and_then(|o| debris.iter().position(|d| d.norad == o.norad)) {
        return Err(fail(
            &format!("debris[{i}].norad"),
            format!(
                "NORAD {} is the observer itself: the debris must be other objects",
                orbit.map_or(0, |o| o.norad)
            ),
        ));
    }
    all_propagate(
        file,
        &resolved,
        base_dir,
        orbit,
        &debris,
        (window_start, window_end),
    )?;
    check_frames(&resolved, base_dir)?;
    pin_model(&mut resolved, base_dir)?;
    let population = match resolved.population.as_mut() {
        // A ground observer is refused with a population (`validate`): none to leave out.
        Some(p) => resolve_population(p, base_dir, observer.orbit().map(|o| o.norad), window_start)
            .map_err(|(f, m)| fail(&format!("population.{f}"), m))?,
        None => Vec::new(),
    };
    if let Stars::Catalog { path: p, .. } = &resolved.stars {
        let full = base_dir.join(p);
        if !full.is_file() {
            return Err(fail(
                "stars.path",
                format!("star catalogue {} does not exist", full.display()),
            ));
        }
    }
    if let Some(o) = orbit {
        survey_drift(&resolved, o, window_start)?;
    }

    let ground = ground_gate(&resolved, &observer, &debris, (window_start, window_end))?;

    let world = World {
        observer,
        debris,
        population,
        ground,
        window_start,
        window_end,
    };
    Ok((resolved, world))
}

/// The error of the campaign field `field`.
fn fail(field: &str, message: String) -> (String, String) {
    (field.to_string(), message)
}

/// An object SGP4 cannot propagate anywhere in the window (decayed before it opens, or
/// diverged) would fail every scene draw, ending in "no acceptable scene" after max_attempts
/// draws: refuse it here, naming its field and its TLE.
fn all_propagate(
    file: &CampaignFile,
    resolved: &CampaignFile,
    base_dir: &Path,
    orbit: Option<&Body>,
    debris: &[Body],
    (window_start, window_end): (Epoch, Epoch),
) -> Result<(), (String, String)> {
    let specs = orbit
        .map(|o| ("observer".to_string(), &file.observer, o))
        .into_iter()
        .chain(
            file.debris
                .iter()
                .zip(debris)
                .enumerate()
                .map(|(i, (spec, body))| (format!("debris[{i}]"), spec, body)),
        );
    for (field, spec, body) in specs {
        let problem = match check_propagates(body, window_start, window_end) {
            Err(e) => Some(format!(
                "{e}: the object cannot be propagated anywhere in the window {} .. {}",
                file.window.start, file.window.end
            )),
            Ok(()) => epoch_too_far(body, window_start, window_end),
        };
        if let Some(problem) = problem {
            let (suffix, source) = match (&spec.tle_file, &spec.tle, &spec.elements) {
                (Some(f), _, _) => {
                    let full = base_dir.join(f);
                    let line = std::fs::read_to_string(&full).ok().and_then(|t| {
                        let [l1, _] = resolved_tle(resolved, &field)?;
                        t.lines().position(|l| l.trim_end() == l1).map(|n| n + 1)
                    });
                    let at = line.map(|n| format!("line {n} of ")).unwrap_or_default();
                    (".tle_file", format!(" (the TLE at {at}{})", full.display()))
                }
                (_, Some(_), _) => (".tle", String::new()),
                _ => (".elements", String::new()),
            };
            return Err(fail(
                &format!("{field}{suffix}"),
                format!("{problem}{source}"),
            ));
        }
    }
    Ok(())
}

/// A semisynthetic campaign's frames: at least one, each a regular file, and a share in 0..=1.
fn check_frames(resolved: &CampaignFile, base_dir: &Path) -> Result<(), (String, String)> {
    if let Background::Frames { paths, share } = &resolved.background {
        if paths.is_empty() {
            return Err(fail("background.paths", "name at least one frame".into()));
        }
        if !(0.0..=1.0).contains(share) {
            return Err(fail(
                "background.share",
                format!("{share}: the share of images on a frame must be within 0..=1"),
            ));
        }
        for (i, p) in paths.iter().enumerate() {
            let full = base_dir.join(p);
            if let Err(why) = crate::input_file::regular(&full) {
                return Err(fail(
                    &format!("background.paths[{i}]"),
                    format!("background frame {}: {why}", full.display()),
                ));
            }
        }
    }
    Ok(())
}

/// A detector model must be a regular file; its sha256 is recorded (so the campaign's hash
/// pins it) and must match a given `model_sha256`.
fn pin_model(resolved: &mut CampaignFile, base_dir: &Path) -> Result<(), (String, String)> {
    if let Some(model) = &resolved.detect.model {
        let full = base_dir.join(model);
        crate::input_file::regular(&full)
            .map_err(|why| fail("detect.model", format!("model {}: {why}", full.display())))?;
        let sha = sha256_file(&full)
            .map_err(|e| {
                fail(
                    "detect.model",
                    format!("cannot read model {}: {e}", full.display()),
                )
            })?
            .0;
        if let Some(given) = &resolved.detect.model_sha256
            && *given != sha
        {
            return Err(fail(
                "detect.model_sha256",
                format!("is {given} but {} has sha256 {sha}", full.display()),
            ));
        }
        resolved.detect.model_sha256 = Some(sha);
    }
    Ok(())
}

/// The boresight of a survey turns at the observer's orbital rate: beyond a few degrees of
/// drift the star cone and the trails grow without bound, so refuse it up front.
fn survey_drift(
    resolved: &CampaignFile,
    o: &Body,
    window_start: Epoch,
) -> Result<(), (String, String)> {
    if resolved.pointing.mode != PointingMode::Survey {
        return Ok(());
    }
    let p = &o.propagator;
    let t1 = window_start + hifitime::Duration::from_seconds(1.0);
    if let (Ok(a), Ok(b)) = (p.position_teme_km(window_start), p.position_teme_km(t1)) {
        let drift = crate::sky::angle_deg(a, b) * resolved.exposure.max_s;
        if drift > MAX_SURVEY_DRIFT_DEG {
            return Err(fail(
                "exposure.max_s",
                format!(
                    "survey pointing would drift {drift:.1} deg in {} s (the observer turns {:.3} deg/s); \
                 at most {MAX_SURVEY_DRIFT_DEG} deg is supported: shorten the exposure",
                    resolved.exposure.max_s,
                    drift / resolved.exposure.max_s
                ),
            ));
        }
    }
    Ok(())
}

/// A placed object named twice (one NORAD number in two `debris` entries, by the same TLE or
/// not) is refused at its second entry, unless `allow_duplicates` asks for it.
fn duplicates(debris: &[Body]) -> Result<(), (String, String)> {
    let mut first = std::collections::BTreeMap::new();
    for (i, body) in debris.iter().enumerate() {
        if let Some(j) = first.insert(body.norad, i) {
            return Err((
                format!("debris[{i}].norad"),
                format!(
                    "NORAD {} is already debris[{j}]: each object once (set `allow_duplicates = true` to weight it twice on purpose)",
                    body.norad
                ),
            ));
        }
    }
    Ok(())
}

/// The bodies of a `[population]`, its sha256 recorded (the hash pins the population, which
/// may be a whole catalogue: its lines are not copied into the campaign). The observer is left
/// out (it cannot see itself); a NORAD number twice, or an orbit SGP4 refuses, is an error
/// naming the line. Errors: (field under `population`, message).
fn resolve_population(
    p: &mut super::Population,
    base_dir: &Path,
    observer: Option<u64>,
    window_start: Epoch,
) -> Result<Vec<Body>, (String, String)> {
    let fail = |m: String| ("tle_file".to_string(), m);
    let full = base_dir.join(&p.tle_file);
    let text = crate::input_file::read_text(&full)
        .map_err(|why| fail(format!("{}: {why}", full.display())))?;
    let sha = sha256_file(&full)
        .map_err(|e| fail(format!("cannot read {}: {e}", full.display())))?
        .0;
    if let Some(given) = &p.tle_sha256
        && *given != sha
    {
        return Err((
            "tle_sha256".into(),
            format!("is {given} but {} has sha256 {sha}", full.display()),
        ));
    }
    p.tle_sha256 = Some(sha);
    let tles = orbit::parse_tles(&text).map_err(|e| fail(format!("{}: {e}", full.display())))?;
    if tles.is_empty() {
        return Err(fail(format!("{} holds no TLE", full.display())));
    }
    let mut first_line = std::collections::BTreeMap::new();
    let mut bodies = Vec::with_capacity(tles.len());
    for tle in tles.iter().filter(|t| Some(t.norad_id) != observer) {
        if let Some(line) = first_line.insert(tle.norad_id, tle.line) {
            return Err(fail(format!(
                "NORAD {} at line {} of {} is already at line {line}: each object once",
                tle.norad_id,
                tle.line,
                full.display()
            )));
        }
        let propagator = Propagator::from_tle(tle).map_err(|e| {
            fail(format!(
                "{e} (the TLE at line {} of {})",
                tle.line,
                full.display()
            ))
        })?;
        bodies.push(Body {
            name: tle
                .name
                .clone()
                .unwrap_or_else(|| format!("NORAD {}", tle.norad_id)),
            norad: tle.norad_id,
            propagator,
            generated: None,
        });
    }
    if let Some(b) = &p.breakup {
        let field = |(f, m): (String, String)| (format!("breakup.{f}"), m);
        if b.parent.is_some() && b.parent == observer {
            return Err(field((
                "parent".into(),
                "the observer itself cannot break up in its own images".into(),
            )));
        }
        let taken = bodies.iter().map(|b| b.norad).collect();
        let file = full.display().to_string();
        let (cloud, destroyed) =
            super::breakup::fragments(b, (&tles, &file), &taken, window_start).map_err(field)?;
        // After an explosion or a catastrophic collision the parent is its fragments.
        bodies.retain(|b| Some(b.norad) != destroyed);
        bodies.extend(cloud);
    }
    Ok(bodies)
}

/// Parse a UTC instant such as `2022-01-01T00:00:00 UTC` or `2022-01-01T00:00:00Z`.
pub fn parse_epoch(s: &str) -> Result<Epoch, String> {
    let t = s.trim();
    let normalized = if let Some(stripped) = t.strip_suffix('Z') {
        format!("{stripped} UTC")
    } else if t.ends_with("UTC") {
        t.to_string()
    } else {
        return Err(format!(
            "`{s}` is not a UTC instant: write it like `2022-01-01T00:00:00 UTC` or `2022-01-01T00:00:00Z`"
        ));
    };
    normalized
        .parse::<Epoch>()
        .map_err(|e| format!("`{s}` is not a valid UTC instant ({e})"))
}

/// Turn an `ObjectSpec` into a body, replacing a `tle_file` by the TLE lines it holds (so the
/// campaign hash covers the orbit, not a path). Errors: (field suffix, message).
fn resolve_object(
    spec: &mut ObjectSpec,
    base_dir: &Path,
    default_epoch: Epoch,
) -> Result<Body, (String, String)> {
    let given = [
        spec.tle.is_some(),
        spec.tle_file.is_some(),
        spec.elements.is_some(),
    ]
    .iter()
    .filter(|&&b| b)
    .count();
    if given != 1 {
        return Err((
            String::new(),
            "give exactly one of `tle`, `tle_file` (with `norad`) or `elements`".into(),
        ));
    }
    if let Some(file) = spec.tle_file.take() {
        let norad = spec.norad.ok_or_else(|| {
            (
                ".norad".to_string(),
                "`tle_file` needs `norad` to pick the object".to_string(),
            )
        })?;
        let full = base_dir.join(&file);
        let text = crate::input_file::read_text(&full).map_err(|why| {
            (
                ".tle_file".to_string(),
                format!("{}: {why}", full.display()),
            )
        })?;
        let tles = orbit::parse_tles(&text)
            .map_err(|e| (".tle_file".to_string(), format!("{}: {e}", full.display())))?;
        let tle = tles
            .into_iter()
            .find(|t| t.norad_id == norad)
            .ok_or_else(|| {
                (
                    ".norad".to_string(),
                    format!("NORAD {norad} is not in {}", full.display()),
                )
            })?;
        // An orbit that cannot exist is refused here, where the file and its line are known.
        Propagator::from_tle(&tle).map_err(|e| {
            (
                ".tle_file".to_string(),
                format!("{e} (the TLE at line {} of {})", tle.line, full.display()),
            )
        })?;
        if spec.name.is_none() {
            spec.name = tle.name.clone();
        }
        spec.tle = Some([tle.line1.clone(), tle.line2.clone()]);
    }
    if let Some([l1, l2]) = &spec.tle {
        let text = format!("{l1}\n{l2}\n");
        let tle: Tle = orbit::parse_tles(&text)
            .map_err(|e| (".tle".to_string(), e.to_string()))?
            .into_iter()
            .next()
            .ok_or_else(|| (".tle".to_string(), "no TLE found".to_string()))?;
        if let Some(n) = spec.norad
            && n != tle.norad_id
        {
            return Err((
                ".norad".into(),
                format!("is {n} but the TLE is for NORAD {}", tle.norad_id),
            ));
        }
        spec.norad = Some(tle.norad_id);
        let propagator =
            Propagator::from_tle(&tle).map_err(|e| (".tle".to_string(), e.to_string()))?;
        let name = spec
            .name
            .clone()
            .unwrap_or_else(|| format!("NORAD {}", tle.norad_id));
        spec.name = Some(name.clone());
        return Ok(Body {
            name,
            norad: tle.norad_id,
            propagator,
            generated: None,
        });
    }
    let el = spec.elements.as_mut().expect("counted above");
    let norad = spec.norad.ok_or_else(|| {
        (
            ".norad".to_string(),
            "objects given by `elements` need a `norad` number".to_string(),
        )
    })?;
    let epoch = match &el.epoch {
        Some(s) => parse_epoch(s).map_err(|m| (".elements.epoch".to_string(), m))?,
        None => default_epoch,
    };
    el.epoch = Some(format!("{epoch}"));
    let elements = OrbitalElements {
        period_min: el.period_min,
        inclination_deg: el.inclination_deg,
        apogee_km: el.apogee_km,
        perigee_km: el.perigee_km,
        raan_deg: el.raan_deg,
        arg_perigee_deg: el.arg_perigee_deg,
        mean_anomaly_deg: el.mean_anomaly_deg,
        epoch,
    };
    let propagator = Propagator::from_elements(&elements, norad)
        .map_err(|e| (".elements".to_string(), e.to_string()))?;
    let name = spec
        .name
        .clone()
        .unwrap_or_else(|| format!("NORAD {norad}"));
    spec.name = Some(name.clone());
    Ok(Body {
        name,
        norad,
        propagator,
        generated: None,
    })
}

/// Instants at which `check_propagates` tries an object, evenly over the window.
const PROPAGATION_CHECKS: u32 = 65;

/// Farthest a window may reach from an orbit's epoch, days. SGP4's along-track error grows by
/// roughly a few km per day from a TLE's epoch: three years covers the paper's year-long window
/// with a TLE from inside it many times over, and refuses a 1900 or 2200 window with a 2022 TLE.
const MAX_DAYS_FROM_EPOCH: f64 = 3.0 * 365.25;

/// Why a body's orbit is too far from its epoch for the window, if it is.
fn epoch_too_far(body: &Body, start: Epoch, end: Epoch) -> Option<String> {
    let epoch = body.propagator.epoch();
    let days = (start - epoch)
        .to_seconds()
        .abs()
        .max((end - epoch).to_seconds().abs())
        / 86_400.0;
    (days > MAX_DAYS_FROM_EPOCH).then(|| {
        format!(
            "the window reaches {days:.0} days from the orbit's epoch {epoch} (at most {MAX_DAYS_FROM_EPOCH:.0}): use elements or a TLE of the window's time"
        )
    })
}

/// Ok if the body propagates at one of `PROPAGATION_CHECKS` instants of the window; else the
/// first failure (at the window start). An object that decays inside the window is kept:
/// draws after its decay are rejected as "propagation failed".
fn check_propagates(body: &Body, start: Epoch, end: Epoch) -> Result<(), orbit::OrbitError> {
    let span = (end - start).to_seconds();
    let mut first = None;
    for k in 0..PROPAGATION_CHECKS {
        let f = k as f64 / (PROPAGATION_CHECKS - 1) as f64;
        let t = start + hifitime::Duration::from_seconds(span * f);
        match body.propagator.position_teme_km(t) {
            Ok(_) => return Ok(()),
            Err(e) => {
                first.get_or_insert(e);
            }
        }
    }
    Err(first.expect("at least one check"))
}

/// The resolved TLE lines of `observer` or `debris[i]`.
fn resolved_tle<'a>(resolved: &'a CampaignFile, field: &str) -> Option<&'a [String; 2]> {
    let spec = match field.strip_prefix("debris[") {
        Some(rest) => resolved
            .debris
            .get(rest.trim_end_matches(']').parse::<usize>().ok()?)?,
        None => &resolved.observer,
    };
    spec.tle.as_ref()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epochs_parse() {
        assert!(parse_epoch("2022-01-01T00:00:00Z").is_ok());
        assert!(parse_epoch("2022-01-01T00:00:00 UTC").is_ok());
        assert!(parse_epoch("2022-01-01").is_err());
    }
}
