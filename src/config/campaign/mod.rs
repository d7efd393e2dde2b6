//! The campaign: its TOML file (`file`, with the paper's `defaults`), composed from a chain of
//! `extends` and `--set` overrides (`compose`), checked (`validate`) with errors that name file,
//! line (`lines`) and field, and resolved (`resolve`) into the campaign whose hash pins every
//! output.
//!
//! All paths inside a campaign are relative to the directory of the campaign file that is
//! loaded, also those a base file supplies (`extends` itself is relative to the file writing it).

mod breakup;
mod compose;
pub mod defaults;
mod file;
mod ground;
mod lines;
mod noise;
mod resolve;
mod validate;

use std::path::{Path, PathBuf};

pub use breakup::{Breakup, BreakupKind, MAX_FRAGMENTS, ParentType};
pub use file::*;
pub use ground::SiteSpec;
pub use noise::{Noise, PhysicalNoise};
pub use resolve::{MAX_SURVEY_DRIFT_DEG, World, parse_epoch};
pub use validate::MAX_OBJECTS_PER_FRAME;

pub use crate::geometry::FrameKind;
pub use crate::render::RenderMethod;
pub use crate::scene::{Body, PointingMode, SnrDefinition};
pub use soig_sim::observer::{GroundGate, Observer};

use crate::hash::hash_json;
use compose::Layers;

/// A user error in a campaign: which file, where, which field, what is allowed. For a
/// command-line override the "file" is the `--set key=value` itself.
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {}{}", file.display(), line.map(|l| format!(":{l}")).unwrap_or_default(), field.as_ref().map(|f| format!("field `{f}`: ")).unwrap_or_default(), message)]
pub struct CampaignError {
    pub file: PathBuf,
    pub line: Option<usize>,
    pub field: Option<String>,
    pub message: String,
}

impl CampaignError {
    /// An error of the whole file (it cannot be read, or is not what it should be): no line,
    /// no field.
    pub fn of_file(file: impl Into<PathBuf>, message: String) -> CampaignError {
        CampaignError {
            file: file.into(),
            line: None,
            field: None,
            message,
        }
    }
}

/// A validated campaign with every default filled in, files read, and its hash.
#[derive(Debug)]
pub struct Campaign {
    /// The campaign with defaults filled and TLE files replaced by their lines: what the hash covers.
    pub resolved: CampaignFile,
    /// sha256 of the canonical JSON of `resolved` (without `output`).
    pub hash: String,
    /// The bodies, ground site and window the scenes are drawn from.
    pub world: World,
    /// Where outputs go.
    pub output_dir: PathBuf,
    /// Directory of the campaign file, for relative paths.
    pub base_dir: PathBuf,
    /// The campaign file (or the name given to campaign text built in code), for messages.
    pub source: PathBuf,
    /// Where each of `RUN_FIELDS`, `WORK_FIELDS` and each `debris[i]` was written (file,
    /// line), for errors found only when the campaign runs (`Campaign::error_at`).
    run_fields: Vec<(String, PathBuf, Option<usize>)>,
}

/// The fields naming files that are read only when a campaign runs (frames, model, catalogue).
const RUN_FIELDS: [&str; 3] = ["background.paths", "detect.model", "stars.path"];

/// The fields a refused estimate of the work names (`work`).
const WORK_FIELDS: [&str; 2] = ["sensor.zero_point_mag", "images"];

impl Campaign {
    /// The files a run reads besides the campaign and its TLE files (whose lines the campaign
    /// hash covers): background frames, the star catalogue and the model, each with its field
    /// and its path as the campaign writes it.
    pub fn input_files(&self) -> Vec<(String, String)> {
        let c = &self.resolved;
        let mut files = Vec::new();
        if let Background::Frames { paths, .. } = &c.background {
            for (i, p) in paths.iter().enumerate() {
                files.push((format!("background.paths[{i}]"), p.clone()));
            }
        }
        if let Stars::Catalog { path, .. } = &c.stars {
            files.push(("stars.path".into(), path.clone()));
        }
        if let Some(m) = &c.detect.model {
            files.push(("detect.model".into(), m.clone()));
        }
        files
    }

    /// The real paths of [`Campaign::input_files`], of the starting weights of training (a
    /// `.pt` `train.model`) and of the campaign file: what an output may not be or contain.
    pub fn input_paths(&self) -> Vec<PathBuf> {
        let mut paths: Vec<PathBuf> = self
            .input_files()
            .into_iter()
            .map(|(_, p)| self.base_dir.join(p))
            .collect();
        if let Some(pt) = self.start_weights() {
            paths.push(pt);
        }
        paths.push(self.source.clone());
        paths
    }

