//! The experiment's tables and plots: one row per point (its replicates pooled: mean and
//! sample standard deviation), and each collected figure against each numeric axis, one line
//! per combination of the other axes, with error bars of one standard deviation.

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;

use super::file::{Experiment, Figure};
use super::run::Outcome;
use crate::store;

/// A point of the summary: the replicates of one set of parameter values.
pub struct Row {
    pub values: Vec<String>,
    /// Replicates that succeeded.
    pub n: usize,
    /// Per column: (mean, standard deviation), None when no replicate has it.
    pub stats: Vec<Option<(f64, f64)>>,
}

/// The summary: its columns (figure, or figure/detector) and rows.
pub struct Summary {
    pub fields: Vec<String>,
    pub columns: Vec<String>,
    pub rows: Vec<Row>,
}

impl Summary {
    pub fn new(experiment: &Experiment, outcomes: &[Outcome]) -> Summary {
        let fields: Vec<String> = experiment
            .file
            .axes
            .iter()
            .map(|a| a.field.clone())
            .collect();
        let mut columns: Vec<String> = Vec::new();
        for f in &experiment.file.collect {
            let matching = outcomes.iter().flat_map(|o| o.figures.keys()).filter(|k| {
                if f.per_detector() {
                    k.starts_with(&format!("{}/", f.name()))
                } else {
                    k.as_str() == f.name()
                }
            });
            for k in matching {
                if !columns.contains(k) {
                    columns.push(k.clone());
                }
            }
        }
        let mut groups: Vec<&str> = Vec::new();
        for o in outcomes {
            if !groups.contains(&o.group.as_str()) {
                groups.push(&o.group);
            }
        }
        let rows = groups
            .iter()
            .map(|g| {
                let reps: Vec<&Outcome> = outcomes
                    .iter()
                    .filter(|o| o.group == *g && o.error.is_none())
                    .collect();
                let first = outcomes
                    .iter()
                    .find(|o| o.group == *g)
                    .expect("a group has outcomes");
                Row {
                    values: first.settings.iter().map(|s| s.value.clone()).collect(),
                    n: reps.len(),
                    stats: columns
                        .iter()
                        .map(|c| {
                            let xs: Vec<f64> = reps
                                .iter()
                                .filter_map(|o| o.figures.get(c).copied())
                                .collect();
                            mean_sd(&xs)
                        })
                        .collect(),
                }
            })
            .collect();
        Summary {
            fields,
            columns,
            rows,
        }
    }

