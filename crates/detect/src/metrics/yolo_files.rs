//! YOLO-format label and prediction text files (`cls xc yc w h [score]`, normalised), read into
//! [`ImageEval`]s paired by file stem.

use super::{ImageEval, box_det};
use std::path::{Path, PathBuf};

/// Errors reading YOLO-format files.
#[derive(thiserror::Error, Debug)]
pub enum MetricsError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{}: prediction file without a label file (expected {})", path.display(), expected.display())]
    OrphanPrediction { path: PathBuf, expected: PathBuf },
}

pub(super) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> MetricsError + '_ {
    move |source| MetricsError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// `*.txt` files of a directory by stem, sorted.
fn txt_files(dir: &Path) -> Result<Vec<(String, PathBuf)>, MetricsError> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
        let entry = entry.map_err(io_err(dir))?;
        let path = entry.path();
        if path.extension().and_then(|e| e.to_str()) != Some("txt") || !path.is_file() {
            continue;
        }
        if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
            out.push((stem.to_string(), path));
        }
    }
    out.sort();
    Ok(out)
}

/// Parses `cls xc yc w h [score]` lines (`with_score` selects the prediction form); blank lines are
/// skipped. Returns `(class, [x1, y1, x2, y2], score)`, normalised; `path` names the text in errors.
pub fn parse_yolo(
    path: &Path,
    text: &str,
    with_score: bool,
) -> Result<Vec<(u32, [f64; 4], f64)>, MetricsError> {
    let (want, form) = if with_score {
        (6, "cls xc yc w h score")
    } else {
        (5, "cls xc yc w h")
    };
    let mut out = Vec::new();
    for (line, class, v) in parse_lines(path, text, want, form)? {
        if v[2] < 0.0 || v[3] < 0.0 {
            return Err(MetricsError::Parse {
                path: path.to_path_buf(),
                line,
                message: "negative box width or height".to_string(),
            });
        }
        let (xc, yc, w, h) = (v[0], v[1], v[2], v[3]);
        let b = [xc - w / 2.0, yc - h / 2.0, xc + w / 2.0, yc + h / 2.0];
        out.push((class, b, if with_score { v[4] } else { 1.0 }));
    }
    Ok(out)
}

/// The lines of a YOLO-format text of `want` fields each (`form` names them in errors), blank
/// lines skipped: (line number, class, the other fields), every field a finite number and the
/// class a non-negative integer.
pub(super) fn parse_lines(
    path: &Path,
    text: &str,
    want: usize,
    form: &str,
) -> Result<Vec<(usize, u32, Vec<f64>)>, MetricsError> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let err = |message: String| MetricsError::Parse {
            path: path.to_path_buf(),
            line: n + 1,
            message,
        };
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        if fields.len() != want {
            return Err(err(format!(
                "expected {want} fields ({form}), found {}",
                fields.len()
            )));
        }
        let mut v = vec![0.0f64; want];
        for (k, f) in fields.iter().enumerate() {
            v[k] = f
                .parse::<f64>()
                .map_err(|_| err(format!("field {} is not a number: {f:?}", k + 1)))?;
            if !v[k].is_finite() {
                return Err(err(format!("field {} is not finite: {f:?}", k + 1)));
            }
        }
        if v[0] < 0.0 || v[0].fract() != 0.0 || v[0] > u32::MAX as f64 {
            return Err(err(format!(
                "class {:?} is not a non-negative integer",
                fields[0]
            )));
        }
        out.push((n + 1, v[0] as u32, v.split_off(1)));
    }
    Ok(out)
}

/// One YOLO-format file: `(class, [x1, y1, x2, y2] normalised, score)` per line, the score 1 for a
/// label file (`with_score` false).
pub fn read_yolo_file(
    path: &Path,
    with_score: bool,
) -> Result<Vec<(u32, [f64; 4], f64)>, MetricsError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    parse_yolo(path, &text, with_score)
}

/// Reads YOLO-format text files: labels `cls xc yc w h` (normalised), predictions `cls xc yc w h score`,
/// paired by file stem (`labels/a.txt` with `predictions/a.txt`). A label file with no prediction file
/// means no detections; a prediction file with no label file is an error, as are malformed lines (the
/// error names the file and line). Boxes stay normalised (x1 y1 x2 y2); scale them to pixels with
/// [`ImageEval::scaled`] for Ultralytics-exact figures. Sorted by stem.
pub fn read_yolo_dirs(
    labels: &Path,
    predictions: &Path,
) -> Result<Vec<(String, ImageEval)>, MetricsError> {
    read_paired(labels, predictions, parse_yolo, |truth, predicted| {
        ImageEval {
            truth: truth.iter().map(|t| t.1).collect(),
            truth_class: truth.iter().map(|t| t.0).collect(),
            detections: predicted
                .into_iter()
                .map(|(class, b, score)| box_det(b, score, class))
                .collect(),
        }
    })
}

/// The label files of `labels` with their prediction files in `predictions` (`paired`), each
/// parsed by `parse` (a prediction file's lines with their score) and made one image by
/// `image` from its label lines and predicted lines (none without a prediction file).
pub(super) fn read_paired<L, T>(
    labels: &Path,
    predictions: &Path,
    parse: impl Fn(&Path, &str, bool) -> Result<Vec<L>, MetricsError>,
    image: impl Fn(Vec<L>, Vec<L>) -> T,
) -> Result<Vec<(String, T)>, MetricsError> {
    paired(labels, predictions)?
        .into_iter()
        .map(|(stem, (path, text), prediction)| {
            let truth = parse(&path, &text, false)?;
            let predicted = match prediction {
                Some((path, text)) => parse(&path, &text, true)?,
                None => Vec::new(),
            };
            Ok((stem, image(truth, predicted)))
        })
        .collect()
}

