//! The geometry every stage shares: a refined segment and the distances and angles between
//! segments.

/// Distance from a point to a segment (the detector's own, shared with the tests that judge it).
pub(super) use soig_image::imaging::point_segment_distance;

/// A point (x, y) in pixel-centre coordinates.
pub(super) type Point = (f64, f64);

/// A refined segment: centre, orientation (rad), length and measurements.
#[derive(Clone, Copy, Debug)]
pub(super) struct Seg {
    pub(super) cx: f64,
    pub(super) cy: f64,
    pub(super) theta: f64,
    pub(super) length: f64,
    pub(super) snr: f64,
    pub(super) flux: f64,
    pub(super) elongation: f64,
    /// Its profile was read as the contrast (kept when it is merged).
    pub(super) contrast: bool,
}

impl Seg {
    pub(super) fn dir(&self) -> (f64, f64) {
        (self.theta.cos(), self.theta.sin())
    }
    pub(super) fn ends(&self) -> ((f64, f64), (f64, f64)) {
        let (ux, uy) = self.dir();
        let hl = 0.5 * self.length;
        (
            (self.cx - hl * ux, self.cy - hl * uy),
            (self.cx + hl * ux, self.cy + hl * uy),
        )
    }
    /// Every field's bits: the same segment, whatever the stage that measured it.
    pub(super) fn bits(&self) -> [u64; 8] {
        let f = [
            self.cx,
            self.cy,
            self.theta,
            self.length,
            self.snr,
            self.flux,
        ];
        let [a, b, c, d, e, g] = f.map(f64::to_bits);
        [
            a,
            b,
            c,
            d,
            e,
            g,
            self.elongation.to_bits(),
            u64::from(self.contrast),
        ]
    }
    /// The axis points 1 px apart from the centre, whole steps only (the profile samples).
    pub(super) fn axis_points(&self) -> impl Iterator<Item = (f64, f64)> + use<> {
        let (ux, uy) = self.dir();
        let (cx, cy) = (self.cx, self.cy);
        let hl = 0.5 * self.length;
        let ta = (-hl + 0.5).ceil() as i64;
        let tb = (hl - 0.5).floor() as i64;
        (ta..=tb).map(move |t| (cx + t as f64 * ux, cy + t as f64 * uy))
    }
}

/// Absolute difference of two axis orientations in degrees, modulo 180 (result in [0, 90]).
pub(super) fn angle_diff_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(180.0);
    d.min(180.0 - d)
}
