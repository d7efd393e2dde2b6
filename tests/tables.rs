//! `results/README.md`'s tables are what `soig tables` makes from the committed `results/` rows.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::Path;
use std::process::Command;

#[test]
fn results_readme_tables_match_the_committed_rows() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut rows: Vec<String> = std::fs::read_dir(root.join("results"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("results-")
        })
        .map(|p| p.display().to_string())
        .collect();
    rows.sort();
    assert!(rows.len() >= 8, "{rows:?}");
    let o = Command::new(env!("CARGO_BIN_EXE_soig"))
        .arg("tables")
        .args(&rows)
        .arg("--models")
        .arg(root.join("models/queue.toml"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let made = String::from_utf8(o.stdout).unwrap();
    let readme = std::fs::read_to_string(root.join("results/README.md")).unwrap();
    let committed = soig::tables::block(&readme).expect("results/README.md has the tables block");
    assert!(
        committed == made.trim_end(),
        "results/README.md's tables are stale: run `soig tables results/results-* --models models/queue.toml --readme results/README.md`\n--- committed\n{committed}\n--- made\n{made}"
    );
    for table in [
        "### Table 3",
        "### Table 5",
        "### What trained each row's model",
        "### Table 6",
    ] {
        assert!(made.contains(table), "{table}");
    }
}
