//! A campaign composed of layers: the chain of files joined by `extends` (the base first), then
//! each `--set key.path=value` override. Tables merge key by key, a later layer's value wins and
//! arrays are replaced whole. Every layer keeps its source, so an error names the file and line
//! (or the `--set`) that wrote the field.
//!
//! `extends` is read here and never reaches `CampaignFile`: the resolved campaign, and its hash,
//! are those of the same settings written in one file.

use std::path::{Path, PathBuf};

use toml::{Table, Value};

use super::lines::{field_at_offset, field_keys, field_on_line, line_of_field, line_of_offset};
use super::{CampaignError, CampaignFile, dir_of};

/// The field a toml error at `offset` is about; none for a missing field, whose error points
/// at the table that lacks it (and names the field itself).
fn field_of_error(text: &str, offset: usize, message: &str) -> Option<String> {
    if message.starts_with("missing field") {
        return None;
    }
    field_at_offset(text, offset)
}

/// Where a layer's values come from.
enum Source {
    File {
        path: PathBuf,
        text: String,
    },
    /// One `--set key.path=value` argument, as given.
    Set(String),
}

impl Source {
    /// The name errors give the source: the file, or `--set key=value`.
    fn label(&self) -> PathBuf {
        match self {
            Source::File { path, .. } => path.clone(),
            Source::Set(arg) => PathBuf::from(format!("--set {arg}")),
        }
    }
}

struct Layer {
    source: Source,
    table: Table,
}

/// The layers of one campaign, lowest precedence first.
pub(super) struct Layers {
    layers: Vec<Layer>,
    /// The campaign file itself (the end of the `extends` chain): it answers for fields no
    /// layer writes.
    leaf: usize,
}

impl Layers {
    /// The campaign `text` read from `path`, the files it extends, and `overrides` on top.
    pub(super) fn read(
        text: &str,
        path: &Path,
        overrides: &[String],
    ) -> Result<Layers, CampaignError> {
        let mut chain: Vec<Layer> = Vec::new();
        let mut seen = vec![canonical(path)];
        let (mut path, mut text) = (path.to_path_buf(), text.to_string());
        loop {
            let mut table: Table = text.parse().map_err(|e: toml::de::Error| {
                let line = e.span().map(|s| line_of_offset(&text, s.start));
                CampaignError {
                    file: path.clone(),
                    line,
                    field: line.and_then(|l| field_on_line(&text, l)),
                    message: e.message().trim().to_string(),
                }
            })?;
            let extends = table.remove("extends");
            let at = |message: String| CampaignError {
                file: path.clone(),
                line: line_of_field(&text, "extends"),
                field: Some("extends".into()),
                message,
            };
            let base = match extends {
                None => None,
                Some(Value::String(rel)) => Some(dir_of(&path).join(rel)),
                Some(_) => {
                    return Err(at(
                        "must be the path of a campaign file, relative to this one".into(),
                    ));
                }
            };
            let Some(base) = base else {
                chain.push(Layer {
                    source: Source::File { path, text },
                    table,
                });
                break;
            };
            let key = canonical(&base);
            if seen.contains(&key) {
                let cycle: Vec<String> = seen
                    .iter()
                    .chain([&key])
                    .map(|p| p.display().to_string())
                    .collect();
                return Err(at(format!("a cycle of `extends`: {}", cycle.join(" -> "))));
            }
            let base_text = crate::input_file::read_text(&base)
                .map_err(|why| at(format!("{}: {why}", base.display())))?;
            seen.push(key);
            chain.push(Layer {
                source: Source::File { path, text },
                table,
            });
            (path, text) = (base, base_text);
        }
        chain.reverse();
        let leaf = chain.len() - 1;
        for arg in overrides {
            chain.push(set_layer(arg)?);
        }
        Ok(Layers {
            layers: chain,
            leaf,
        })
    }

    /// The composed campaign, parsed.
    pub(super) fn parse(&self) -> Result<CampaignFile, CampaignError> {
        // One file: parse its own text, so errors keep toml's exact position.
        if let [
            Layer {
                source: Source::File { path, text },
                ..
            },
        ] = self.layers.as_slice()
        {
            return toml::from_str(text).map_err(|e| CampaignError {
                file: path.clone(),
                line: e.span().map(|s| line_of_offset(text, s.start)),
                field: e
                    .span()
                    .and_then(|s| field_of_error(text, s.start, e.message())),
                message: e.message().trim().to_string(),
            });
        }
        let mut merged = Table::new();
        for layer in &self.layers {
            merge(&mut merged, layer.table.clone());
        }
        // Parse the merged table as text: toml's error then has a position, hence a field,
        // and the layer that wrote that field answers for it.
        let text = toml::to_string(&merged).expect("a TOML table serialises");
        toml::from_str(&text).map_err(|e| {
            let field = e
                .span()
                .and_then(|s| field_of_error(&text, s.start, e.message()));
            let (file, line) = match &field {
                Some(f) => self.locate(f),
                None => (self.layers[self.leaf].source.label(), None),
            };
            CampaignError {
                file,
                line,
                field,
                message: e.message().trim().to_string(),
            }
        })
    }

