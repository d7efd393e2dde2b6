//! The metrics `soig compare` holds a run to, and how far each may fall.
//!
//! The default, 0.002 for every metric, is a claim about what changes a metric between two
//! honest runs of one campaign. The images and the streak detector are bit-identical on any
//! machine (one stream per purpose, no float reduction whose order depends on the CPU); YOLO is
//! not: ONNX Runtime picks its GEMM and convolution kernels by CPU, which moves a box edge by up
//! to 1.4e-3 px and a score by up to 3e-6 (measured, `tests/yolo.rs`). Through IoU and the
//! confidence ranking that moves a metric continuously by ~1e-5, 200 times below 0.002; it can
//! also flip one match that sits within 1e-5 of an IoU threshold, which costs mAP50-95 one
//! threshold of one object, 1/(10 N) (2.5e-4 on the paper's N = 400 test images), still below
//! 0.002. What 0.002 does not let through is one detection lost or gained outright: 1/N, at
//! least 0.0025 on test sets up to the paper's 400 objects. Smaller test sets (the quickstart's
//! 6) make any real change far larger than the default, so it never hides one.

use std::collections::BTreeMap;

use anyhow::{Context, bail};

use crate::report::DetectorMetrics;

/// The default allowed fall of every metric (see the module docs).
pub const DEFAULT: f64 = 0.002;

/// A metric of `report.json`, by its `--tolerance` name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Metric {
    Precision,
    Recall,
    Map50,
    Map50To95,
    CocoAp,
    CocoAp50,
    PrecisionAtConf,
    RecallAtConf,
}

impl Metric {
    pub const ALL: [Metric; 8] = [
        Metric::Precision,
        Metric::Recall,
        Metric::Map50,
        Metric::Map50To95,
        Metric::CocoAp,
        Metric::CocoAp50,
        Metric::PrecisionAtConf,
        Metric::RecallAtConf,
    ];

    /// The name in `--tolerance NAME=VALUE` and in the output.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Precision => "precision",
            Metric::Recall => "recall",
            Metric::Map50 => "map50",
            Metric::Map50To95 => "map50-95",
            Metric::CocoAp => "coco-ap",
            Metric::CocoAp50 => "coco-ap50",
            Metric::PrecisionAtConf => "precision-at-conf",
            Metric::RecallAtConf => "recall-at-conf",
        }
    }

    pub fn of(self, d: &DetectorMetrics) -> f64 {
        match self {
            Metric::Precision => d.ultralytics.precision,
            Metric::Recall => d.ultralytics.recall,
            Metric::Map50 => d.ultralytics.map50,
            Metric::Map50To95 => d.ultralytics.map50_95,
            Metric::CocoAp => d.coco.ap,
            Metric::CocoAp50 => d.coco.ap50,
            Metric::PrecisionAtConf => d.at_threshold.precision,
            Metric::RecallAtConf => d.at_threshold.recall,
        }
    }
}

/// The allowed fall of each metric: the default unless overridden.
#[derive(Clone, Debug, Default)]
pub struct Tolerances {
    set: BTreeMap<Metric, f64>,
    all: Option<f64>,
}

impl Tolerances {
    /// From `--tolerance NAME=VALUE` arguments (`all=VALUE` sets every metric; a named metric
    /// wins over `all`).
    pub fn parse(args: &[String]) -> anyhow::Result<Tolerances> {
        let mut t = Tolerances::default();
        for arg in args {
            let (name, value) = arg
                .split_once('=')
                .with_context(|| format!("--tolerance {arg}: expected NAME=VALUE"))?;
            let value: f64 = value
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && *v >= 0.0)
                .with_context(|| format!("--tolerance {arg}: the value must be a number >= 0"))?;
            let name = name.trim();
            if name == "all" {
                t.all = Some(value);
                continue;
            }
            let Some(metric) = Metric::ALL.into_iter().find(|m| m.name() == name) else {
                let names: Vec<&str> = Metric::ALL.iter().map(|m| m.name()).collect();
                bail!(
                    "--tolerance {arg}: unknown metric `{name}`; known: all, {}",
                    names.join(", ")
                );
            };
            t.set.insert(metric, value);
        }
        Ok(t)
    }

    pub fn of(&self, metric: Metric) -> f64 {
        self.set
            .get(&metric)
            .copied()
            .or(self.all)
            .unwrap_or(DEFAULT)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn named_overrides_all_and_default() {
        let t = Tolerances::parse(&["all=0.05".into(), "map50-95=0.01".into()]).unwrap();
        assert_eq!(t.of(Metric::Map50To95), 0.01);
        assert_eq!(t.of(Metric::Recall), 0.05);
        assert_eq!(Tolerances::default().of(Metric::Recall), DEFAULT);
        for bad in ["map50", "map=0.1", "recall=-1", "recall=x"] {
            assert!(Tolerances::parse(&[bad.into()]).is_err(), "{bad}");
        }
    }
}
