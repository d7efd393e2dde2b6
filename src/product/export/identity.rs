//! Which object each label line of an image is, from its truth sidecar: the objects whose
//! label box reached the final frame, in the sidecar's order (the order the label files are
//! written in, `streak_labels::labels`), each with its name, id and source, for the COCO
//! annotations and the DS9 text.

use std::path::Path;

use serde::Deserialize;

/// One labelled object: its name, its id (the NORAD number, or a generated object's id) and
/// where it came from: the truth's `source` (`placed`, `debris`, `population`, `generated`);
/// a one-object sidecar's object is the campaign's `debris` drawn where its orbit puts it.
#[derive(Clone, Debug, PartialEq)]
pub struct Identity {
    pub object: String,
    pub id: u64,
    pub source: String,
}

/// What the identities need of a sidecar's object (or of a one-object sidecar itself).
#[derive(Deserialize)]
struct Labelled {
    object: String,
    norad: u64,
    #[serde(default)]
    source: Option<String>,
    label_box_final_px: Option<serde_json::Value>,
}

/// The source a one-object sidecar's object has.
const ONE_OBJECT_SOURCE: &str = "debris";

impl Identity {
    /// The DS9 text of the object: "NAME (NORAD n)", or "NAME (id n)" for a generated one,
    /// whose id is no NORAD number.
    pub fn text(&self) -> String {
        match self.source.as_str() {
            "generated" => format!("{} (id {})", self.object, self.id),
            _ => format!("{} (NORAD {})", self.object, self.id),
        }
    }
}

/// Every object of the sidecar at `path`, labelled or not, with whether it has a label line.
pub fn objects(path: &Path) -> anyhow::Result<Vec<(Identity, bool)>> {
    let sidecar = crate::truth_sidecar::read::<serde::de::IgnoredAny, Labelled>(path)?;
    Ok(sidecar
        .objects
        .into_iter()
        .map(|o| {
            let labelled = crate::truth_sidecar::labelled(&o.label_box_final_px);
            let source = o.source.unwrap_or_else(|| ONE_OBJECT_SOURCE.into());
            let identity = Identity {
                object: o.object,
                id: o.norad,
                source,
            };
            (identity, labelled)
        })
        .collect())
}

/// The objects of the label file `labels` (with `lines` lines), from the sidecar `truth`: one
/// per line, or an error naming both files when they disagree.
pub fn of_labels(truth: &Path, labels: &Path, lines: usize) -> anyhow::Result<Vec<Identity>> {
    let labelled: Vec<Identity> = objects(truth)?
        .into_iter()
        .filter_map(|(id, labelled)| labelled.then_some(id))
        .collect();
    if labelled.len() != lines {
        anyhow::bail!(
            "{} has {lines} label line(s) but its truth {} has {} labelled object(s)",
            labels.display(),
            truth.display(),
            labelled.len()
        );
    }
    Ok(labelled)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame's sidecar: the labelled objects in order, a one-object sidecar as `debris`, a
    /// generated object's text by its id; a label file with more lines than labelled objects
    /// is refused naming both files.
    #[test]
    fn label_lines_are_the_labelled_objects_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let frame = dir.path().join("frame.json");
        let one = dir.path().join("one.json");
        let boxed = r#"{"x_min": 0, "y_min": 0, "x_max": 1, "y_max": 1}"#;
        std::fs::write(
            &frame,
            format!(
                r#"{{"objects": [
                {{"object": "A", "norad": 5, "source": "population", "label_box_final_px": null}},
                {{"object": "B fragment 2", "norad": 500002, "source": "generated", "label_box_final_px": {boxed}}},
                {{"object": "C", "norad": 7, "source": "population", "label_box_final_px": {boxed}}}]}}"#
            ),
        )
        .unwrap();
        std::fs::write(
            &one,
            format!(r#"{{"object": "D", "norad": 9, "label_box_final_px": {boxed}}}"#),
        )
        .unwrap();
        let labels = dir.path().join("img.txt");
        let ids = of_labels(&frame, &labels, 2).unwrap();
        assert_eq!(ids.iter().map(|i| i.id).collect::<Vec<_>>(), [500002, 7]);
        assert_eq!(ids[0].text(), "B fragment 2 (id 500002)");
        assert_eq!(ids[1].text(), "C (NORAD 7)");
        let d = of_labels(&one, &labels, 1).unwrap();
        assert_eq!(d[0].source, "debris");
        let e = of_labels(&frame, &labels, 3).unwrap_err().to_string();
        assert!(e.contains("img.txt has 3 label line(s)"), "{e}");
        assert!(e.contains("frame.json has 2 labelled object(s)"), "{e}");
    }
}
