//! `[population.breakup]`: a generated breakup cloud added to a catalogue scene's population.
//! Its fragments are drawn by the NASA Standard Breakup Model (`crate::sky::breakup`, Johnson
//! et al. 2001), one random stream per fragment; each leaves its parent's SGP4 state at the
//! breakup epoch with its ejection velocity and is propagated by SGP4 from there (the mean
//! elements fitted to that state, `Propagator::from_state_teme`), so it is culled, judged and
//! rendered as a catalogued object, under a generated id.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::Body;
use super::resolve::parse_epoch;
use crate::rng::{Purpose, stream};
use crate::scene::Generated;
use crate::sky::breakup::{self, Event, ParentKind};
use crate::sky::orbit::{Propagator, Tle};

/// A breakup: its parent (`parent`, a NORAD number of `population.tle_file`, or
/// `parent_tle`), when (`epoch`; the window must open at or after it), what happened (`kind`:
/// `explosion`, with `scaling`; or `collision`, with `target_mass_kg`, `projectile_mass_kg`
/// and `impact_speed_km_s`), the parent's type, the smallest fragment and a seed. The
/// fragments' ids are the parent's NORAD number x 100000 + their index (1, 2, ...); their
/// names `<parent> fragment <index>`. A fragment on no closed orbit, or whose perigee lies
/// below the Earth's surface, is left out (its index is skipped). After an explosion or a
/// catastrophic collision the parent is no longer in the population.
#[derive(Clone, Debug, Serialize, Deserialize, JsonSchema, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Breakup {
    /// The parent: its NORAD number in `population.tle_file`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parent: Option<u64>,
    /// Or the parent's two TLE lines.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "super::file::two_tle_lines"
    )]
    #[schemars(with = "Option<[String; 2]>")]
    pub parent_tle: Option<[String; 2]>,
    /// UTC instant of the breakup, e.g. `2022-01-22T00:38:00 UTC`.
    pub epoch: String,
    pub kind: BreakupKind,
    /// `spacecraft` (default) or `rocket-body`: the area-to-mass law of large fragments.
    #[serde(default)]
    pub parent_type: ParentType,
    /// Explosion: the model's scaling factor S (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scaling: Option<f64>,
    /// Collision: the parent's mass, kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_mass_kg: Option<f64>,
    /// Collision: the projectile's mass, kg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub projectile_mass_kg: Option<f64>,
    /// Collision: the impact speed, km/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impact_speed_km_s: Option<f64>,
    /// The smallest fragment's characteristic length Lc, m (the model holds from 1 mm).
    pub lc_min_m: f64,
    /// Seed of the fragments' draws (fragment k draws on its own stream of it).
    #[serde(default)]
    pub seed: u64,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum BreakupKind {
    Explosion,
    Collision,
}

#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, JsonSchema, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ParentType {
    #[default]
    Spacecraft,
    RocketBody,
}

/// Most fragments of one breakup: ids are the parent's number x 100000 + index, and a cloud
/// of 100 000 would take minutes to fit before the first image.
pub const MAX_FRAGMENTS: u64 = 99_999;

/// Smallest fragment the model covers, m (Johnson et al.: 1 mm).
const LC_FLOOR_M: f64 = 0.001;

/// Drag coefficient of a fragment in SGP4's B* (the usual 2.2 of a tumbling plate).
const DRAG_COEFFICIENT: f64 = 2.2;
/// SGP4's reference density rho0 in B* = Cd (A/M) rho0 / 2, kg/m^2 per Earth radius
/// (Vallado, Fundamentals of Astrodynamics and Applications, 4th ed., sec. 9.7).
const RHO0: f64 = 0.156_966_15;

/// Error: (field under `population.breakup`, message).
type Refused = (String, String);

fn refuse(field: &str, message: String) -> Refused {
    (field.to_string(), message)
}

impl Breakup {
    /// The event, its fields checked.
    fn event(&self) -> Result<Event, Refused> {
        let positive = |field: &str, v: Option<f64>| -> Result<f64, Refused> {
            match v {
                Some(x) if x.is_finite() && x > 0.0 => Ok(x),
                Some(x) => Err(refuse(field, format!("{x}: must be a positive number"))),
                None => Err(refuse(field, "a collision needs it".into())),
            }
        };
        match self.kind {
            BreakupKind::Explosion => {
                for (f, v) in [
                    ("target_mass_kg", self.target_mass_kg),
                    ("projectile_mass_kg", self.projectile_mass_kg),
                    ("impact_speed_km_s", self.impact_speed_km_s),
                ] {
                    if v.is_some() {
                        return Err(refuse(
                            f,
                            "only a collision has it: drop it or set `kind = \"collision\"`".into(),
                        ));
                    }
                }
                let scaling = self.scaling.unwrap_or(1.0);
                if !(scaling.is_finite() && scaling > 0.0 && scaling <= 100.0) {
                    return Err(refuse("scaling", format!("{scaling}: must be in (0, 100]")));
                }
                Ok(Event::Explosion { scaling })
            }
            BreakupKind::Collision => {
                if self.scaling.is_some() {
                    return Err(refuse("scaling", "only an explosion has it".into()));
                }
                let speed = positive("impact_speed_km_s", self.impact_speed_km_s)?;
                if speed > 100.0 {
                    return Err(refuse(
                        "impact_speed_km_s",
                        format!("{speed} km/s: at most 100 (Earth-orbit impacts are under 20)"),
                    ));
                }
                Ok(Event::Collision {
                    target_kg: positive("target_mass_kg", self.target_mass_kg)?,
                    projectile_kg: positive("projectile_mass_kg", self.projectile_mass_kg)?,
                    speed_km_s: speed,
                })
            }
        }
    }
}

