//! The README's figures are the binary's: its quickstart output block, and its table of
//! detections on the real NEOSSat frames. Each test reruns the README's own command and fails,
//! saying what to update, when they drift apart. The table is read generically: every column
//! whose header names a detector ("streak", "yolo") and whose cell is a whole number is a count
//! of that detector's boxes on the row's frame (named by its file stem anywhere in the row).

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod common;
use common::ort_available;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn readme() -> String {
    std::fs::read_to_string(root().join("README.md")).unwrap()
}

/// The first fenced block after the line `marker`, without its fences.
fn block_after<'a>(text: &'a str, marker: &str) -> &'a str {
    let at = text
        .find(marker)
        .unwrap_or_else(|| panic!("README.md has no {marker:?}"));
    let rest = &text[at..];
    let open = rest.find("```").expect("a fenced block after the marker");
    let body = &rest[open..];
    let body = &body[body.find('\n').unwrap() + 1..];
    &body[..body.find("```").expect("the block is closed")]
}

/// A README section: from its heading to the next heading of the same or a higher level.
fn section<'a>(text: &'a str, heading: &str) -> &'a str {
    let at = text
        .find(&format!("\n{heading}\n"))
        .unwrap_or_else(|| panic!("README.md has no section {heading:?}"));
    let level = heading.split(' ').next().unwrap().len();
    let rest = &text[at + 1..];
    let end = rest[1..]
        .match_indices("\n#")
        .map(|(i, _)| i + 1)
        .find(|&i| {
            let line = &rest[i + 1..];
            let hashes = line.chars().take_while(|&c| c == '#').count();
            hashes > 0 && hashes <= level && line[hashes..].starts_with(' ')
        })
        .unwrap_or(rest.len() - 1);
    &rest[..end + 1]
}