    /// An error about `field`, at the file and line (or the `--set`) that wrote it.
    pub(super) fn error(&self, field: &str, message: String) -> CampaignError {
        let (file, line) = self.locate(field);
        CampaignError {
            file,
            line,
            field: Some(field.to_string()),
            message,
        }
    }

    /// The source and line of `field`: the last layer that writes it, or replaces an array or
    /// value above it; else the layer that writes most of its enclosing tables (a field left to
    /// its default reports its table); else the campaign file, without a line.
    fn locate(&self, field: &str) -> (PathBuf, Option<usize>) {
        let keys = field_keys(field);
        let mut best: Option<(usize, usize)> = None;
        for (i, layer) in self.layers.iter().enumerate().rev() {
            let (depth, owns) = written(&layer.table, &keys);
            if owns {
                best = Some((depth, i));
                break;
            }
            if depth > 0 && best.is_none_or(|(d, _)| depth > d) {
                best = Some((depth, i));
            }
        }
        let layer = &self.layers[best.map_or(self.leaf, |(_, i)| i)];
        let line = match &layer.source {
            Source::File { text, .. } => line_of_field(text, field),
            Source::Set(_) => None,
        };
        (layer.source.label(), line)
    }
}

/// How many keys of a field path a table writes, and whether it decides the field's value: it
/// writes the whole path, or an array or value above it (which replaces what bases wrote).
fn written(table: &Table, keys: &[(String, Option<usize>)]) -> (usize, bool) {
    let mut t = table;
    for (depth, (key, index)) in keys.iter().enumerate() {
        let Some(value) = t.get(key) else {
            return (depth, false);
        };
        match value {
            Value::Table(inner) if index.is_none() => t = inner,
            _ => return (depth + 1, true),
        }
    }
    (keys.len(), true)
}

/// Merge `over` into `into`: tables key by key, anything else (arrays too) replaced.
fn merge(into: &mut Table, over: Table) {
    for (key, value) in over {
        match (into.get_mut(&key), value) {
            (Some(Value::Table(a)), Value::Table(b)) => merge(a, b),
            (_, value) => {
                into.insert(key, value);
            }
        }
    }
}

/// The layer of one `--set key.path=value`: the value is a TOML value (`512`, `true`,
/// `[8, 8]`, `"text"`) if it parses as one, else the text as a string.
fn set_layer(arg: &str) -> Result<Layer, CampaignError> {
    let fail =
        |message: String| CampaignError::of_file(Source::Set(arg.to_string()).label(), message);
    let (key, value) = arg
        .split_once('=')
        .ok_or_else(|| fail("write it as `key.path=value`".into()))?;
    let keys: Vec<&str> = key.trim().split('.').collect();
    let bare = |k: &&str| {
        !k.is_empty()
            && k.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    };
    if !keys.iter().all(bare) {
        return Err(fail(format!(
            "`{key}` is not a key path such as `sensor.width_px`"
        )));
    }
    if keys == ["extends"] {
        return Err(fail(
            "`extends` can only be written in a campaign file".into(),
        ));
    }
    let value = value
        .trim()
        .parse::<Value>()
        .unwrap_or_else(|_| Value::String(value.to_string()));
    let (last, outer) = keys.split_last().expect("split gives at least one key");
    let mut table = Table::from_iter([(last.to_string(), value)]);
    for k in outer.iter().rev() {
        table = Table::from_iter([(k.to_string(), Value::Table(table))]);
    }
    Ok(Layer {
        source: Source::Set(arg.to_string()),
        table,
    })
}

