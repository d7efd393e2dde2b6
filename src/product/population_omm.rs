//! A generated population's orbits (a breakup cloud's fragments, `[population.breakup]`) as
//! the run's `population/generated.omm.json`: each fragment's catalogue entry, the SGP4 mean
//! elements soig fitted to its state at the breakup (`Propagator::from_state_teme`) and
//! propagates, so that another SGP4 (python-sgp4, tests/reference/breakup_sky_reference.py)
//! can put it on the sky. A catalogue's own objects are in its TLE file already: not repeated.
//!
//! The format: a JSON array of CCSDS Orbit Mean-elements Messages (CCSDS 502.0-B-3) with the
//! keyword names CelesTrak's GP JSON uses (`OBJECT_NAME`, `OBJECT_ID`, `EPOCH`, `MEAN_MOTION`
//! rev/day, `ECCENTRICITY`, `INCLINATION`, `RA_OF_ASC_NODE`, `ARG_OF_PERICENTER`,
//! `MEAN_ANOMALY` degrees, `EPHEMERIS_TYPE` 0, `CLASSIFICATION_TYPE`, `NORAD_CAT_ID`,
//! `ELEMENT_SET_NO`, `REV_AT_EPOCH`, `BSTAR` 1/Earth radii, `MEAN_MOTION_DOT`,
//! `MEAN_MOTION_DDOT`), read by python-sgp4's `omm` module and the sgp4 crate alike. The
//! numbers are full double precision (a TLE's four decimals of a degree would be 0.4" at GEO
//! range); `EPOCH` UTC to the microsecond. `OBJECT_ID` is empty (no COSPAR designator);
//! `NORAD_CAT_ID` is the generated id, which no NORAD number can be (over nine digits).

use std::path::Path;

use serde::Serialize;

use crate::scene::Body;
use crate::store::fs;

/// The file, inside the run's folder.
pub const FILE: &str = "population/generated.omm.json";

#[derive(Serialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
struct Omm<'a> {
    object_name: &'a str,
    object_id: &'a str,
    epoch: String,
    mean_motion: f64,
    eccentricity: f64,
    inclination: f64,
    ra_of_asc_node: f64,
    arg_of_pericenter: f64,
    mean_anomaly: f64,
    ephemeris_type: u8,
    classification_type: &'a str,
    norad_cat_id: u64,
    element_set_no: u64,
    rev_at_epoch: u64,
    bstar: f64,
    mean_motion_dot: f64,
    mean_motion_ddot: f64,
}

/// The OMM JSON of the generated bodies of `population`; None when it has none.
pub fn json(population: &[Body]) -> anyhow::Result<Option<String>> {
    let omm: Vec<Omm> = population
        .iter()
        .filter(|b| b.generated.is_some())
        .map(|b| {
            let p = &b.propagator;
            let e = p.mean_elements();
            Omm {
                object_name: &b.name,
                object_id: "",
                epoch: crate::render::iso_utc(p.epoch()),
                mean_motion: e.mean_motion_rev_day,
                eccentricity: e.eccentricity,
                inclination: e.inclination_deg,
                ra_of_asc_node: e.raan_deg,
                arg_of_pericenter: e.arg_perigee_deg,
                mean_anomaly: e.mean_anomaly_deg,
                ephemeris_type: 0,
                classification_type: "U",
                norad_cat_id: b.norad,
                element_set_no: 0,
                rev_at_epoch: 0,
                bstar: p.mean_drag_term(),
                mean_motion_dot: e.mean_motion_dot,
                mean_motion_ddot: e.mean_motion_ddot,
            }
        })
        .collect();
    if omm.is_empty() {
        return Ok(None);
    }
    Ok(Some(serde_json::to_string_pretty(&omm)? + "\n"))
}

/// Write [`FILE`] into run folder `dir` when `population` has generated bodies.
pub fn write(dir: &Path, population: &[Body]) -> anyhow::Result<()> {
    if let Some(text) = json(population)? {
        let path = dir.join(FILE);
        if let Some(parent) = path.parent() {
            fs::create_dir_all(parent)?;
        }
        fs::create(&path, text)?;
    }
    Ok(())
}
