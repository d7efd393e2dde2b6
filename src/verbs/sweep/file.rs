//! The experiment file: a base campaign, its axes (campaign fields by dotted path, each with a
//! list of values or a range, crossed as a grid or zipped), seed replicates, and the figures to
//! collect. `points` expands it and checks every point by loading its campaign through the
//! same `--set` machinery as `soig run`, so a field path or a value type is judged by the
//! campaign's own code, and refuses a malformed file with its file, line and field.

use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::campaign::{Campaign, CampaignError};

/// An experiment: sweeps over the fields of one base campaign.
#[derive(Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExperimentFile {
    /// The base campaign, relative to the experiment file.
    pub base: String,
    /// How the axes combine: every combination (`grid`), or the i-th values together (`zip`).
    #[serde(default)]
    pub mode: Mode,
    /// Replicates of every point, the campaign `seed` being the base's plus 0, 1, .. N-1.
    #[serde(default = "one")]
    pub seeds: u32,
    /// Fixed overrides of the base for every point, `key.path=value` as `soig run --set`
    /// writes them (applied before the axes).
    #[serde(default)]
    pub set: Vec<String>,
    /// The figures of the summary (default: mAP50-95 and recall).
    #[serde(default = "default_collect")]
    pub collect: Vec<Figure>,
    /// The swept campaign fields.
    #[serde(rename = "axis")]
    pub axes: Vec<Axis>,
}

fn one() -> u32 {
    1
}

fn default_collect() -> Vec<Figure> {
    vec![Figure::Map50_95, Figure::Recall]
}

#[derive(Debug, Default, Clone, Copy, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    #[default]
    Grid,
    Zip,
}

/// A figure of the summary. The detector metrics are those of the run's report, one column per
/// detector; `mag50` is the magnitude at which a detector's recall falls to 50% (its report's
/// detection efficiency; absent where the run's magnitudes never cross it); `objects` counts
/// the labelled debris of the test split; `seconds` is the run time (volatile: shown, but
/// outside the digest).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Figure {
    Map50,
    #[serde(rename = "map50_95")]
    Map50_95,
    Precision,
    Recall,
    CocoAp,
    Mag50,
    Objects,
    Seconds,
}

impl Figure {
    pub fn name(self) -> &'static str {
        match self {
            Figure::Map50 => "map50",
            Figure::Map50_95 => "map50_95",
            Figure::Precision => "precision",
            Figure::Recall => "recall",
            Figure::CocoAp => "coco_ap",
            Figure::Mag50 => "mag50",
            Figure::Objects => "objects",
            Figure::Seconds => "seconds",
        }
    }

    /// Whether the figure is one per detector.
    pub fn per_detector(self) -> bool {
        !matches!(self, Figure::Objects | Figure::Seconds)
    }
}

/// One swept field: `values`, or a range `from`..=`to` by `step` or in `count` values.
#[derive(Debug, Deserialize, Serialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// A campaign field by its dotted path, as `soig run --set` writes it.
    pub field: String,
    pub values: Option<Vec<serde_json::Value>>,
    pub from: Option<f64>,
    pub to: Option<f64>,
    pub step: Option<f64>,
    pub count: Option<u32>,
}

/// One parameter value of a point: the axis field and the value as `--set` writes it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Setting {
    pub field: String,
    pub value: String,
}

/// One run of the experiment: a point of the axes and a seed replicate.
#[derive(Debug)]
pub struct Point {
    pub settings: Vec<Setting>,
    /// Replicate index, 0-based.
    pub replicate: u32,
    /// The point's name, from its parameter values (and replicate): what the summary shows.
    pub name: String,
    /// The point's folder under `points/`: a hash of its values and replicate, so two values
    /// whose names read alike never share one (`points/<folder>.json` holds the values).
    pub folder: String,
    /// The point name without the replicate: replicates share it in the summary.
    pub group: String,
    pub campaign: Campaign,
}

/// A parsed experiment with every point checked.
#[derive(Debug)]
pub struct Experiment {
    pub file: ExperimentFile,
    pub source: PathBuf,
    pub points: Vec<Point>,
    /// The estimated work of every point, seconds of one core (`work`).
    pub seconds: f64,
    /// The file's text, for the lines of errors found after loading.
    text: String,
}

/// Most runs (points times seed replicates) an experiment may hold: each is a campaign loaded
/// and checked before anything runs, and a folder of its own.
pub const MAX_RUNS: u64 = 10_000;

/// Most values a range axis may hold.
const MAX_AXIS_VALUES: u64 = 10_000;

/// Whole numbers up to this are exact in a float: a range of integers beyond it would give
/// values that are not those asked for (or the same one twice).
const EXACT_INTEGERS: f64 = 9_007_199_254_740_992.0; // 2^53

