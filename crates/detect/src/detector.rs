//! One way to run either detector on a frame: what a detector is told of the frame's stars
//! ([`Stars`]), what it finds ([`Found`]), and the [`Detector`] trait that `soig run`'s detect
//! stage, `soig detect` (and through it Python) and the examples call (issue #42). A detector
//! sees an 8-bit frame and, at most, what is known of its stars: never a truth file.

use crate::Detection;
use crate::streak::{self, Candidate, Footprint, OwnTrails, Sanitized, StarTrail, StreakParams};
use crate::yolo::YoloDetector;

/// An 8-bit frame: `pixels` row-major, `width * height` values.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    pub pixels: &'a [u8],
    pub width: usize,
    pub height: usize,
    /// Where the frame holds data (the original image inside a rotated or padded frame, as the
    /// conversion put it); `None`: all of it. The streak detector ends a streak that runs on to
    /// its outline there; YOLO ignores it.
    pub footprint: Option<Footprint>,
}

impl<'a> Frame<'a> {
    /// A frame that holds data everywhere.
    pub fn new(pixels: &'a [u8], width: usize, height: usize) -> Frame<'a> {
        Frame {
            pixels,
            width,
            height,
            footprint: None,
        }
    }
}

/// What a detector is told of a frame's stars. The streak detector reads it; YOLO learned the
/// stars from its training set and ignores it.
#[derive(Clone, Copy, Debug)]
pub enum Stars<'a> {
    /// Nothing: the streak detector measures the frame's own star trails (a user's bare frame).
    Unknown,
    /// Round stars (fixed or sidereal pointing): no direction to subtract along.
    Points,
    /// Star trails along this direction (degrees in image axes, see [`streak`]'s docs), from
    /// the attitude.
    Along(f64),
    /// The catalogue's stars, their trails predicted on the frame, along `angle_deg`.
    Catalogue {
        angle_deg: f64,
        trails: &'a [StarTrail],
    },
}

impl<'a> Stars<'a> {
    /// From what a caller knows: a trail direction and the predicted trails, either optional.
    /// Without a (finite) direction the trails cannot be used and the stars count as points.
    pub fn told(angle_deg: Option<f64>, trails: Option<&'a [StarTrail]>) -> Stars<'a> {
        match (angle_deg.filter(|a| a.is_finite()), trails) {
            (Some(angle_deg), Some(trails)) => Stars::Catalogue { angle_deg, trails },
            (Some(angle_deg), None) => Stars::Along(angle_deg),
            (None, _) => Stars::Points,
        }
    }
}

/// One thing a detector found: the streak detector's streak (its ends, length, SNR, flux
/// and box), or a detector's box alone (YOLO).
#[derive(Clone, Debug)]
pub enum Found {
    Streak(Candidate),
    Box(Detection),
}

impl Found {
    /// The box and confidence, as every detector reports them and the metrics score them.
    pub fn detection(&self) -> &Detection {
        match self {
            Found::Streak(c) => &c.detection,
            Found::Box(d) => d,
        }
    }

