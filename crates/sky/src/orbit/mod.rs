//! Orbits: two/three-line element sets (TLEs) and SGP4/SDP4 propagation; the TEME -> GCRS
//! rotation that takes propagated positions to the sky is in [`crate::frames`].
//!
//! Propagation uses the `sgp4` crate in its AFSPC compatibility mode (WGS72 gravity, AFSPC sidereal
//! time and epoch expressions, AFSPC Lyddane branch): TLEs are fitted by the US Space Force with
//! that very model, so it is the one that reproduces them; it matches python-sgp4 with `WGS72` and
//! opsmode `'a'`. Times are UTC `hifitime::Epoch`s; minutes since the TLE epoch are taken as
//! hifitime differences, which count leap seconds (none fall between 2017 and 2023).
//!
//! The unit tests' reference figures were printed by `tests/reference/orbit_reference.py`
//! (python-sgp4 2.27 in WGS72 opsmode 'a', astropy 8.0.2 with its bundled IERS tables, pyerfa
//! 2.0.1.5). Measured: TEME positions agree with python-sgp4 to 2.5e-7 km at worst (40989,
//! resonant deep space, 343 days after its epoch; 40649: 1.2e-8 km).

mod coarse;
mod fit;
mod propagate;
mod tle;

use hifitime::Epoch;
use sgp4::chrono::{Datelike, Timelike};

pub use coarse::{CoarseOrbit, seconds as coarse_seconds};
pub use fit::{FIT_POSITION_KM, FIT_VELOCITY_KM_S};
pub use propagate::{MeanElements, OrbitError, OrbitalElements, Propagator, Regime};
pub use tle::{Tle, TleError, parse_tles};
// The frame rotation and its matrix helpers were first defined here; their paths still work.
pub use super::frames::{teme_to_gcrs, teme_to_gcrs_matrix};
pub use super::vec3::{Mat3, mat_vec};

/// UTC calendar time of the `sgp4` crate (chrono) to a hifitime UTC epoch.
fn chrono_to_epoch(dt: &sgp4::chrono::NaiveDateTime) -> Option<Epoch> {
    let (y, mo, d) = (
        dt.year(),
        u8::try_from(dt.month()).ok()?,
        u8::try_from(dt.day()).ok()?,
    );
    let (h, mi, s) = (dt.hour() as u8, dt.minute() as u8, dt.second() as u8);
    Epoch::maybe_from_gregorian_utc(y, mo, d, h, mi, s, dt.nanosecond()).ok()
}

/// hifitime UTC epoch to the calendar time the `sgp4` crate wants; `None` outside 1900..=2100
/// (the AFSPC epoch expression of the crate is only meant for TLE-era dates).
fn epoch_to_chrono(epoch: Epoch) -> Option<sgp4::chrono::NaiveDateTime> {
    let (y, mo, d, h, mi, s, ns) = epoch.to_gregorian_utc();
    if !(1900..=2100).contains(&y) {
        return None;
    }
    sgp4::chrono::NaiveDate::from_ymd_opt(y, mo.into(), d.into())?.and_hms_nano_opt(
        h.into(),
        mi.into(),
        s.into(),
        ns,
    )
}
