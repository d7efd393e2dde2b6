//! Why a candidate line was dropped (`soig detect --explain`): every refined fragment or merged
//! segment that did not become a candidate, with the stage and the test it failed, so a user
//! can see which knob holds a streak back.

use std::fmt;

use super::segment::Seg;

/// The stage that produced a segment: step 3's local line filters or step 3b's long lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Seeds {
    Local,
    LongLine,
    FullLine,
}

impl fmt::Display for Seeds {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Seeds::Local => "local line filter",
            Seeds::LongLine => "long-line stage",
            Seeds::FullLine => "full-line stage",
        })
    }
}

/// The test a segment failed, with the measured value and the limit where there is one.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "test")]
pub enum Reason {
    /// Refinement: the profile along the axis has no positive level (no line there).
    NoLevel,
    /// Refinement: the fragment is shorter than `min_fragment_px`.
    ShortFragment { length_px: f64, limit: f64 },
    /// Along the star trails (their direction, or a predicted trail that explains it).
    StarTrail,
    /// Acceptance: shorter than `min_length_px`.
    TooShort { length_px: f64, limit: f64 },
    /// Acceptance: elongation below `min_elongation` (round: a star or a blob).
    NotElongated { elongation: f64, limit: f64 },
    /// Acceptance: SNR below `min_snr`.
    LowSnr { snr: f64, limit: f64 },
    /// Acceptance: one stretch of it holds no streak (a chain of stars; see the gap test in
    /// `merge`): chunk `chunk` of `chunks`, at `level` of the segment's median level, `sigma`
    /// noise sigmas below it.
    Gap {
        chunk: usize,
        chunks: usize,
        level: f64,
        sigma: f64,
    },
    /// Acceptance: a full-line segment along the frame's outline (its footprint's, else its
    /// border): the edge, not a streak.
    Outline,
    /// Explaining away: too little of it lies away from a better candidate.
    Duplicate,
    /// `max_candidates` better candidates were already kept.
    OverCap { limit: usize },
}

impl Reason {
    /// The step of the module docs where the test sits.
    pub fn stage(&self) -> &'static str {
        match self {
            Reason::NoLevel | Reason::ShortFragment { .. } => "refine",
            Reason::StarTrail => "star trails",
            Reason::TooShort { .. }
            | Reason::NotElongated { .. }
            | Reason::LowSnr { .. }
            | Reason::Gap { .. }
            | Reason::Outline => "accept",
            Reason::Duplicate => "explaining away",
            Reason::OverCap { .. } => "output",
        }
    }
}

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.stage())?;
        match self {
            Reason::NoLevel => f.write_str("no positive level along the axis"),
            Reason::ShortFragment { length_px, limit } => {
                write!(f, "fragment {length_px:.1} px < min_fragment_px {limit}")
            }
            Reason::StarTrail => f.write_str("explained by the star trails"),
            Reason::TooShort { length_px, limit } => {
                write!(f, "length {length_px:.1} px < min_length_px {limit}")
            }
            Reason::NotElongated { elongation, limit } => {
                write!(f, "elongation {elongation:.2} < min_elongation {limit}")
            }
            Reason::LowSnr { snr, limit } => write!(f, "SNR {snr:.2} < min_snr {limit}"),
            Reason::Gap {
                chunk,
                chunks,
                level,
                sigma,
            } => write!(
                f,
                "a gap: chunk {} of {chunks} at {level:.2} of its level, {sigma:.1} sigma below",
                chunk + 1
            ),
            Reason::Outline => f.write_str("a full line along the frame's outline (its edge)"),
            Reason::Duplicate => {
                f.write_str("within duplicate_distance_px of a better candidate for the most part")
            }
            Reason::OverCap { limit } => write!(f, "max_candidates {limit} already kept"),
        }
    }
}

/// A dropped segment: where it was (pixel-edge coordinates, as [`super::Candidate::ends`];
/// `None` when refinement gave no segment: then the seed's axis ends), what seeded it and why it
/// was dropped.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Dropped {
    pub seeds: Seeds,
    pub ends: [[f64; 2]; 2],
    pub length_px: f64,
    pub snr: Option<f64>,
    pub elongation: Option<f64>,
    pub reason: Reason,
}

impl Dropped {
    pub(super) fn of_seg(s: &Seg, seeds: Seeds, reason: Reason) -> Dropped {
        let (a, b) = s.ends();
        Dropped {
            seeds,
            ends: [[a.0 + 0.5, a.1 + 0.5], [b.0 + 0.5, b.1 + 0.5]],
            length_px: s.length,
            snr: Some(s.snr),
            elongation: Some(s.elongation),
            reason,
        }
    }

    pub(super) fn of_axis(c: (f64, f64), theta: f64, half: f64, seeds: Seeds) -> Dropped {
        let (ux, uy) = (theta.cos(), theta.sin());
        Dropped {
            seeds,
            ends: [
                [c.0 - half * ux + 0.5, c.1 - half * uy + 0.5],
                [c.0 + half * ux + 0.5, c.1 + half * uy + 0.5],
            ],
            length_px: 2.0 * half,
            snr: None,
            elongation: None,
            reason: Reason::NoLevel,
        }
    }
}

impl fmt::Display for Dropped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [[x0, y0], [x1, y1]] = self.ends;
        write!(
            f,
            "({x0:.1}, {y0:.1})-({x1:.1}, {y1:.1}), {:.0} px, from the {}: {}",
            self.length_px, self.seeds, self.reason
        )
    }
}
