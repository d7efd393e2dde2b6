//! Every run states what it will write and checks its disk holds it before the first image.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::Path;

mod common;
use common::{run_quickstart, scratch};

/// The quickstart's stages without its detect stage.
const STAGES: &str = "stages=[\"render\", \"enhance\", \"dataset\"]";

fn bytes_under(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            if e.file_type().unwrap().is_dir() {
                bytes_under(&e.path())
            } else {
                e.metadata().unwrap().len()
            }
        })
        .sum()
}

#[test]
fn a_run_too_big_for_its_disk_is_refused_with_both_figures_before_writing() {
    let (dir, out) = scratch("run");
    // 1e7 images (the most a campaign may ask) of 1024 x 1024 with both FITS: about 100 TB,
    // more than any machine this runs on has free. (--force: their work, over 30 days of one
    // core, is refused first otherwise; tests/hostile/runaway.toml checks that.)
    let o = run_quickstart(
        &[
            "--quiet",
            "--force",
            "--set",
            "images=10000000",
            "--set",
            STAGES,
        ],
        &out,
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("the run would write 10000000 images of 1024 x 1024 px: about ")
            && err.contains(" GB, but its disk has ")
            && err.contains(" free; lower `images`"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn the_planned_size_is_said_and_bounds_what_the_run_writes() {
    let (_dir, out) = scratch("run");
    let o = run_quickstart(&["--set", "images=3", "--set", STAGES], &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    let said = err
        .lines()
        .find(|l| l.starts_with("planned: 3 images of 1024 x 1024 px: about "))
        .unwrap_or_else(|| panic!("{err}"));
    let mut words = said.split("about ").nth(1).unwrap().split(' ');
    let number: f64 = words.next().unwrap().parse().unwrap();
    let planned_mb = match words.next() {
        Some("MB") => number,
        Some("GB") => number * 1e3,
        _ => panic!("{said}"),
    };
    let written_mb = bytes_under(&out) as f64 / 1e6;
    // An upper bound (PNG as if incompressible, truth and star list with room to spare), but
    // not a wild one: the FITS, exact, are most of a run. 0.05 MB: the figure's rounding.
    assert!(
        planned_mb + 0.05 >= written_mb && planned_mb <= 1.5 * written_mb,
        "planned {planned_mb} MB, written {written_mb} MB"
    );
}
