//! The last lines `soig run` prints, in one place: the output folder as a clean path, the
//! digest, where the report is, and each detector's headline metrics.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::pipeline::RunSummary;
use crate::report::Report;

/// `dir` without `.` and `..` and symbolic links, relative to the current directory when it
/// lies under it (`campaigns/../runs/x` -> `runs/x`); `dir` as given if it cannot be resolved.
pub fn clean_path(dir: &Path) -> PathBuf {
    let Ok(full) = dir.canonicalize() else {
        return dir.to_path_buf();
    };
    match std::env::current_dir().and_then(|d| d.canonicalize()) {
        Ok(cwd) => match full.strip_prefix(&cwd) {
            Ok(rel) if rel.as_os_str().is_empty() => PathBuf::from("."),
            Ok(rel) => rel.to_path_buf(),
            Err(_) => full,
        },
        Err(_) => full,
    }
}

impl RunSummary {
    /// What `soig run` ends with. The `digest HEX` line is for scripts and stays as it is.
    pub fn final_lines(&self) -> String {
        let resumed = match self.resumed {
            0 => String::new(),
            r => format!(" (and {r} resumed)"),
        };
        // A run that only finished what a killed one left has no rate to speak of.
        let rate = match self.images {
            0 => String::new(),
            n => format!(
                " rendered in {:.1} s ({:.2} images/s)",
                self.seconds,
                n as f64 / self.seconds
            ),
        };
        let head = format!("{} images{resumed}{rate}", self.images);
        self.lines(&head)
    }

    /// The last line of `soig run` and `soig merge`: the whole command's wall time
    /// `total_s` and each step's share of it; "other" is the rest (loading the campaign,
    /// checks, moving the output into place).
    pub fn timing_line(&self, total_s: f64) -> String {
        let share = |s: f64| {
            if total_s > 0.0 {
                100.0 * s / total_s
            } else {
                0.0
            }
        };
        let other = (total_s - self.steps.iter().map(|(_, s)| s).sum::<f64>()).max(0.0);
        let parts: Vec<String> = self
            .steps
            .iter()
            .copied()
            .chain(std::iter::once(("other", other)))
            .map(|(name, s)| format!("{name} {s:.1} s ({:.0}%)", share(s)))
            .collect();
        format!("total {total_s:.1} s: {}\n", parts.join(", "))
    }

    /// What `soig merge` of `shards` shard outputs ends with: `final_lines`, its first line
    /// counting the images merged (all of them `resumed`: none rendered here).
    pub fn merge_lines(&self, shards: usize) -> String {
        let head = format!(
            "{} images of {shards} shards merged in {:.1} s",
            self.resumed, self.seconds
        );
        self.lines(&head)
    }

    /// `head -> OUTPUT`, the digest, the report's headline and the debris mix.
    fn lines(&self, head: &str) -> String {
        let out = clean_path(&self.output);
        let mut s = format!("{head} -> {}\ndigest {}\n", out.display(), self.digest);
        let report = self.output.join("report/report.json");
        if let Ok(r) = Report::read(&report) {
            let _ = writeln!(
                s,
                "report {} ({} test images, {} objects)",
                out.join("report/report.md").display(),
                r.images,
                r.objects
            );
            for d in &r.detectors {
                let u = &d.ultralytics;
                let _ = writeln!(
                    s,
                    "  {:<8} P {:.3}  R {:.3}  mAP50 {:.3}  mAP50-95 {:.3}",
                    d.detector, u.precision, u.recall, u.map50, u.map50_95
                );
            }
        }
        if !self.mix.is_empty() {
            let mix: Vec<String> = self
                .mix
                .iter()
                .map(|d| format!("{} (NORAD {}) {}", d.object, d.norad, d.images))
                .collect();
            let _ = writeln!(s, "debris mix: {}", mix.join(", "));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clean_path_drops_dot_dot_and_stays_relative() {
        let cwd = std::env::current_dir().unwrap();
        let tmp = tempfile::tempdir_in(&cwd).unwrap();
        let name = tmp.path().file_name().unwrap();
        std::fs::create_dir(tmp.path().join("a")).unwrap();
        let messy = Path::new(".").join(name).join("a").join("..").join("a");
        assert_eq!(clean_path(&messy), Path::new(name).join("a"));
        // Outside the current directory: absolute, and missing: as given.
        assert!(clean_path(&std::env::temp_dir()).is_absolute());
        assert_eq!(
            clean_path(Path::new("no/such/../dir")),
            Path::new("no/such/../dir")
        );
    }
}
