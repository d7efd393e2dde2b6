//! Progress of long work, reported through a callback so the library never draws or prints
//! by itself: the command line passes [`Bars`] (indicatif bars with rate and ETA, and notes on
//! stderr), an embedding program its own [`Progress`], or [`Silent`].

use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressStyle};

/// What long work reports. Every method has a default that ignores it.
pub trait Progress: Sync {
    /// A stage of `total` items begins (e.g. "render", "yolo").
    fn start(&self, _stage: &str, _total: u64) {}
    /// One more item of the current stage is done (called from any thread).
    fn advance(&self) {}
    /// The current stage is over.
    fn finish(&self) {}
    /// Something the user should know (e.g. which interpreter trains).
    fn note(&self, _message: &str) {}
    /// Whether the user asked to stop (Python's Ctrl-C): long loops then end with
    /// [`Interrupted`] before their next item, and the output is left to resume.
    fn cancelled(&self) -> bool {
        false
    }
}

/// The error of work stopped because [`Progress::cancelled`] said so: the work done is kept
/// for a resume, as after a kill.
#[derive(Debug)]
pub struct Interrupted;

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("interrupted: the work done so far is kept; run the same again to resume it")
    }
}

impl std::error::Error for Interrupted {}

/// `Err(Interrupted)` when `progress` asks to stop.
pub fn check(progress: &dyn Progress) -> Result<(), Interrupted> {
    if progress.cancelled() {
        Err(Interrupted)
    } else {
        Ok(())
    }
}

/// Reports nothing.
pub struct Silent;

impl Progress for Silent {}

/// Progress bars on stderr with rate and ETA, one style for every stage (render, streak,
/// yolo, report), and notes printed there. indicatif draws nothing when stderr is not a
/// terminal.
#[derive(Default)]
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
}

impl Progress for Bars {
    fn start(&self, stage: &str, total: u64) {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(
                "{msg:>7} [{bar:30}] {pos:>5}/{len:5}  {per_sec:>11}  elapsed {elapsed:>4}  ETA {eta:>4}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar.set_message(stage.to_string());
        *self.bar.lock().expect("bar lock") = Some(bar);
    }

    fn advance(&self) {
        if let Some(bar) = &*self.bar.lock().expect("bar lock") {
            bar.inc(1);
        }
    }

    fn finish(&self) {
        if let Some(bar) = self.bar.lock().expect("bar lock").take() {
            bar.finish_and_clear();
        }
    }

    fn note(&self, message: &str) {
        eprintln!("{message}");
    }
}
