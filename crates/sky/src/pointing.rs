//! Where the sensor points over an exposure: fixed, the survey's turn with the observer's
//! orbit, or a track that follows one object. Each variant carries only what its mode needs.

use serde::Serialize;

use super::{Turn, Vec3, angle_deg, cross, dot, norm, radec_deg, radec_unit, rotate, scale, unit};

/// Where the sensor points. Fixed pointing carries only its direction; survey pointing carries
/// the attitude track, so fixed scenes never build one.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum Pointing {
    Fixed { ra_deg: f64, dec_deg: f64 },
    Survey(SurveyTrack),
    Track(TargetTrack),
}

impl Pointing {
    /// Boresight at mid-exposure: the centre of the FITS WCS.
    pub fn mid_radec_deg(&self) -> (f64, f64) {
        match self {
            Pointing::Fixed { ra_deg, dec_deg } => (*ra_deg, *dec_deg),
            Pointing::Survey(t) => (t.mid_ra_deg, t.mid_dec_deg),
            Pointing::Track(t) => (t.mid_ra_deg, t.mid_dec_deg),
        }
    }

    /// Direction in which stars move in the image, degrees from +x towards +y (None when they
    /// stand still).
    pub fn trail_angle_deg(&self) -> Option<f64> {
        match self {
            Pointing::Fixed { .. } => None,
            Pointing::Survey(t) => Some(t.trail_angle_deg),
            Pointing::Track(t) => Some(t.trail_angle_deg),
        }
    }
}

/// Survey pointing (paper 3.2.1): the sensor is fixed on the observer, whose attitude is nadir
/// pointing, so the camera is fixed in the observer's local-vertical frame and turns with it,
/// as a rigid body, about the orbit normal at the orbital rate. At mid-exposure the image axes
/// are along RA and Dec (the FITS WCS); at other times they turn with the camera (the paper
/// keeps them along the local RA/Dec, which bends trails near the poles). The motion is
/// analytic, so every photon gets the exact pointing of its arrival time (the paper
/// interpolates a spline through sampled pointings).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SurveyTrack {
    /// Boresight at mid-exposure.
    pub mid_ra_deg: f64,
    pub mid_dec_deg: f64,
    /// Orbit normal of the observer (GCRS unit vector) and the turn rate about it.
    pub axis: Vec3,
    pub rate_deg_s: f64,
    /// Seconds from the start of the exposure to mid-exposure.
    pub t_mid_s: f64,
    /// Total boresight drift over the exposure, degrees.
    pub drift_deg: f64,
    /// Direction in which stars move in the image, degrees from +x towards +y: the paper's
    /// Eq. 13 with atan2 (opposite to the boresight drift). Every star trail is parallel to it.
    pub trail_angle_deg: f64,
}

impl SurveyTrack {
    fn angle_rad(&self, t_s: f64) -> f64 {
        (self.rate_deg_s * (t_s - self.t_mid_s)).to_radians()
    }

    /// Boresight (RA, Dec) at `t_s` seconds after the start of the exposure.
    pub fn radec_at(&self, t_s: f64) -> (f64, f64) {
        let b = radec_unit(self.mid_ra_deg, self.mid_dec_deg);
        radec_deg(rotate(b, self.axis, self.angle_rad(t_s)))
    }

    /// The sky direction that the camera at `t_s` sees where the mid-exposure camera sees
    /// (ra, dec): the camera turned by R(t), so a star s appears at R(t)^-1 s of the mid frame.
    pub fn to_mid_frame(&self, t_s: f64, ra_deg: f64, dec_deg: f64) -> (f64, f64) {
        radec_deg(self.turn_back(t_s).apply(radec_unit(ra_deg, dec_deg)))
    }

    /// The turn that carries a star's direction at `t_s` into the mid-exposure frame
    /// (`to_mid_frame` is it, applied), for turning many stars at one time.
    pub fn turn_back(&self, t_s: f64) -> Turn {
        Turn::new(self.axis, -self.angle_rad(t_s))
    }
}

/// Track pointing: the sensor rate-tracks the image's debris object. At each instant the camera
/// is the mid-exposure camera turned by the smallest rotation that carries the debris'
/// mid-exposure direction onto its direction then (no roll about the line of sight), so the
/// object stays on the pixel where it was placed and the stars move against its apparent
/// motion. The debris directions are kept at nodes close enough (the scene's `TRACK_NODE_SPACING_PX`)
/// that normalised linear interpolation between them is exact to well under 0.01 px; the
/// truth records the boresight at the start, middle and end, the nodes stay in memory.
#[derive(Clone, Debug, Serialize)]
pub struct TargetTrack {
    /// Boresight at mid-exposure (the FITS WCS) and at the start and end of the exposure.
    pub mid_ra_deg: f64,
    pub mid_dec_deg: f64,
    pub boresight_radec_start_deg: [f64; 2],
    pub boresight_radec_end_deg: [f64; 2],
    /// Seconds from the start of the exposure to mid-exposure.
    pub t_mid_s: f64,
    /// Angle the boresight turns through over the exposure (its path, not the chord), degrees.
    pub drift_deg: f64,
    /// Direction in which a star at the image centre moves, degrees from +x towards +y: from
    /// its places at the start and end of the exposure, as survey pointing defines it.
    pub trail_angle_deg: f64,
    /// Largest angle between the debris' mid-exposure direction and its direction at any
    /// node: how far the boresight strays from its mid-exposure place (the star cone's reach).
    #[serde(skip)]
    reach_deg: f64,
    /// The debris' unit direction at mid-exposure and at nodes `step_s` apart from the start.
    #[serde(skip)]
    debris_mid: Vec3,
    #[serde(skip)]
    step_s: f64,
    #[serde(skip)]
    nodes: Vec<Vec3>,
}

