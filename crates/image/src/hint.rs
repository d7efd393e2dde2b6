//! What a detector may be told about a frame besides its pixels: the catalogued stars'
//! predicted trails. The simulator derives them from a scene, `soig detect --catalog` from a
//! FITS header and a catalogue; the streak detector reads them. Neither side sees the other.

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