impl Experiment {
    /// Read, check and expand an experiment file; nothing runs.
    pub fn load(path: &Path) -> Result<Experiment, CampaignError> {
        // A FIFO or a device would block or never end: a regular file of a sane size only.
        let text = crate::input_file::read_text(path).map_err(|e| {
            CampaignError::of_file(path, format!("cannot read experiment file: {e}"))
        })?;
        let file: ExperimentFile = toml::from_str(&text).map_err(|e| CampaignError {
            file: path.to_path_buf(),
            line: e.span().map(|s| text[..s.start].matches('\n').count() + 1),
            field: None,
            message: e.message().trim().to_string(),
        })?;
        let at = |axis: Option<usize>, key: &str, message: String| CampaignError {
            file: path.to_path_buf(),
            line: line_of(&text, axis, key),
            field: Some(match axis {
                Some(i) => format!("axis[{i}].{key}"),
                None => key.to_string(),
            }),
            message,
        };
        let columns = checked_columns(&file, &at)?;
        let base = dir_of(path).join(&file.base);
        let base_campaign = Campaign::load(&base)
            .map_err(|e| at(None, "base", format!("the base campaign is refused: {e}")))?;
        // A replicate's seed is written as a TOML integer, which stops at 2^63 - 1.
        if file.seeds > 1
            && base_campaign
                .resolved
                .seed
                .checked_add(u64::from(file.seeds) - 1)
                .is_none_or(|last| last > i64::MAX as u64)
        {
            return Err(at(
                None,
                "seeds",
                format!(
                    "the base seed {} plus {} replicates passes 2^63 - 1, the largest seed a campaign holds",
                    base_campaign.resolved.seed, file.seeds
                ),
            ));
        }
        let points = expand(&file, &columns, &base, base_campaign.resolved.seed, &at)?;
        let seconds = points
            .iter()
            .map(|p| {
                crate::work::image(&p.campaign).seconds * f64::from(p.campaign.resolved.images)
            })
            .sum();
        Ok(Experiment {
            file,
            source: path.to_path_buf(),
            points,
            seconds,
            text,
        })
    }

    /// Refuse an experiment whose points would take beyond `work::MAX_SECONDS` of one core,
    /// saying so, or one of whose points `work::check_run` refuses.
    pub fn check_work(&self) -> Result<(), CampaignError> {
        let key = if self.file.seeds > 1 { "seeds" } else { "axis" };
        if self.seconds > crate::work::MAX_SECONDS {
            return Err(CampaignError {
                file: self.source.clone(),
                line: line_of(&self.text, None, key),
                field: Some(key.into()),
                message: format!(
                    "{} runs would take up to about {} of one core, beyond the limit of {}: fewer points, replicates or images, or pass --force",
                    self.points.len(),
                    crate::work::duration(self.seconds),
                    crate::work::duration(crate::work::MAX_SECONDS)
                ),
            });
        }
        for p in &self.points {
            let images = u64::from(p.campaign.resolved.images);
            crate::work::check_run(&p.campaign, images, false).map_err(|e| CampaignError {
                file: self.source.clone(),
                line: line_of(&self.text, None, "axis"),
                field: Some("axis".into()),
                message: format!("point {}: {e}", p.name),
            })?;
        }
        Ok(())
    }
}

/// The folder of a point: the first 16 hex digits of the hash of its values and replicate.
fn point_folder(settings: &[Setting], replicate: u32) -> String {
    let h = crate::hash::hash_json(&(settings, replicate));
    h[..16].to_string()
}

