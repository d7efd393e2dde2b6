//! Reading a truth sidecar (`truth/<image>.json`) back: the one reader of the report and the
//! exports. A sidecar is either one object's truth (a campaign without `[objects]` or
//! `[population]`: the frame's and the object's fields side by side) or a frame's truth with an
//! `objects` list (none, one or many). Each reader names the fields it needs: the frame's as
//! `F`, an object's as `O`; the rest is ignored.

use std::path::Path;

use anyhow::Context;
use serde::Deserialize;
use serde::de::DeserializeOwned;

/// A sidecar read back: its frame's fields and its objects, in the sidecar's order (the order
/// of the image's label lines among the labelled ones).
pub struct Sidecar<F, O> {
    pub frame: F,
    pub objects: Vec<O>,
}

/// The sidecar at `path`: `F` from the whole file, `O` from each entry of its `objects`, or
/// from the whole file when it has none (a one-object sidecar).
pub fn read<F: DeserializeOwned, O: DeserializeOwned>(
    path: &Path,
) -> anyhow::Result<Sidecar<F, O>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let bad =
        |e: serde_json::Error| anyhow::anyhow!("{}: not a soig truth sidecar: {e}", path.display());
    let value: serde_json::Value = serde_json::from_str(&text).map_err(bad)?;
    let frame = F::deserialize(&value).map_err(bad)?;
    let objects = match value.get("objects") {
        Some(list) if !list.is_null() => Vec::<O>::deserialize(list).map_err(bad)?,
        _ => vec![O::deserialize(&value).map_err(bad)?],
    };
    Ok(Sidecar { frame, objects })
}

/// Whether an object's `label_box_final_px` is a box: it has a label line (`null` or absent
/// when no photon of it landed in the final frame).
pub fn labelled(label_box_final_px: &Option<serde_json::Value>) -> bool {
    label_box_final_px.as_ref().is_some_and(|b| !b.is_null())
}
