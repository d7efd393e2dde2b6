//! Helpers shared by the unit tests of the orbit and frame modules: the TLE catalogue of the
//! shared data folder, instants given either way the reference scripts print them, and angles
//! between positions in arcseconds.

use hifitime::{Epoch, Unit};

use super::orbit::{Tle, parse_tles};
use super::{ARCSEC, Vec3, cross, dot, norm};

/// The repository's copy of the shared catalogue (campaigns/data/README.md).
pub fn catalog_text() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../campaigns/data/catalog-2022-01-22.tle"
    ))
    .expect("campaigns/data/catalog-2022-01-22.tle")
}

pub fn catalog() -> Vec<Tle> {
    parse_tles(&catalog_text()).expect("catalogue parses")
}

/// An instant of a reference table: minutes after an epoch, or a UTC date.
pub enum When {
    SinceEpoch(f64),
    Utc(i32, u8, u8, u8, u8, u8),
}

impl When {
    pub fn at(&self, epoch: Epoch) -> Epoch {
        match *self {
            When::SinceEpoch(m) => epoch + m * Unit::Minute,
            When::Utc(y, mo, d, h, mi, s) => Epoch::from_gregorian_utc_hms(y, mo, d, h, mi, s),
        }
    }
}

pub fn arcsec_between(a: Vec3, b: Vec3) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b)) / ARCSEC
}