#[test]
fn the_quickstart_output_in_the_readme_is_the_binarys() {
    if !ort_available() {
        return;
    }
    let text = readme();
    let shown: Vec<&str> = block_after(
        &text,
        "<!-- quickstart output: checked by tests/readme.rs -->",
    )
    .lines()
    .collect();
    // Run from a folder of its own so the output prints as `runs/quickstart`, as in the README.
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_soig"))
        .current_dir(dir.path())
        .arg("run")
        .arg(root().join("campaigns/quickstart.toml"))
        .args(["--quiet", "--out", "runs/quickstart"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let printed: Vec<&str> = stdout.lines().collect();
    let fix = "update README.md's quickstart block from `soig run campaigns/quickstart.toml`";
    assert_eq!(shown.len(), printed.len(), "{fix}:\n{stdout}");
    // The first line's and the last line's times vary; every other line is exact.
    let (first, last) = (0, shown.len() - 1);
    for (i, (s, p)) in shown.iter().zip(&printed).enumerate() {
        if i == first {
            // `30 images rendered in 7.9 s (3.79 images/s) -> runs/quickstart`
            let ends = |l: &str| {
                let head = l.split(" in ").next().unwrap().to_string();
                (head, l.rsplit(" -> ").next().unwrap().to_string())
            };
            assert_eq!(ends(s), ends(p), "{fix}:\n{stdout}");
        } else if i == last {
            assert!(
                s.starts_with("total ") && p.starts_with("total "),
                "{fix}:\n{stdout}"
            );
        } else {
            assert_eq!(s, p, "{fix}:\n{stdout}");
        }
    }
}

/// The README's `soig detect` command, as words, its globs expanded (from the repository).
fn detect_command(text: &str) -> Vec<String> {
    // The command is the fenced block that starts with `soig detect tests/fixtures/...`.
    let at = text.find("\nsoig detect tests/fixtures/neossat").unwrap() + 1;
    let end = at + text[at..].find("```").unwrap();
    let line = text[at..end].replace("\\\n", " ");
    let mut words = Vec::new();
    for w in line.split_whitespace() {
        match w.split_once('*') {
            Some((head, tail)) => {
                let (dir, prefix) = head.rsplit_once('/').unwrap_or((".", head));
                let mut found: Vec<String> = std::fs::read_dir(root().join(dir))
                    .unwrap()
                    .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                    .filter(|n| n.starts_with(prefix) && n.ends_with(tail))
                    .map(|n| format!("{dir}/{n}"))
                    .collect();
                found.sort();
                words.extend(found);
            }
            None => words.push(w.to_string()),
        }
    }
    words
}

#[test]
fn the_real_frame_table_in_the_readme_is_the_binarys() {
    if !ort_available() {
        return;
    }
    let text = readme();
    let part = section(&text, "### Detecting on real frames");
    let words = detect_command(part);
    assert_eq!(words[..2], ["soig", "detect"], "{words:?}");
    let dir = tempfile::tempdir().unwrap();
    let out: PathBuf = dir.path().join("detections");
    let o = Command::new(env!("CARGO_BIN_EXE_soig"))
        .current_dir(root())
        .args(&words[1..])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Boxes per (frame stem, detector), every frame run starting at 0 for each detector.
    let frames: Vec<String> = words
        .iter()
        .filter(|w| w.ends_with(".fits") || w.ends_with(".png"))
        .map(|w| {
            Path::new(w)
                .file_stem()
                .unwrap()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    let mut found: BTreeMap<(String, String), u64> = BTreeMap::new();
    for f in &frames {
        for d in ["streak", "yolo"] {
            found.insert((f.clone(), d.to_string()), 0);
        }
    }
    let mut csv = csv::Reader::from_path(out.join("detections.csv")).unwrap();
    for r in csv.records() {
        let r = r.unwrap();
        let stem = Path::new(&r[0])
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        *found.entry((stem, r[1].to_string())).or_default() += 1;
    }
    // Every table of the section: the header's detector columns, each row's frame.
    let mut checked = 0;
    let mut header: Vec<String> = Vec::new();
    for line in part.lines() {
        if !line.starts_with('|') {
            header.clear();
            continue;
        }
        let cells: Vec<String> = line
            .trim_matches('|')
            .split(" | ")
            .map(|c| c.trim().to_string())
            .collect();
        if header.is_empty() {
            header = cells.into_iter().map(|c| c.to_lowercase()).collect();
            continue;
        }
        if cells
            .iter()
            .all(|c| c.chars().all(|ch| ch == '-' || ch == ':'))
        {
            continue;
        }
        let Some(frame) = frames.iter().find(|f| line.contains(f.as_str())) else {
            continue;
        };
        for (h, cell) in header.iter().zip(&cells) {
            let Some(detector) = ["streak", "yolo"].into_iter().find(|d| h.contains(d)) else {
                continue;
            };
            let Ok(n) = cell.parse::<u64>() else { continue };
            let got = found[&(frame.clone(), detector.to_string())];
            assert_eq!(
                n, got,
                "README.md, real-frame table, {frame}, column {h:?}: says {n}, `soig detect` finds {got}"
            );
            checked += 1;
        }
    }
    assert!(
        checked >= frames.len(),
        "README.md's real-frame table gives {checked} counts for {} frames: keep a column per detector (header naming `streak` or `yolo`) with whole numbers",
        frames.len()
    );
}

#[test]
fn the_command_reference_names_every_verb() {
    let o = Command::new(env!("CARGO_BIN_EXE_soig"))
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&o.stdout);
    let verbs: Vec<&str> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|v| *v != "help")
        .collect();
    assert!(verbs.len() >= 14, "{help}");
    let text = readme();
    let reference = section(&text, "## Commands");
    let missing: Vec<&&str> = verbs
        .iter()
        .filter(|v| !reference.contains(&format!("| `soig {v}")))
        .collect();
    assert!(
        missing.is_empty(),
        "README.md's \"Commands\" table lacks {missing:?}"
    );
}