/// A label file's stem, path and text, and its prediction file's path and text if any.
type Paired = (String, (PathBuf, String), Option<(PathBuf, String)>);

/// The label files of `labels` with their prediction files in `predictions` (paired by stem,
/// sorted); a prediction file with no label file is an error.
fn paired(labels: &Path, predictions: &Path) -> Result<Vec<Paired>, MetricsError> {
    let label_files = txt_files(labels)?;
    let pred_files = txt_files(predictions)?;
    for (stem, path) in &pred_files {
        if label_files
            .binary_search_by(|(s, _)| s.as_str().cmp(stem))
            .is_err()
        {
            return Err(MetricsError::OrphanPrediction {
                path: path.clone(),
                expected: labels.join(format!("{stem}.txt")),
            });
        }
    }
    let read = |path: PathBuf| -> Result<(PathBuf, String), MetricsError> {
        let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
        Ok((path, text))
    };
    let mut out = Vec::with_capacity(label_files.len());
    for (stem, path) in label_files {
        let prediction = match pred_files.binary_search_by(|(s, _)| s.as_str().cmp(&stem)) {
            Ok(i) => Some(read(pred_files[i].1.clone())?),
            Err(_) => None,
        };
        out.push((stem, read(path)?, prediction));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::at_threshold;
    use super::*;

    struct TempDir(PathBuf);

    impl TempDir {
        fn new(tag: &str) -> TempDir {
            let p = std::env::temp_dir().join(format!("soig-metrics-{tag}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(p.join("labels")).unwrap();
            std::fs::create_dir_all(p.join("pred")).unwrap();
            TempDir(p)
        }
        fn write(&self, rel: &str, text: &str) {
            std::fs::write(self.0.join(rel), text).unwrap();
        }
        fn read(&self) -> Result<Vec<(String, ImageEval)>, MetricsError> {
            read_yolo_dirs(&self.0.join("labels"), &self.0.join("pred"))
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn yolo_round_trip() {
        let t = TempDir::new("ok");
        t.write("labels/b.txt", "0 0.5 0.5 0.2 0.1\n\n1 0.25 0.75 0.1 0.1\n");
        t.write("labels/a.txt", "");
        t.write("labels/c.txt", "0 0.1 0.1 0.02 0.02\n");
        t.write("labels/notes.md", "ignored");
        t.write(
            "pred/b.txt",
            "0 0.5 0.5 0.2 0.1 0.9\n1 0.3 0.7 0.1 0.1 0.4\n",
        );
        t.write("pred/a.txt", "0 0.9 0.9 0.05 0.05 0.3\n");
        let got = t.read().unwrap();
        let stems: Vec<&str> = got.iter().map(|g| g.0.as_str()).collect();
        assert_eq!(stems, ["a", "b", "c"]);
        let a = &got[0].1;
        assert!(a.truth.is_empty() && a.detections.len() == 1);
        let b = &got[1].1;
        assert_eq!(b.truth_class, [0, 1]);
        assert!((b.truth[0][0] - 0.4).abs() < 1e-15 && (b.truth[0][3] - 0.55).abs() < 1e-15);
        assert_eq!(b.detections[1].class, 1);
        assert_eq!(b.detections[0].score, 0.9);
        assert!(got[2].1.detections.is_empty()); // no prediction file: no detections
        let px: Vec<ImageEval> = got.iter().map(|g| g.1.scaled(640.0, 512.0)).collect();
        assert!((px[1].truth[0][2] - 0.6 * 640.0).abs() < 1e-9);
        assert_eq!(at_threshold(&px, 0.5, 0.5).tp, 1);
    }

    #[test]
    fn yolo_errors_name_file_and_line() {
        let t = TempDir::new("bad-label");
        t.write("labels/x.txt", "0 0.5 0.5 0.2 0.1\n0 0.5 0.5 0.2\n");
        let e = t.read().unwrap_err().to_string();
        assert!(
            e.contains("x.txt:2:") && e.contains("expected 5 fields"),
            "{e}"
        );

        let t = TempDir::new("bad-pred");
        t.write("labels/x.txt", "0 0.5 0.5 0.2 0.1\n");
        t.write(
            "pred/x.txt",
            "0 0.5 0.5 0.2 0.1 0.5\n\n0 0.5 0.5 0.2 0.1 abc\n",
        );
        let e = t.read().unwrap_err().to_string();
        assert!(
            e.contains("pred") && e.contains("x.txt:3:") && e.contains("field 6"),
            "{e}"
        );

        let t = TempDir::new("bad-class");
        t.write("labels/x.txt", "1.5 0.5 0.5 0.2 0.1\n");
        assert!(t.read().unwrap_err().to_string().contains("x.txt:1:"));

        let t = TempDir::new("orphan");
        t.write("labels/x.txt", "");
        t.write("pred/y.txt", "0 0.5 0.5 0.2 0.1 0.5\n");
        let e = t.read().unwrap_err();
        assert!(
            matches!(e, MetricsError::OrphanPrediction { .. }) && e.to_string().contains("y.txt"),
            "{e}"
        );

        let e = read_yolo_dirs(
            Path::new("/nonexistent/labels"),
            Path::new("/nonexistent/pred"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("/nonexistent/labels"), "{e}");
    }
}