    /// The weights training starts from (`train.model` ending in `.pt`, relative to the
    /// campaign file); None for an architecture that trains from scratch.
    pub fn start_weights(&self) -> Option<PathBuf> {
        let m = &self.resolved.train.model;
        m.ends_with(".pt").then(|| self.base_dir.join(m))
    }

    /// sha256 of each of [`Campaign::input_files`], by path as written: what identifies the
    /// run's inputs by content (`Manifest::inputs`).
    pub fn input_hashes(
        &self,
    ) -> Result<std::collections::BTreeMap<String, String>, CampaignError> {
        let mut hashes = std::collections::BTreeMap::new();
        for (field, p) in self.input_files() {
            let full = self.base_dir.join(&p);
            let (sha, _) = crate::hash::sha256_file(&full).map_err(|e| {
                let base = field.split('[').next().unwrap_or(&field);
                self.error_at(
                    base,
                    format!("{field}: cannot read {}: {e}", full.display()),
                )
            })?;
            hashes.insert(p, sha);
        }
        Ok(hashes)
    }

    /// Read, parse, validate and resolve a campaign file (and the files it `extends`).
    pub fn load(path: &Path) -> Result<Campaign, CampaignError> {
        Campaign::load_with_overrides(path, &[])
    }

    /// `load`, with `key.path=value` overrides applied on top, in order (`soig run --set`).
    pub fn load_with_overrides(
        path: &Path,
        overrides: &[String],
    ) -> Result<Campaign, CampaignError> {
        let text = crate::input_file::read_text(path)
            .map_err(|why| CampaignError::of_file(path, format!("campaign file: {why}")))?;
        Campaign::compose(&text, path, overrides)
    }

    /// Parse and validate campaign text, e.g. built in code; `path` names it in messages, and
    /// its directory is where relative paths (`extends`, TLE files, frames) are read from.
    ///
    /// ```
    /// use std::path::Path;
    /// use soig::campaign::Campaign;
    ///
    /// let orbit = "elements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";
    /// let text = format!(
    ///     "name = \"demo\"\nimages = 10\n[observer]\nnorad = 1\n{orbit}\n[[debris]]\nnorad = 40649\n{orbit}\n"
    /// );
    /// let c = Campaign::from_toml(&text, Path::new("demo.toml")).unwrap();
    /// assert_eq!(c.resolved.images, 10);
    /// assert_eq!(c.resolved.sensor.width_px, 1024); // the paper's value
    /// assert_eq!(c.world.debris[0].name, "NORAD 40649");
    /// ```
    pub fn from_toml(text: &str, path: &Path) -> Result<Campaign, CampaignError> {
        Campaign::compose(text, path, &[])
    }

    /// `from_toml`, with `key.path=value` overrides applied on top, in order, as `--set` does:
    /// the Python bindings keep a campaign as (text, path, overrides).
    pub fn from_toml_with_overrides(
        text: &str,
        path: &Path,
        overrides: &[String],
    ) -> Result<Campaign, CampaignError> {
        Campaign::compose(text, path, overrides)
    }

    fn compose(text: &str, path: &Path, overrides: &[String]) -> Result<Campaign, CampaignError> {
        let layers = Layers::read(text, path, overrides)?;
        let file = layers.parse()?;
        let base_dir = dir_of(path);
        validate::validate(&file).map_err(|(field, msg)| layers.error(&field, msg))?;
        let (mut resolved, world) =
            resolve::resolve(&file, &base_dir).map_err(|(field, msg)| layers.error(&field, msg))?;
        let output_dir = match &file.output {
            Some(o) => base_dir.join(o),
            None => base_dir.join("runs").join(&file.name),
        };
        resolved.output = None;
        let hash = hash_json(&resolved);
        Ok(Campaign {
            resolved,
            hash,
            world,
            output_dir,
            base_dir,
            source: path.to_path_buf(),
            run_fields: RUN_FIELDS
                .iter()
                .chain(&WORK_FIELDS)
                .map(|f| f.to_string())
                .chain((0..file.debris.len()).map(|i| format!("debris[{i}]")))
                .map(|f| {
                    let e = layers.error(&f, String::new());
                    (f, e.file, e.line)
                })
                .collect(),
        })
    }