impl TargetTrack {
    /// The track through the debris' unit directions `nodes`, `step_s` apart from the start of
    /// an exposure of `exposure_s` (`debris_mid` at mid-exposure), with the boresight
    /// `(ra, dec)` at mid-exposure; its trail angle is the caller's to set (it needs the sensor).
    pub fn new(
        boresight: (f64, f64),
        exposure_s: f64,
        debris_mid: Vec3,
        step_s: f64,
        nodes: Vec<Vec3>,
    ) -> TargetTrack {
        let drift_deg = nodes.windows(2).map(|w| angle_deg(w[0], w[1])).sum();
        let reach_deg = nodes
            .iter()
            .map(|&n| angle_deg(debris_mid, n))
            .fold(0.0, f64::max);
        let mut track = TargetTrack {
            mid_ra_deg: boresight.0,
            mid_dec_deg: boresight.1,
            boresight_radec_start_deg: [0.0; 2],
            boresight_radec_end_deg: [0.0; 2],
            t_mid_s: exposure_s / 2.0,
            drift_deg,
            trail_angle_deg: 0.0,
            reach_deg,
            debris_mid,
            step_s,
            nodes,
        };
        let (ra0, dec0) = track.radec_at(0.0);
        let (ra1, dec1) = track.radec_at(exposure_s);
        track.boresight_radec_start_deg = [ra0, dec0];
        track.boresight_radec_end_deg = [ra1, dec1];
        track
    }

    /// Largest angle between the debris' mid-exposure direction and its direction at any node.
    pub fn reach_deg(&self) -> f64 {
        self.reach_deg
    }

    /// The debris' unit direction `t_s` seconds after the start, interpolated between nodes.
    fn debris_at(&self, t_s: f64) -> Vec3 {
        let last = self.nodes.len() - 1;
        let u = (t_s / self.step_s).clamp(0.0, last as f64);
        let i = (u.floor() as usize).min(last - 1);
        let f = u - i as f64;
        let (a, b) = (self.nodes[i], self.nodes[i + 1]);
        unit([0, 1, 2].map(|k| a[k] + f * (b[k] - a[k])))
    }

    /// The camera's turn R(t) from mid-exposure to `t_s`: its unit axis and angle (radians),
    /// None when it has not turned.
    pub fn turn_at(&self, t_s: f64) -> Option<(Vec3, f64)> {
        let u = self.debris_at(t_s);
        let n = cross(self.debris_mid, u);
        let sin = norm(n);
        (sin != 0.0).then(|| (scale(n, 1.0 / sin), sin.atan2(dot(self.debris_mid, u))))
    }

    /// [`Self::turn_at`] as the turn that undoes it, R(t)^-1 (None: no turn); the renderer
    /// takes each node's once for all stars.
    pub fn turn_back(&self, t_s: f64) -> Option<Turn> {
        self.turn_at(t_s)
            .map(|(axis, angle)| Turn::new(axis, -angle))
    }

    /// The sky direction that the camera at `t_s` sees where the mid-exposure camera sees
    /// (ra, dec): the camera turned by R(t), so a star s appears at R(t)^-1 s of the mid frame.
    pub fn to_mid_frame(&self, t_s: f64, ra_deg: f64, dec_deg: f64) -> (f64, f64) {
        match self.turn_back(t_s) {
            Some(turn) => radec_deg(turn.apply(radec_unit(ra_deg, dec_deg))),
            None => (ra_deg, dec_deg),
        }
    }

    /// Boresight (RA, Dec) at `t_s` seconds after the start of the exposure.
    pub fn radec_at(&self, t_s: f64) -> (f64, f64) {
        let b = radec_unit(self.mid_ra_deg, self.mid_dec_deg);
        let n = cross(self.debris_mid, self.debris_at(t_s));
        let sin = norm(n);
        if sin == 0.0 {
            return (self.mid_ra_deg, self.mid_dec_deg);
        }
        let angle = sin.atan2(dot(self.debris_mid, self.debris_at(t_s)));
        radec_deg(rotate(b, scale(n, 1.0 / sin), angle))
    }
}
