//! What a detector may be told about a frame besides its pixels: the catalogued stars'
//! predicted trails. The simulator derives them from a scene, `soig detect --catalog` from a
//! FITS header and a catalogue (both a [`PredictedTrail`] in the whole frame); the streak
//! detector reads their part on its image (a [`StarTrail`]). Neither side sees the other.

/// A catalogued star's predicted path in the detector's image: pixel centres at integers,
/// linear between nodes (one node: a star that does not move).
#[derive(Clone, Debug, PartialEq)]
pub struct StarTrail {
    pub nodes: Vec<(f64, f64)>,
    /// Each node's time from the exposure's start, seconds (empty: not known). With them the
    /// pointing's wander over the exposure is measured on the bright trails and followed by
    /// all (see `jitter_across`).
    pub times_s: Vec<f64>,
    /// Expected photo-electrons of the star while its trail is in the image.
    pub electrons: f64,
}

/// A catalogued star's predicted trail over the exposure in a whole frame's pixel grid: pixel
/// centres at integers, linear between nodes, one node for a star that does not move. The
/// simulator's comes from a scene (`render::trails`), `soig detect --catalog`'s from a FITS
/// header and a catalogue; both are compared node for node (tests/detect_catalog.rs).
#[derive(Clone, Debug)]
pub struct PredictedTrail {
    pub ra_deg: f64,
    pub dec_deg: f64,
    pub mag: f64,
    /// Positions at the time nodes while the star is near the frame.
    pub nodes: Vec<[f64; 2]>,
    /// Each node's time from the exposure's start, seconds.
    pub times_s: Vec<f64>,
    /// Expected photo-electrons over those nodes' share of the exposure; None from a header
    /// with no zero point (`MAGZERO`).
    pub electrons: Option<f64>,
}

impl PredictedTrail {
    /// Its part on a detector's image: `at` places a node there (None: off the image), each
    /// kept node with its time; None when no node is on it. Without expected electrons, NaN
    /// (the detector measures the trail's level on the image).
    pub fn on_image(&self, at: impl Fn([f64; 2]) -> Option<(f64, f64)>) -> Option<StarTrail> {
        let (nodes, times_s): (Vec<(f64, f64)>, Vec<f64>) = self
            .nodes
            .iter()
            .zip(&self.times_s)
            .filter_map(|(&n, &t)| at(n).map(|p| (p, t)))
            .unzip();
        (!nodes.is_empty()).then(|| StarTrail {
            nodes,
            times_s,
            electrons: self.electrons.unwrap_or(f64::NAN),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trail(electrons: Option<f64>) -> PredictedTrail {
        PredictedTrail {
            ra_deg: 10.0,
            dec_deg: -5.0,
            mag: 9.0,
            nodes: vec![[-3.0, 1.0], [2.0, 1.0], [7.0, 1.0], [12.0, 1.0]],
            times_s: vec![0.0, 1.0, 2.0, 3.0],
            electrons,
        }
    }

    /// The nodes `at` places are kept with their own times, in order; a trail none of whose
    /// nodes lands is no trail; a header without a zero point gives NaN electrons.
    #[test]
    fn on_image_keeps_the_placed_nodes_with_their_times() {
        // An image 10 px wide, shifted 1 px left.
        let at = |[x, y]: [f64; 2]| (0.0..=9.0).contains(&x).then_some((x - 1.0, y));
        let t = trail(Some(500.0)).on_image(at).unwrap();
        assert_eq!(t.nodes, vec![(1.0, 1.0), (6.0, 1.0)]);
        assert_eq!(t.times_s, vec![1.0, 2.0]);
        assert_eq!(t.electrons, 500.0);
        assert!(trail(None).on_image(at).unwrap().electrons.is_nan());
        assert!(trail(Some(500.0)).on_image(|_| None).is_none());
    }
}
