//! A place on the sky at an instant of an exposure, from its places at the exposure's start,
//! middle and end (the truth's ephemeris; a pixel through the start, mid and end WCS).

/// The value at `t` of the parabola through `v` at 0, `span / 2` and `span` (Lagrange's form:
/// exactly `v[k]` at those instants), for (RA, Dec) in degrees: RA taken on the branch of
/// `v[0]`'s so that a track across RA 0 stays continuous, and returned in [0, 360).
pub fn interpolate(v: [[f64; 2]; 3], span: f64, t: f64) -> [f64; 2] {
    let nodes = [0.0, span / 2.0, span];
    let w: [f64; 3] = std::array::from_fn(|i| {
        (0..3)
            .filter(|&j| j != i)
            .map(|j| (t - nodes[j]) / (nodes[i] - nodes[j]))
            .product()
    });
    let ra: Vec<f64> = v
        .iter()
        .map(|p| v[0][0] + (p[0] - v[0][0] + 540.0).rem_euclid(360.0) - 180.0)
        .collect();
    [
        (w[0] * ra[0] + w[1] * ra[1] + w[2] * ra[2]).rem_euclid(360.0),
        w[0] * v[0][1] + w[1] * v[1][1] + w[2] * v[2][1],
    ]
}

#[cfg(test)]
mod tests {
    use super::interpolate;

    /// Exact at the three instants; a track quadratic in time is followed exactly between
    /// them; a track across RA 0 stays continuous.
    #[test]
    fn the_parabola_through_three_places() {
        let v = [[10.0, 5.0], [10.5, 5.25], [12.0, 4.0]];
        assert_eq!(interpolate(v, 10.0, 0.0), v[0]);
        assert_eq!(interpolate(v, 10.0, 5.0), v[1]);
        assert_eq!(interpolate(v, 10.0, 10.0), v[2]);
        // RA = 10 + 0.02 t^2 and Dec = 5 + 0.2 t - 0.03 t^2 go through those three.
        let t = 0.0025;
        let [ra, dec] = interpolate(v, 10.0, t);
        assert!((ra - (10.0 + 0.02 * t * t)).abs() < 1e-12, "{ra}");
        assert!(
            (dec - (5.0 + 0.2 * t - 0.03 * t * t)).abs() < 1e-12,
            "{dec}"
        );
        let across = [[359.9, 0.0], [0.0, 0.0], [0.1, 0.0]];
        let [ra, _] = interpolate(across, 2.0, 1.5);
        assert!((ra - 0.05).abs() < 1e-9, "{ra}");
    }
}