/// The values of an axis as TOML text (`--set` syntax); an error names the key at fault.
fn axis_values(axis: &Axis) -> Result<Vec<String>, (&'static str, String)> {
    let range =
        axis.from.is_some() || axis.to.is_some() || axis.step.is_some() || axis.count.is_some();
    match (&axis.values, range) {
        (Some(_), true) => Err((
            "values",
            "give `values` or a range (`from`, `to`, `step` or `count`), not both".into(),
        )),
        (Some(values), false) => values
            .iter()
            .map(|v| {
                toml::Value::try_from(v)
                    .map(|t| t.to_string())
                    .map_err(|e| ("values", format!("not a TOML value: {e}")))
            })
            .collect(),
        (None, false) => Err((
            "values",
            "give `values` or a range `from`, `to`, `step` or `count`".into(),
        )),
        (None, true) => {
            let (Some(from), Some(to)) = (axis.from, axis.to) else {
                return Err(("from", "a range needs both `from` and `to`".into()));
            };
            let xs: Vec<f64> = match (axis.step, axis.count) {
                (Some(step), None) => {
                    if step.is_nan() || step <= 0.0 || !step.is_finite() {
                        return Err(("step", "must be a positive number".into()));
                    }
                    // A tolerance of a millionth of a step keeps `to` when rounding misses it.
                    let n = ((to - from) / step + 1e-6).floor();
                    if !(0.0..=MAX_AXIS_VALUES as f64).contains(&n) {
                        return Err(("to", "the range is empty or has over 10000 values".into()));
                    }
                    (0..=n as u64).map(|i| from + i as f64 * step).collect()
                }
                (None, Some(count)) => match count {
                    n if u64::from(n) > MAX_AXIS_VALUES => {
                        return Err((
                            "count",
                            format!("must be at most {MAX_AXIS_VALUES} values (got {n})"),
                        ));
                    }
                    0 => Vec::new(),
                    1 => vec![from],
                    n => (0..n)
                        .map(|i| from + (to - from) * i as f64 / (n - 1) as f64)
                        .collect(),
                },
                _ => {
                    return Err((
                        "step",
                        "a range needs exactly one of `step` and `count`".into(),
                    ));
                }
            };
            // Whole numbers are written as integers, so integer fields (`images`) take them.
            let integral = [Some(from), Some(to), axis.step]
                .iter()
                .flatten()
                .all(|x| x.fract() == 0.0)
                && xs.iter().all(|x| x.fract() == 0.0);
            // Beyond 2^53 a float range no longer steps by whole numbers (and beyond 2^63 an
            // integer is not TOML): list such values in `values`.
            if integral && xs.iter().any(|x| x.abs() > EXACT_INTEGERS) {
                return Err((
                    "to",
                    "a range of whole numbers beyond 2^53 is not exact: list the values in `values`".into(),
                ));
            }
            if xs.iter().any(|x| !x.is_finite()) {
                return Err(("to", "the range must stay finite".into()));
            }
            Ok(xs
                .iter()
                .map(|&x| {
                    if integral {
                        format!("{}", x as i64)
                    } else {
                        toml::Value::Float(x).to_string()
                    }
                })
                .collect())
        }
    }
}

/// The value indices of every point: the cross product (the last axis fastest), or zipped.
fn combinations(columns: &[Vec<String>], mode: Mode) -> Vec<Vec<usize>> {
    match mode {
        Mode::Zip => (0..columns[0].len())
            .map(|i| vec![i; columns.len()])
            .collect(),
        Mode::Grid => columns.iter().fold(vec![Vec::new()], |acc, c| {
            acc.iter()
                .flat_map(|prefix| {
                    (0..c.len()).map(move |i| {
                        let mut p = prefix.clone();
                        p.push(i);
                        p
                    })
                })
                .collect()
        }),
    }
}