    /// An error found while running about `field` (`background.paths`, `detect.model`,
    /// `stars.path`, `sensor.zero_point_mag`, `images` or `debris[i]`), at the file and line
    /// that wrote it.
    pub fn error_at(&self, field: &str, message: String) -> CampaignError {
        let (file, line) = self
            .run_fields
            .iter()
            .find(|(f, _, _)| *f == field)
            .map_or((self.source.clone(), None), |(_, file, line)| {
                (file.clone(), *line)
            });
        CampaignError {
            file,
            line,
            field: Some(field.to_string()),
            message,
        }
    }

    /// The campaign whose resolved form (`resolved`, as a manifest records it) is given, its
    /// relative paths (model, frames) read from `base_dir`: `soig merge` rebuilds a shard's
    /// campaign this way. Resolving a resolved campaign changes nothing, so the hash is the
    /// original's; the caller compares it.
    pub fn from_resolved(
        resolved: &serde_json::Value,
        base_dir: &Path,
    ) -> Result<Campaign, CampaignError> {
        let source = base_dir.join("(resolved campaign of a manifest)");
        let fail = |message: String| CampaignError::of_file(&source, message);
        let file: CampaignFile = serde_json::from_value(resolved.clone())
            .map_err(|e| fail(format!("not a campaign of this soig version: {e}")))?;
        let text = toml::to_string(&file).map_err(|e| fail(format!("cannot write it: {e}")))?;
        Campaign::compose(&text, &source, &[])
    }

    /// The signal-to-noise gate for this campaign's pointing mode.
    pub fn snr_min(&self) -> f64 {
        self.resolved
            .visibility
            .snr_min
            .unwrap_or(match self.resolved.pointing.mode {
                PointingMode::Fixed => defaults::snr_fixed(),
                PointingMode::Survey => defaults::snr_survey(),
                // The debris is a point, as a fixed-pointing streak seen end-on.
                PointingMode::Track => defaults::snr_fixed(),
            })
    }
}