/// The parent's TLE: `parent` in the population's `tles`, or `parent_tle`.
fn parent_tle(b: &Breakup, tles: &[Tle], file: &str) -> Result<Tle, Refused> {
    match (&b.parent, &b.parent_tle) {
        (Some(n), None) => tles.iter().find(|t| t.norad_id == *n).cloned().ok_or_else(|| {
            refuse("parent", format!("NORAD {n} is not in {file}: name an object of the population's TLE file, or give `parent_tle`"))
        }),
        (None, Some([l1, l2])) => crate::sky::orbit::parse_tles(&format!("{l1}\n{l2}\n"))
            .map_err(|e| refuse("parent_tle", e.to_string()))?
            .into_iter()
            .next()
            .ok_or_else(|| refuse("parent_tle", "no TLE found".into())),
        _ => Err(refuse("parent", "give exactly one of `parent` (a NORAD number of the population's TLE file) or `parent_tle`".into())),
    }
}

/// The bodies of the cloud, in fragment order, and whether the parent is destroyed. `tles`
/// are the population file's (`file` names it), `taken` the ids already in the population,
/// `window_start` the window's opening. Errors name a field under `population.breakup`.
pub(super) fn fragments(
    b: &Breakup,
    (tles, file): (&[Tle], &str),
    taken: &std::collections::BTreeSet<u64>,
    window_start: hifitime::Epoch,
) -> Result<(Vec<Body>, Option<u64>), Refused> {
    let event = b.event()?;
    let epoch = parse_epoch(&b.epoch).map_err(|m| refuse("epoch", m))?;
    if window_start < epoch {
        return Err(refuse(
            "epoch",
            format!(
                "{epoch} is after the window opens ({window_start}): fragments exist only after their breakup"
            ),
        ));
    }
    if !(b.lc_min_m.is_finite() && b.lc_min_m >= LC_FLOOR_M) {
        return Err(refuse(
            "lc_min_m",
            format!(
                "{}: must be at least {LC_FLOOR_M} m, the model's smallest fragment",
                b.lc_min_m
            ),
        ));
    }
    let n = event.count_above(b.lc_min_m).round();
    if n > MAX_FRAGMENTS as f64 {
        return Err(refuse(
            "lc_min_m",
            format!(
                "{} m gives N(>Lc) = {n} fragments, more than {MAX_FRAGMENTS}: raise it",
                b.lc_min_m
            ),
        ));
    }
    let tle = parent_tle(b, tles, file)?;
    let field = if b.parent.is_some() {
        "parent"
    } else {
        "parent_tle"
    };
    let parent = Propagator::from_tle(&tle).map_err(|e| refuse(field, e.to_string()))?;
    let (r, v) = parent.state_teme(epoch).map_err(|e| {
        refuse(
            "epoch",
            format!("the parent cannot be propagated to the breakup: {e}"),
        )
    })?;
    let kind = match b.parent_type {
        ParentType::Spacecraft => ParentKind::Spacecraft,
        ParentType::RocketBody => ParentKind::RocketBody,
    };
    let name = tle
        .name
        .clone()
        .unwrap_or_else(|| format!("NORAD {}", tle.norad_id));
    let mut bodies = Vec::new();
    for k in 0..n as u64 {
        let id = tle.norad_id * (MAX_FRAGMENTS + 1) + k + 1;
        if taken.contains(&id) {
            return Err(refuse(
                field,
                format!(
                    "fragment id {id} is already a NORAD number of the population: a parent of another number"
                ),
            ));
        }
        let f = breakup::draw(
            &event,
            kind,
            b.lc_min_m,
            &mut stream(b.seed, k, Purpose::BreakupFragment),
        );
        let kick = f.dv_m_s.map(|x| x / 1e3);
        let state = (r, [v[0] + kick[0], v[1] + kick[1], v[2] + kick[2]]);
        let bstar = 0.5 * DRAG_COEFFICIENT * f.area_to_mass * RHO0;
        // Escaping, re-entering or unfittable: not in orbit to be seen.
        if let Ok(propagator) = Propagator::from_state_teme(id, epoch, state, bstar) {
            bodies.push(Body {
                name: format!("{name} fragment {}", k + 1),
                norad: id,
                propagator,
                generated: Some(Generated { area_m2: f.area_m2 }),
            });
        }
    }
    Ok((bodies, event.catastrophic().then_some(tle.norad_id)))
}