/// A folder name from parameter values: `field=value` joined by commas, characters that are
/// awkward in a path replaced by `_`.
fn point_name(settings: &[Setting]) -> String {
    let raw: Vec<String> = settings
        .iter()
        .map(|s| format!("{}={}", s.field, s.value))
        .collect();
    raw.join(",")
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "=.,-_+".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The line of `key` in the file: in the `axis`-th `[[axis]]` table (its header when the key
/// is not written there), or at top level.
fn line_of(text: &str, axis: Option<usize>, key: &str) -> Option<usize> {
    let mut seen: Option<usize> = None;
    let mut header = None;
    for (n, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.starts_with('[') {
            seen = if t.starts_with("[[axis]]") {
                Some(seen.map_or(0, |s| s + 1))
            } else {
                Some(usize::MAX)
            };
            if seen == axis {
                header = Some(n + 1);
            }
            if axis.is_none() && key == "axis" && t.starts_with("[[axis]]") {
                return Some(n + 1);
            }
            continue;
        }
        let writes = t
            .strip_prefix(key)
            .is_some_and(|rest| rest.trim_start().starts_with('='));
        let here = match axis {
            None => seen.is_none(),
            Some(_) => seen == axis,
        };
        if writes && here {
            return Some(n + 1);
        }
    }
    header
}

fn dir_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// The error of a key of the experiment file, or of one axis' key, at its line.
type At<'a> = dyn Fn(Option<usize>, &str, String) -> CampaignError + 'a;

/// Each axis' values, checked: at least one axis and one seed, no axis empty or holding a value
/// twice, zip axes of equal length, a seed given once, and the runs within `MAX_RUNS`.
fn checked_columns(file: &ExperimentFile, at: &At) -> Result<Vec<Vec<String>>, CampaignError> {
    if file.axes.is_empty() {
        return Err(at(None, "axis", "give at least one [[axis]]".into()));
    }
    if file.seeds == 0 {
        return Err(at(None, "seeds", "must be at least 1".into()));
    }
    let mut columns = Vec::new();
    for (i, axis) in file.axes.iter().enumerate() {
        let values = axis_values(axis).map_err(|(key, m)| at(Some(i), key, m))?;
        if values.is_empty() {
            return Err(at(Some(i), "values", "the axis has no values".into()));
        }
        columns.push(values);
    }
    if file.mode == Mode::Zip
        && let Some(i) = columns.iter().position(|c| c.len() != columns[0].len())
    {
        return Err(at(
            Some(i),
            "values",
            format!(
                "mode = \"zip\" needs axes of equal length: axis[0] has {}, axis[{i}] has {}",
                columns[0].len(),
                columns[i].len()
            ),
        ));
    }
    for (i, values) in columns.iter().enumerate() {
        let mut seen = std::collections::HashSet::new();
        if let Some(v) = values.iter().find(|v| !seen.insert(*v)) {
            return Err(at(
                Some(i),
                "values",
                format!("holds {v} twice: each value is one point"),
            ));
        }
    }
    // Each replicate sets `seed`, which would silently replace a swept or fixed seed.
    if file.seeds > 1 {
        if let Some(i) = file.axes.iter().position(|a| a.field.trim() == "seed") {
            return Err(at(
                Some(i),
                "field",
                format!(
                    "a `seed` axis is replaced by the seed of each of the `seeds` = {} replicates: sweep `seed` or give `seeds`, not both",
                    file.seeds
                ),
            ));
        }
        if file
            .set
            .iter()
            .any(|s| s.split('=').next().map(str::trim) == Some("seed"))
        {
            return Err(at(
                None,
                "set",
                format!(
                    "`seed` is replaced by the seed of each of the `seeds` = {} replicates: set one or the other",
                    file.seeds
                ),
            ));
        }
    }
    let points_count = match file.mode {
        Mode::Zip => columns[0].len() as u64,
        Mode::Grid => columns
            .iter()
            .try_fold(1u64, |n, c| n.checked_mul(c.len() as u64))
            .unwrap_or(u64::MAX),
    };
    let runs = points_count.saturating_mul(u64::from(file.seeds));
    if runs > MAX_RUNS {
        let (axis, key) = if file.seeds > 1 {
            (None, "seeds")
        } else {
            (None, "axis")
        };
        return Err(at(
            axis,
            key,
            format!(
                "{points_count} point(s) times {} seed replicate(s) is {runs} runs, beyond the limit of {MAX_RUNS}: fewer values or replicates, or several experiments",
                file.seeds
            ),
        ));
    }
    Ok(columns)
}

/// The experiment's points: each combination of the axes' values (`columns`) for each seed
/// replicate, its campaign the base campaign with the file's `set` and the point's values.
fn expand(
    file: &ExperimentFile,
    columns: &[Vec<String>],
    base: &Path,
    base_seed: u64,
    at: &At,
) -> Result<Vec<Point>, CampaignError> {
    let mut points = Vec::new();
    for combo in combinations(columns, file.mode) {
        let settings: Vec<Setting> = combo
            .iter()
            .enumerate()
            .map(|(a, &v)| Setting {
                field: file.axes[a].field.clone(),
                value: columns[a][v].clone(),
            })
            .collect();
        let group = point_name(&settings);
        for replicate in 0..file.seeds {
            let mut sets = file.set.clone();
            sets.extend(settings.iter().map(|s| format!("{}={}", s.field, s.value)));
            let mut name = group.clone();
            if file.seeds > 1 {
                sets.push(format!("seed={}", base_seed + replicate as u64));
                name = format!("{group},rep={replicate}");
            }
            let campaign = Campaign::load_with_overrides(base, &sets).map_err(|e| {
                let label = e.file.to_string_lossy();
                if file.set.iter().any(|s| label == format!("--set {s}")) {
                    return at(None, "set", format!("refused by the campaign: {e}"));
                }
                // The axis whose value the campaign refused answers for it.
                let a = settings
                    .iter()
                    .position(|s| {
                        e.file
                            .to_string_lossy()
                            .contains(&format!("--set {}=", s.field))
                    })
                    .or_else(|| {
                        e.field
                            .as_ref()
                            .and_then(|f| settings.iter().position(|s| f.starts_with(&s.field)))
                    })
                    .unwrap_or(0);
                // An unknown path is the `field`'s fault, anything else the value's.
                let key = if e.message.contains("unknown field") {
                    "field"
                } else {
                    "values"
                };
                at(
                    Some(a),
                    key,
                    format!(
                        "`{}` = {} is refused by the campaign: {e}",
                        settings[a].field, settings[a].value
                    ),
                )
            })?;
            points.push(Point {
                folder: point_folder(&settings, replicate),
                settings: settings.clone(),
                replicate,
                name,
                group: group.clone(),
                campaign,
            });
        }
    }
    Ok(points)
}
