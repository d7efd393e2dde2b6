//! Probing a Python interpreter with `python -c CODE`: how soig finds the ONNX Runtime library
//! of the `onnxruntime` package (`detect::yolo`) and an interpreter with Ultralytics (`train`).
//! A probe never reads stdin and never shows the interpreter's errors: a missing interpreter,
//! a failed import and a crash all mean "not this one".

use std::path::Path;
use std::process::{Command, Stdio};

fn probe(python: &Path, code: &str) -> Command {
    let mut cmd = Command::new(python);
    cmd.args(["-c", code])
        .stdin(Stdio::null())
        .stderr(Stdio::null());
    cmd
}

/// The non-empty output lines of `python -c code`, trimmed, or None when the interpreter is
/// missing or fails.
pub fn lines(python: &Path, code: &str) -> Option<Vec<String>> {
    let out = probe(python, code).output().ok()?;
    if !out.status.success() {
        return None;
    }
    Some(
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .map(|l| l.trim().to_string())
            .filter(|l| !l.is_empty())
            .collect(),
    )
}

/// Whether `python -c code` runs and exits with success (its output is discarded).
pub fn succeeds(python: &Path, code: &str) -> bool {
    probe(python, code)
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_interpreter_is_none_and_false() {
        let py = Path::new("/nonexistent/python3");
        assert_eq!(lines(py, "print(1)"), None);
        assert!(!succeeds(py, "pass"));
    }

    #[test]
    fn lines_are_trimmed_and_failures_are_none() {
        let py = Path::new("python3");
        if !succeeds(py, "pass") {
            return; // no Python on this machine: the test above covers it
        }
        assert_eq!(
            lines(py, "print(' a ')\nprint()\nprint('b')"),
            Some(vec!["a".to_string(), "b".to_string()])
        );
        assert_eq!(lines(py, "raise SystemExit(1)"), None);
        assert!(!succeeds(py, "import no_such_module_soig"));
    }
}
