//! Why a scene draw was rejected (`Rejection`, in the words truth files hold), and why no
//! scene could be drawn at all (`NoScene`).

use std::collections::BTreeMap;

use serde::Serialize;

use super::Inputs;

/// Why one scene draw was rejected (`try_draw`, `try_place`). Its words (`as_str`, also its `Display`,
/// `Debug` and serialised form) are the ones truth files and messages have always held, and
/// it orders by them, so a map of rejections keeps its order and bytes.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rejection {
    EarthAngle,
    SunAngle,
    MoonAngle,
    ThroughEarth,
    EarthShadow,
    TooFaint,
    BrightStar,
    LowSnr,
    PropagationFailed,
    TooFast,
    TrackTooFast,
    /// A later frame of the collect would start after the campaign's window.
    CollectPastWindow,
    /// Ground observer: the Sun above the night's limit at the site.
    Daylight,
    /// Ground observer: the object below the site's altitude limit.
    BelowHorizon,
}

impl Rejection {
    pub fn as_str(self) -> &'static str {
        match self {
            Rejection::EarthAngle => "earth angle",
            Rejection::SunAngle => "sun angle",
            Rejection::MoonAngle => "moon angle",
            Rejection::ThroughEarth => "line of sight through the earth",
            Rejection::EarthShadow => "debris in earth shadow",
            Rejection::TooFaint => "fainter than the magnitude limit",
            Rejection::BrightStar => "star brighter than the limit in the field",
            Rejection::LowSnr => "signal to noise below the gate",
            Rejection::PropagationFailed => "propagation failed",
            Rejection::TooFast => "streak too fast to sample (over 1e6 trajectory samples)",
            Rejection::TrackTooFast => "tracking drift beyond the survey drift limit",
            Rejection::CollectPastWindow => "a later frame of the collect after the window",
            Rejection::Daylight => "sun above the night's limit at the site",
            Rejection::BelowHorizon => "object below the site's altitude limit",
        }
    }
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::fmt::Debug for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(self.as_str(), f)
    }
}

impl Ord for Rejection {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.as_str().cmp(other.as_str())
    }
}

impl PartialOrd for Rejection {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Serialize for Rejection {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// Why no scene could be drawn: the image's debris object was never visible.
#[derive(Debug, thiserror::Error)]
#[error(
    "image {image}: {object} (NORAD {norad}, debris[{debris_index}]) was never visible in {attempts} draws (rejections: {reasons})"
)]
pub struct NoScene {
    pub image: u64,
    /// The object drawn for the image: its index in the campaign's debris, name and number.
    pub debris_index: usize,
    pub object: String,
    pub norad: u64,
    pub attempts: u32,
    pub reasons: String,
    /// Draws rejected for each reason.
    pub rejections: BTreeMap<Rejection, u32>,
}

impl NoScene {
    /// The reasons draws were rejected for, the most frequent first.
    pub fn reasons_by_count(&self) -> Vec<Rejection> {
        let mut r: Vec<(Rejection, u32)> = self.rejections.iter().map(|(k, v)| (*k, *v)).collect();
        r.sort_by_key(|&(_, n)| std::cmp::Reverse(n));
        r.into_iter().map(|(k, _)| k).collect()
    }

    /// Image `image`'s object `debris_index` never accepted in `attempts` draws.
    pub(super) fn of(
        inputs: &Inputs,
        image: u64,
        debris_index: usize,
        attempts: u32,
        rejections: BTreeMap<Rejection, u32>,
    ) -> NoScene {
        let debris = &inputs.debris[debris_index];
        let object = (debris_index, debris.name.clone(), debris.norad);
        NoScene::named(image, object, attempts, rejections)
    }

    /// Image `image`'s `(debris index, name, NORAD number)` never accepted in `attempts` draws.
    pub(super) fn named(
        image: u64,
        (debris_index, object, norad): (usize, String, u64),
        attempts: u32,
        rejections: BTreeMap<Rejection, u32>,
    ) -> NoScene {
        NoScene {
            image,
            debris_index,
            object,
            norad,
            attempts,
            reasons: rejections
                .iter()
                .map(|(k, v)| format!("{k} x{v}"))
                .collect::<Vec<_>>()
                .join(", "),
            rejections,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Rejection;
    use std::collections::BTreeMap;

    /// Truth files hold rejections as a map from these words, in their alphabetical order.
    #[test]
    fn rejections_keep_their_words_and_order() {
        let mut m = BTreeMap::new();
        for r in [
            Rejection::SunAngle,
            Rejection::EarthAngle,
            Rejection::LowSnr,
        ] {
            m.insert(r, 1u32);
        }
        assert_eq!(
            serde_json::to_string(&m).unwrap(),
            r#"{"earth angle":1,"signal to noise below the gate":1,"sun angle":1}"#
        );
        assert_eq!(
            format!("{:?}", m),
            r#"{"earth angle": 1, "signal to noise below the gate": 1, "sun angle": 1}"#
        );
        assert_eq!(
            Rejection::TooFaint.to_string(),
            "fainter than the magnitude limit"
        );
    }
}