    /// The streak's two ends in pixel-edge coordinates, where the detector measures them.
    pub fn ends(&self) -> Option<[[f64; 2]; 2]> {
        match self {
            Found::Streak(c) => Some(c.ends),
            Found::Box(_) => None,
        }
    }
}

/// Why a detector could not look at a frame (YOLO: a model or image it cannot use).
pub type DetectError = Box<dyn std::error::Error + Send + Sync>;

/// A detector: a frame and what is known of its stars in, what it found out.
pub trait Detector {
    /// The name reports and prediction folders use ("streak", "yolo").
    fn name(&self) -> &'static str;
    /// What the detector finds on `frame`, best first.
    fn detect(&mut self, frame: Frame<'_>, stars: Stars<'_>) -> Result<Vec<Found>, DetectError>;
}

/// The classical streak detector with its settings.
#[derive(Clone, Debug)]
pub struct StreakDetector {
    pub params: StreakParams,
}

impl StreakDetector {
    /// [`Detector::detect`], and the frame's own star trails where it measured them
    /// ([`Stars::Unknown`]; `soig detect` reports them).
    pub fn detect_measuring(
        &self,
        frame: Frame<'_>,
        stars: Stars<'_>,
    ) -> (Vec<Candidate>, Option<OwnTrails>) {
        let Frame {
            pixels,
            width,
            height,
            footprint,
        } = frame;
        let p = &Sanitized::new(&self.params).within(footprint);
        match stars {
            Stars::Unknown => streak::on_frame(pixels, width, height, p, None, None),
            Stars::Points => (streak::explained(pixels, width, height, p, None).0, None),
            Stars::Along(a) => (streak::explained(pixels, width, height, p, Some(a)).0, None),
            Stars::Catalogue { angle_deg, trails } => (
                streak::among_stars(pixels, width, height, p, Some(angle_deg), Some(trails)),
                None,
            ),
        }
    }
}

impl Detector for StreakDetector {
    fn name(&self) -> &'static str {
        "streak"
    }

    fn detect(&mut self, frame: Frame<'_>, stars: Stars<'_>) -> Result<Vec<Found>, DetectError> {
        let (found, _) = self.detect_measuring(frame, stars);
        Ok(found.into_iter().map(Found::Streak).collect())
    }
}

impl Detector for YoloDetector {
    fn name(&self) -> &'static str {
        "yolo"
    }

    fn detect(&mut self, frame: Frame<'_>, _stars: Stars<'_>) -> Result<Vec<Found>, DetectError> {
        let found = YoloDetector::detect(self, frame.pixels, frame.width, frame.height)?;
        Ok(found.into_iter().map(Found::Box).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_a_caller_knows_picks_the_stars() {
        let trails: Vec<StarTrail> = Vec::new();
        assert!(matches!(Stars::told(None, None), Stars::Points));
        // Trails without a direction cannot be used.
        assert!(matches!(Stars::told(None, Some(&trails)), Stars::Points));
        assert!(matches!(Stars::told(Some(f64::NAN), None), Stars::Points));
        assert!(matches!(Stars::told(Some(30.0), None), Stars::Along(a) if a == 30.0));
        assert!(matches!(
            Stars::told(Some(30.0), Some(&trails)),
            Stars::Catalogue { angle_deg, .. } if angle_deg == 30.0
        ));
    }

    /// The trait finds what the streak functions find: a bright line across a flat frame,
    /// with round stars, and with the frame told nothing.
    #[test]
    fn the_streak_detector_through_the_trait_is_the_functions() {
        let (w, h) = (160usize, 120usize);
        let mut pixels = vec![20u8; w * h];
        for x in 20..140 {
            let y = 30 + (x - 20) / 2;
            pixels[y * w + x] = 200;
            pixels[(y + 1) * w + x] = 120;
        }
        let params = StreakParams::default();
        let frame = Frame::new(&pixels, w, h);
        let boxes = |found: Vec<Found>| -> Vec<Detection> {
            found.iter().map(|f| *f.detection()).collect()
        };
        let mut d = StreakDetector {
            params: params.clone(),
        };
        let direct: Vec<Detection> = streak::detect_streaks(&pixels, w, h, &params, None)
            .iter()
            .map(|c| c.detection)
            .collect();
        assert!(!direct.is_empty(), "the line is found");
        assert_eq!(boxes(d.detect(frame, Stars::Points).unwrap()), direct);
        let own: Vec<Detection> =
            streak::detect_streaks_on_frame(&pixels, w, h, &params, None, None)
                .0
                .iter()
                .map(|c| c.detection)
                .collect();
        assert_eq!(boxes(d.detect(frame, Stars::Unknown).unwrap()), own);
        assert_eq!(d.name(), "streak");
    }
}