/// The directory of a campaign file (`.` for a bare file name).
fn dir_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// The JSON Schema of the campaign format, generated from the Rust types.
pub fn schema_json() -> String {
    let schema = schemars::schema_for!(CampaignFile);
    serde_json::to_string_pretty(&schema).expect("schema serialises")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<Campaign, CampaignError> {
        Campaign::from_toml(text, Path::new("/nowhere/c.toml"))
    }

    const ELEMENTS: &str = "elements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";

    fn minimal(extra: &str) -> String {
        format!(
            "name = \"t\"\n[observer]\nnorad = 1\n{ELEMENTS}\n[[debris]]\nnorad = 40649\n{ELEMENTS}\n{extra}"
        )
    }

    #[test]
    fn a_resolved_campaign_resolves_to_itself() {
        let tle = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/campaigns/data/catalog-2022-01-22.tle"
        );
        let text = format!(
            "name = \"t\"\nseed = 3\n[observer]\ntle_file = \"{tle}\"\nnorad = 41335\n[[debris]]\nnorad = 40649\n{ELEMENTS}\n[sensor]\nwidth_px = 256\n[detect.streak]\nmin_snr = 4.0\n"
        );
        let c = load(&text).unwrap();
        let json = serde_json::to_value(&c.resolved).unwrap();
        let again = Campaign::from_resolved(&json, Path::new("/elsewhere")).unwrap();
        assert_eq!(again.hash, c.hash);
        assert_eq!(again.base_dir, Path::new("/elsewhere"));
    }

    #[test]
    fn a_photometry_preset_refuses_the_fields_it_sets_and_keeps_paper_hashes() {
        let e = load(&minimal(
            "[photometry]\npreset = \"nasa-fragments\"\nalbedo = 0.5\n",
        ))
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("photometry.albedo") && e.contains("preset"),
            "{e}"
        );
        let preset = load(&minimal("[photometry]\npreset = \"nasa-fragments\"\n")).unwrap();
        assert_eq!(
            preset.resolved.photometry.preset,
            PhotometryPreset::NasaFragments
        );
        // `paper`, written or not, is the same campaign as before presets existed.
        let paper = load(&minimal("[photometry]\npreset = \"paper\"\n")).unwrap();
        assert_eq!(paper.hash, load(&minimal("")).unwrap().hash);
        assert_ne!(preset.hash, paper.hash);
    }

    #[test]
    fn defaults_are_the_papers() {
        let c = load(&minimal("")).unwrap();
        let r = &c.resolved;
        assert_eq!(r.images, 4000);
        assert_eq!((r.sensor.width_px, r.sensor.height_px), (1024, 1024));
        assert_eq!(r.sensor.fov_radius_deg, 0.1);
        assert_eq!(r.sensor.zero_point_mag, 22.26);
        assert_eq!(r.sensor.gain_e_per_adu, 1.6);
        assert_eq!((r.exposure.min_s, r.exposure.max_s), (2.0, 8.0));
        assert_eq!(r.stars.cone_radius_deg(), 0.15);
        assert_eq!(r.render.trajectory_samples, 2000);
        assert_eq!((r.split.train, r.split.val, r.split.test), (0.7, 0.2, 0.1));
        assert_eq!(c.snr_min(), 0.15);
        assert_eq!(
            c.resolved.debris[0]
                .elements
                .as_ref()
                .unwrap()
                .epoch
                .as_deref(),
            Some("2022-01-01T00:00:00 UTC")
        );
        // The hash ignores the output directory but not the physics.
        let other_out = load(&minimal("")).unwrap();
        assert_eq!(c.hash, other_out.hash);
        let with_out = load(&format!("output = \"x\"\n{}", minimal(""))).unwrap();
        assert_eq!(c.hash, with_out.hash);
        let other = load(&minimal("[sensor]\ngain_e_per_adu = 2.0\n")).unwrap();
        assert_ne!(c.hash, other.hash);
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let e = load(&minimal("[exposure]\nmin_s = 2.0\nmax_s = -3.0\n")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("/nowhere/c.toml:"), "{msg}");
        assert_eq!(e.field.as_deref(), Some("exposure.max_s"));
        assert_eq!(e.line, Some(10), "{msg}");

        let e = load(&minimal("[sensor]\nwidth = 3\n")).unwrap_err();
        assert_eq!(e.line, Some(9), "{e}");
        assert!(e.to_string().contains("unknown field `width`"), "{e}");

        let e = load(&minimal("[split]\ntest = 0.3\n")).unwrap_err();
        assert!(e.to_string().contains("sum to 1"), "{e}");
        assert_eq!(e.line, Some(8), "{e}");

        let e = load(&minimal("[window]\nstart = \"2022-13-01T00:00:00 UTC\"\n")).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("window.start"));

        let e = load(&minimal("[enhance]\ngeometry = \"rotated\"\n")).unwrap_err();
        assert!(
            e.to_string().contains("needs survey or track pointing"),
            "{e}"
        );
        assert!(
            load(&minimal(
                "[pointing]\nmode = \"survey\"\n[enhance]\ngeometry = \"rotated\"\n"
            ))
            .is_ok()
        );

        let e = load("name = \"t\"\n[observer]\nnorad = 1\n[[debris]]\nnorad = 2\n").unwrap_err();
        assert_eq!(e.field.as_deref(), Some("observer"));
        assert!(e.to_string().contains("exactly one of"), "{e}");

        // A survey exposure so long that the camera would turn by degrees is refused.
        let e = load(&minimal(
            "[pointing]\nmode = \"survey\"\n[exposure]\nmax_s = 600.0\n",
        ))
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("exposure.max_s"), "{e}");
        assert!(e.to_string().contains("drift"), "{e}");

        let e = load(&minimal("[stages]\n")).unwrap_err();
        assert!(e.line.is_some(), "{e}");
    }

    /// One object named twice in `debris` is refused at the second entry's line, unless the
    /// campaign asks for it; the opt-in stays out of the hash when off.
    #[test]
    fn placed_duplicates_are_refused_unless_asked_for() {
        let twice = format!("[[debris]]\nname = \"again\"\nnorad = 40649\n{ELEMENTS}\n");
        let e = load(&minimal(&twice)).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("debris[1].norad"), "{e}");
        // minimal's 7 lines, then `[[debris]]`, `name`, `norad` on line 10.
        assert_eq!(e.line, Some(10), "{e}");
        let msg = e.to_string();
        assert!(
            msg.starts_with("/nowhere/c.toml:10: field `debris[1].norad`"),
            "{msg}"
        );
        assert!(msg.contains("NORAD 40649 is already debris[0]"), "{msg}");
        let asked = format!("allow_duplicates = true\n{}", minimal(&twice));
        let c = load(&asked).unwrap();
        assert_eq!(c.world.debris.len(), 2);
        assert!(c.resolved.allow_duplicates);
        let off = load(&minimal("")).unwrap();
        let json = serde_json::to_value(&off.resolved).unwrap();
        assert!(json.get("allow_duplicates").is_none());
    }

    #[test]
    fn run_away_sensors_and_star_budgets_are_refused() {
        for (extra, field) in [
            (
                "[sensor]\nzero_point_mag = 1e300\n",
                "sensor.zero_point_mag",
            ),
            (
                "[sensor]\ngain_e_per_adu = 1e-300\n",
                "sensor.gain_e_per_adu",
            ),
            (
                "[sensor]\nmag_limit = 30.0\n[stars]\nsource = \"procedural\"\ncone_radius_deg = 10.0\n",
                "sensor.mag_limit",
            ),
        ] {
            let e = load(&minimal(extra)).unwrap_err();
            assert_eq!(e.field.as_deref(), Some(field), "{e}");
            assert!(e.line.is_some(), "{e}");
        }
        // The paper's sensor and a deep but small cone pass.
        load(&minimal("[sensor]\nmag_limit = 20.0\n")).unwrap();
    }

    #[test]
    fn streak_detector_knobs_are_optional_and_checked() {
        let c = load(&minimal(
            "[detect.streak]\nthreshold_sigma = 3.5\nmin_snr = 7.0\n",
        ))
        .unwrap();
        let s = &c.resolved.detect.streak;
        assert_eq!((s.threshold_sigma, s.min_snr), (3.5, 7.0));
        assert_eq!(
            s.n_angles,
            crate::detect::streak::StreakParams::default().n_angles
        );
        // Left at the defaults the table is not in the resolved campaign: hashes do not move.
        let plain = load(&minimal("")).unwrap();
        let json = serde_json::to_value(&plain.resolved).unwrap();
        assert!(json["detect"].get("streak").is_none(), "{json}");
        let same = load(&minimal("[detect.streak]\nthreshold_sigma = 3.0\n")).unwrap();
        assert_eq!(same.hash, plain.hash);
        assert_ne!(c.hash, plain.hash);

        let e = load(&minimal(
            "[detect]\nclassical = true\n[detect.streak]\nmin_snr = 5.0\nthreshold_sigma = nan\n",
        ))
        .unwrap_err();
        assert_eq!(
            e.field.as_deref(),
            Some("detect.streak.threshold_sigma"),
            "{e}"
        );
        assert_eq!(e.line, Some(12), "{e}");
        assert!(
            e.to_string().starts_with(
                "/nowhere/c.toml:12: field `detect.streak.threshold_sigma`: must be a finite number"
            ),
            "{e}"
        );
        let e = load(&minimal("[detect.streak]\nn_angles = 0\n")).unwrap_err();
        assert_eq!(e.field.as_deref(), Some("detect.streak.n_angles"), "{e}");
        let e = load(&minimal("[detect.streak]\nthreshold = 3.0\n")).unwrap_err();
        assert!(e.to_string().contains("unknown field `threshold`"), "{e}");
        assert_eq!(e.line, Some(9), "{e}");
    }

    #[test]
    fn stages_are_a_prefix_with_an_optional_train_stage() {
        let with =
            |stages: &str, extra: &str| load(&format!("stages = [{stages}]\n{}", minimal(extra)));
        let classical = "[detect]\nclassical = true\n";
        for ok in [
            r#""render""#,
            r#""render", "enhance", "dataset""#,
            r#""render", "enhance", "dataset", "train""#,
            r#""render", "enhance", "dataset", "train", "detect""#,
        ] {
            assert!(with(ok, "").is_ok(), "{ok}: {:?}", with(ok, "").err());
        }
        assert!(with(r#""render", "enhance", "dataset", "detect""#, classical).is_ok());
        for bad in [
            r#""enhance""#,
            r#""render", "render""#,
            r#""render", "enhance", "train""#,
            r#""render", "enhance", "dataset", "detect", "train""#,
            r#""render", "enhance", "dataset", "train", "train""#,
        ] {
            let e = with(bad, classical).unwrap_err();
            assert_eq!(e.field.as_deref(), Some("stages"), "{bad}: {e}");
        }
        // A train stage detects with the model it trains, not a second one.
        let e = with(
            r#""render", "enhance", "dataset", "train", "detect""#,
            "[detect]\nmodel = \"m.onnx\"\n",
        )
        .unwrap_err();
        assert_eq!(e.field.as_deref(), Some("detect.model"), "{e}");
    }
}