    pub fn write_csv(&self, path: &Path) -> anyhow::Result<()> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut header: Vec<String> = self.fields.clone();
        header.push("replicates".into());
        for c in &self.columns {
            header.push(format!("{c}_mean"));
            header.push(format!("{c}_sd"));
        }
        w.write_record(&header)?;
        for r in &self.rows {
            let mut rec = r.values.clone();
            rec.push(r.n.to_string());
            for s in &r.stats {
                match s {
                    Some((m, sd)) => {
                        rec.push(format!("{m:.4}"));
                        rec.push(format!("{sd:.4}"));
                    }
                    None => rec.extend([String::new(), String::new()]),
                }
            }
            w.write_record(&rec)?;
        }
        store::fs::write(path, w.into_inner().map_err(|e| e.into_error())?)
    }

    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let mut header: Vec<String> = self.fields.iter().map(|f| format!("`{f}`")).collect();
        header.push("replicates".into());
        header.extend(self.columns.iter().cloned());
        let _ = writeln!(s, "| {} |", header.join(" | "));
        let _ = writeln!(s, "|{}", "---|".repeat(header.len()));
        for r in &self.rows {
            let mut cells = r.values.clone();
            cells.push(r.n.to_string());
            for st in &r.stats {
                cells.push(match st {
                    Some((m, sd)) => format!("{m:.3} ± {sd:.3}"),
                    None => "-".into(),
                });
            }
            let _ = writeln!(s, "| {} |", cells.join(" | "));
        }
        s
    }

    /// One plot per column and numeric axis, `<column>-vs-<field>.png` in `dir`; the files.
    pub fn plots(&self, dir: &Path) -> anyhow::Result<Vec<String>> {
        // Plots of an earlier run of a different experiment must not linger.
        if dir.is_dir() {
            store::fs::remove_dir_all(dir)?;
        }
        store::fs::create_dir_all(dir)?;
        let mut files = Vec::new();
        for (a, field) in self.fields.iter().enumerate() {
            let xs: Option<Vec<f64>> = self.rows.iter().map(|r| r.values[a].parse().ok()).collect();
            // A numeric axis with at least two values: anything else makes no curve.
            let Some(xs) = xs else { continue };
            if xs.iter().all(|x| *x == xs[0]) {
                continue;
            }
            for (c, column) in self.columns.iter().enumerate() {
                let name = format!("{}-vs-{field}.png", column.replace('/', "-"));
                if self.plot(&dir.join(&name), a, &xs, c)? {
                    files.push(name);
                }
            }
        }
        Ok(files)
    }

    /// Column `c` against axis `a` (values `xs`); false when there is nothing to draw.
    fn plot(&self, path: &Path, a: usize, xs: &[f64], c: usize) -> anyhow::Result<bool> {
        // Series: the rows sharing the values of every other axis.
        let mut series: Vec<(String, Vec<Bar>)> = Vec::new();
        for (r, x) in self.rows.iter().zip(xs) {
            let Some((m, sd)) = r.stats[c] else { continue };
            let label: Vec<String> = self
                .fields
                .iter()
                .zip(&r.values)
                .enumerate()
                .filter(|(i, _)| *i != a)
                .map(|(_, (f, v))| format!("{f}={v}"))
                .collect();
            let label = label.join(", ");
            match series.iter_mut().find(|s| s.0 == label) {
                Some(s) => s.1.push((*x, m, sd)),
                None => series.push((label, vec![(*x, m, sd)])),
            }
        }
        if series.is_empty() {
            return Ok(false);
        }
        let all: Vec<&(f64, f64, f64)> = series.iter().flat_map(|s| &s.1).collect();
        let (x0, x1) = pad(all.iter().map(|p| p.0));
        let (y0, y1) = pad(all.iter().flat_map(|p| [p.1 - p.2, p.1 + p.2]));
        let (field, column) = (&self.fields[a], &self.columns[c]);
        crate::plot::png(path, (720, 480), |root| {
            let mut chart = ChartBuilder::on(root)
                .caption(format!("{column} against {field}"), ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(x0..x1, y0..y1)?;
            chart
                .configure_mesh()
                .x_desc(field.as_str())
                .y_desc(format!("{column} (mean ± sd over seeds)"))
                .draw()?;
            for (k, (label, pts)) in series.iter().enumerate() {
                let color = Palette99::pick(k).to_rgba();
                let mut pts = pts.clone();
                pts.sort_by(|p, q| p.0.total_cmp(&q.0));
                let line = chart.draw_series(LineSeries::new(
                    pts.iter().map(|p| (p.0, p.1)),
                    color.stroke_width(2),
                ))?;
                if !label.is_empty() {
                    line.label(label.clone()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                    });
                }
                // Error bars as lines from mean - sd to mean + sd (plotters' ErrorBar needs a
                // feature the crate is built without), the mean marked by a dot.
                chart.draw_series(pts.iter().map(|p| {
                    PathElement::new(
                        vec![(p.0, p.1 - p.2), (p.0, p.1 + p.2)],
                        color.stroke_width(2),
                    )
                }))?;
                chart.draw_series(
                    pts.iter()
                        .map(|p| Circle::new((p.0, p.1), 4, color.filled())),
                )?;
            }
            if series.len() > 1 {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .draw()?;
            }
            Ok(())
        })?;
        Ok(true)
    }
}

/// A plotted point: axis value, mean, standard deviation.
type Bar = (f64, f64, f64);

/// Mean and sample standard deviation (0 for one value).
fn mean_sd(xs: &[f64]) -> Option<(f64, f64)> {
    if xs.is_empty() {
        return None;
    }
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let sd = if xs.len() > 1 {
        (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    Some((mean, sd))
}

/// A range around the values with 5% room (or ±1 around a single value).
fn pad(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
        (l.min(x), h.max(x))
    });
    let room = if hi > lo { 0.05 * (hi - lo) } else { 1.0 };
    (lo - room, hi + room)
}

/// Figures that are collected though no point produced them (e.g. a metric without a detect
/// stage): said in the summary so an empty column is not a silent surprise.
pub fn missing(experiment: &Experiment, summary: &Summary) -> Vec<&'static str> {
    experiment
        .file
        .collect
        .iter()
        .filter(|f: &&Figure| {
            !summary
                .columns
                .iter()
                .any(|c| c == f.name() || c.starts_with(&format!("{}/", f.name())))
        })
        .map(|f| f.name())
        .collect()
}