/// A file's identity for cycle checks: its canonical path when it exists.
fn canonical(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::super::Campaign;

    const ORBIT: &str = "elements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";

    /// Write `files` (name, text) into a temporary directory.
    fn files(files: &[(&str, &str)]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in files {
            std::fs::write(dir.path().join(name), text).unwrap();
        }
        dir
    }

    fn objects() -> String {
        format!("[observer]\nnorad = 1\n{ORBIT}\n[[debris]]\nnorad = 40649\n{ORBIT}\n")
    }

    #[test]
    fn a_chain_of_bases_resolves_like_one_file() {
        let base = format!(
            "images = 7\n{}[sensor]\nwidth_px = 512\nheight_px = 512\n[split]\ntrain = 0.5\nval = 0.25\ntest = 0.25\n",
            objects()
        );
        let middle = format!(
            "extends = \"../base.toml\"\nseed = 9\n[sensor]\nwidth_px = 256\n[[debris]]\nnorad = 2\n{ORBIT}\n"
        );
        let leaf = "extends = \"sub/middle.toml\"\nname = \"leaf\"\n";
        let dir = files(&[("base.toml", &base), ("leaf.toml", leaf)]);
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        std::fs::write(dir.path().join("sub/middle.toml"), middle).unwrap();
        let c = Campaign::load(&dir.path().join("leaf.toml")).unwrap();
        let flat = format!(
            "name = \"leaf\"\nseed = 9\nimages = 7\n[observer]\nnorad = 1\n{ORBIT}\n[[debris]]\nnorad = 2\n{ORBIT}\n[sensor]\nwidth_px = 256\nheight_px = 512\n[split]\ntrain = 0.5\nval = 0.25\ntest = 0.25\n"
        );
        let one = Campaign::from_toml(&flat, &dir.path().join("flat.toml")).unwrap();
        // Tables merge key by key; the array of debris is replaced whole.
        assert_eq!(c.resolved.sensor.width_px, 256);
        assert_eq!(c.resolved.sensor.height_px, 512);
        assert_eq!(c.resolved.debris.len(), 1);
        assert_eq!(c.resolved, one.resolved);
        assert_eq!(c.hash, one.hash);
        let json = serde_json::to_string(&c.resolved).unwrap();
        assert!(!json.contains("extends"), "{json}");
    }

    #[test]
    fn a_missing_base_or_a_cycle_names_file_line_and_field() {
        let dir = files(&[
            ("a.toml", "name = \"a\"\n\nextends = \"b.toml\"\n"),
            ("b.toml", "# b\nextends = \"a.toml\"\n"),
            ("c.toml", "name = \"c\"\nextends = \"nope.toml\"\n"),
        ]);
        let e = Campaign::load(&dir.path().join("a.toml")).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("extends"), "{e}");
        assert!(e.file.ends_with("b.toml") && e.line == Some(2), "{e}");
        assert!(e.message.contains("cycle"), "{e}");
        let e = Campaign::load(&dir.path().join("c.toml")).unwrap_err();
        assert!(e.to_string().contains("c.toml:2: field `extends`"), "{e}");
        assert!(e.message.contains("nope.toml"), "{e}");
    }

    #[test]
    fn errors_name_the_layer_that_wrote_the_field() {
        let base = format!("{}\n[exposure]\nmin_s = 2.0\nmax_s = 1.0\n", objects());
        let dir = files(&[
            ("base.toml", &base),
            ("leaf.toml", "extends = \"base.toml\"\nname = \"x\"\n"),
            (
                "typo.toml",
                "extends = \"base.toml\"\nname = \"x\"\n[sensor]\nwidth = 3\n",
            ),
        ]);
        // From the base: the base's line.
        let e = Campaign::load(&dir.path().join("leaf.toml")).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("exposure.max_s"));
        assert!(e.file.ends_with("base.toml") && e.line == Some(10), "{e}");
        // Fixed on the command line: fine; broken there: the `--set` is named.
        let leaf = dir.path().join("leaf.toml");
        let ok = ["exposure.max_s=4.0".to_string()];
        assert_eq!(
            Campaign::load_with_overrides(&leaf, &ok)
                .unwrap()
                .resolved
                .exposure
                .max_s,
            4.0
        );
        let bad = [
            "exposure.max_s=4".to_string(),
            "exposure.min_s=-1".to_string(),
        ];
        let e = Campaign::load_with_overrides(&leaf, &bad).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--set exposure.min_s=-1: field `exposure.min_s`"),
            "{e}"
        );
        // A parse error in a composed campaign: the file and line of the unknown key.
        let e = Campaign::load(&dir.path().join("typo.toml")).unwrap_err();
        assert!(e.file.ends_with("typo.toml") && e.line == Some(4), "{e}");
        assert!(e.message.contains("unknown field `width`"), "{e}");
        assert_eq!(e.field.as_deref(), Some("sensor.width"));
        let e = Campaign::load_with_overrides(&leaf, &["sensor.width=3".into()]).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("--set sensor.width=3: field `sensor.width`: unknown field `width`"),
            "{e}"
        );
    }

    #[test]
    fn set_values_are_toml_or_else_strings() {
        let dir = files(&[("c.toml", &format!("name = \"c\"\n{}", objects()))]);
        let path = dir.path().join("c.toml");
        let sets: Vec<String> = [
            "name=renamed",
            "images=12",
            "enhance.clahe_tiles=[4, 4]",
            "window.start=2022-02-01T00:00:00 UTC",
            "artifacts.fits=false",
        ]
        .map(String::from)
        .to_vec();
        let c = Campaign::load_with_overrides(&path, &sets).unwrap();
        assert_eq!(c.resolved.name, "renamed");
        assert_eq!(c.resolved.images, 12);
        assert_eq!(c.resolved.enhance.clahe_tiles, [4, 4]);
        assert_eq!(c.resolved.window.start, "2022-02-01T00:00:00 UTC");
        assert!(!c.resolved.artifacts.fits);
        for bad in ["images", "=3", "sensor..width_px=3", "extends=x.toml"] {
            let e = Campaign::load_with_overrides(&path, &[bad.to_string()]).unwrap_err();
            assert_eq!(e.file, Path::new(&format!("--set {bad}")), "{e}");
        }
    }
}
