//! Small vector maths of the sky: 3-vectors, 3x3 matrices, rotations and directions given as
//! (RA, Dec). The sums are written out in one fixed order on purpose: the pinned digests depend
//! on the last bit of every position, so a reordered sum would change the rendered images.

/// A 3-vector in km (or unitless when normalised).
pub type Vec3 = [f64; 3];

/// A 3x3 matrix, rows first.
pub type Mat3 = [[f64; 3]; 3];

pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

pub fn scale(a: Vec3, k: f64) -> Vec3 {
    [a[0] * k, a[1] * k, a[2] * k]
}

pub fn unit(a: Vec3) -> Vec3 {
    scale(a, 1.0 / norm(a))
}

/// Angle between two vectors, degrees (robust near 0 and 180 via atan2).
pub fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b)).to_degrees()
}

/// Rodrigues' rotation of `v` about the unit `axis` by `angle` radians.
pub fn rotate(v: Vec3, axis: Vec3, angle: f64) -> Vec3 {
    Turn::new(axis, angle).apply(v)
}

/// A rotation about a unit axis with its sine and cosine taken once: the renderer turns every
/// star by each trail node's rotation, and the sines were most of that work. [`rotate`] is
/// this, so a turn gives its result to the bit.
#[derive(Clone, Copy, Debug)]
pub struct Turn {
    axis: Vec3,
    angle: f64,
    sin: f64,
    cos: f64,
}

impl Turn {
    /// The rotation about the unit `axis` by `angle` radians.
    pub fn new(axis: Vec3, angle: f64) -> Turn {
        let (sin, cos) = angle.sin_cos();
        Turn {
            axis,
            angle,
            sin,
            cos,
        }
    }

    /// Its angle, radians: no direction moves farther than its absolute value.
    pub fn angle(&self) -> f64 {
        self.angle
    }

    /// Rodrigues' rotation of `v`.
    pub fn apply(&self, v: Vec3) -> Vec3 {
        let (k, s, c) = (self.axis, self.sin, self.cos);
        let kxv = cross(k, v);
        let kv = dot(k, v) * (1.0 - c);
        [0, 1, 2].map(|i| v[i] * c + kxv[i] * s + k[i] * kv)
    }
}

pub fn mat_vec(a: &Mat3, v: Vec3) -> Vec3 {
    [0, 1, 2].map(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

pub fn transpose(a: &Mat3) -> Mat3 {
    [0, 1, 2].map(|i| [a[0][i], a[1][i], a[2][i]])
}

/// Right ascension in [0, 360) and declination of a direction, degrees.
pub fn radec_deg(v: Vec3) -> (f64, f64) {
    let ra = v[1].atan2(v[0]).to_degrees().rem_euclid(360.0);
    let dec = v[2].atan2((v[0] * v[0] + v[1] * v[1]).sqrt()).to_degrees();
    (ra, dec)
}

/// Unit vector of (ra, dec) in degrees.
pub fn radec_unit(ra_deg: f64, dec_deg: f64) -> Vec3 {
    let (sa, ca) = ra_deg.to_radians().sin_cos();
    let (sd, cd) = dec_deg.to_radians().sin_cos();
    [cd * ca, cd * sa, sd]
}

/// Does the segment from `a` to `b` pass within `radius` of the origin?
pub fn segment_hits_sphere(a: Vec3, b: Vec3, radius: f64) -> bool {
    let d = sub(b, a);
    let len2 = dot(d, d);
    let t = if len2 > 0.0 {
        (-dot(a, d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let closest = [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]];
    norm(closest) < radius
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radec_round_trip_and_angles() {
        for &(ra, dec) in &[(0.0, 0.0), (359.9, -89.0), (123.4, 45.6), (180.0, 89.999)] {
            let (r, d) = radec_deg(radec_unit(ra, dec));
            assert!(
                (r - ra).abs() < 1e-9 && (d - dec).abs() < 1e-9,
                "{ra} {dec} -> {r} {d}"
            );
        }
        assert!((angle_deg([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) - 90.0).abs() < 1e-12);
        assert!((angle_deg([1.0, 0.0, 0.0], [-1.0, 1e-9, 0.0]) - 180.0).abs() < 1e-6);
    }

    #[test]
    fn segment_sphere() {
        assert!(segment_hits_sphere(
            [-10.0, 0.5, 0.0],
            [10.0, 0.5, 0.0],
            1.0
        ));
        assert!(!segment_hits_sphere(
            [-10.0, 1.5, 0.0],
            [10.0, 1.5, 0.0],
            1.0
        ));
        // The sphere is behind the start point: no hit.
        assert!(!segment_hits_sphere([2.0, 0.0, 0.0], [10.0, 0.0, 0.0], 1.0));
    }
}
