//! The truth's observations as a CCSDS TDM (`artifacts.tdm`, `soig export --tdm`; issue #45
//! item 2): the file is parsed here against the KVN rules and keywords of CCSDS 503.0-B-2
//! (header, then META_START..META_STOP / DATA_START..DATA_STOP segments; `KEY = value`;
//! data lines `KEY = epoch value`), and its values are the truth sidecars'. The truth's RA/Dec
//! themselves are checked against python-sgp4 and astropy elsewhere (tests/apparent.rs,
//! tests/reference/ephemeris_reference.py); tests/reference/tdm_reader.py reads the same file
//! with ccsds-ndm, an independent CCSDS reader.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::{json, ok, run_quickstart, soig};

/// Header keywords of a TDM (503.0-B-2, 3.2).
const HEADER: [&str; 5] = [
    "CCSDS_TDM_VERS",
    "COMMENT",
    "CREATION_DATE",
    "ORIGINATOR",
    "MESSAGE_ID",
];
/// Metadata keywords soig may write, all of the standard's (3.3): a misspelt one fails here.
const METADATA: [&str; 11] = [
    "COMMENT",
    "TIME_SYSTEM",
    "START_TIME",
    "STOP_TIME",
    "PARTICIPANT_1",
    "PARTICIPANT_2",
    "MODE",
    "PATH",
    "ANGLE_TYPE",
    "REFERENCE_FRAME",
    "DATA_QUALITY",
];
/// Data keywords of optical angles and photometry (3.4).
const DATA: [&str; 3] = ["ANGLE_1", "ANGLE_2", "MAG"];

/// One segment: its metadata and its data lines (keyword, epoch, value).
struct Segment {
    meta: BTreeMap<String, String>,
    data: Vec<(String, String, f64)>,
}

/// `KEY = value` of a KVN line (COMMENT has no `=`).
fn key_value(line: &str) -> (String, String) {
    if let Some(rest) = line.strip_prefix("COMMENT") {
        return ("COMMENT".into(), rest.trim().into());
    }
    let (k, v) = line
        .split_once('=')
        .unwrap_or_else(|| panic!("not KEY = value: {line:?}"));
    (k.trim().to_string(), v.trim().to_string())
}

/// An epoch as the standard writes it: `YYYY-MM-DDThh:mm:ss[.d...]`.
fn is_epoch(s: &str) -> bool {
    let b = s.as_bytes();
    b.len() >= 19
        && s.chars().enumerate().take(19).all(|(i, c)| match i {
            4 | 7 => c == '-',
            10 => c == 'T',
            13 | 16 => c == ':',
            _ => c.is_ascii_digit(),
        })
        && (b.len() == 19 || (b[19] == b'.' && s[20..].chars().all(|c| c.is_ascii_digit())))
}

fn parse(text: &str) -> (BTreeMap<String, String>, Vec<Segment>) {
    let mut header = BTreeMap::new();
    let mut segments: Vec<Segment> = Vec::new();
    let mut state = "header";
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        match (state, line) {
            ("header" | "between", "META_START") => {
                state = "meta";
                segments.push(Segment {
                    meta: BTreeMap::new(),
                    data: Vec::new(),
                });
            }
            ("meta", "META_STOP") => state = "after_meta",
            ("after_meta", "DATA_START") => state = "data",
            ("data", "DATA_STOP") => state = "between",
            ("header", _) => {
                let (k, v) = key_value(line);
                assert!(HEADER.contains(&k.as_str()), "header keyword {k}");
                header.insert(k, v);
            }
            ("meta", _) => {
                let (k, v) = key_value(line);
                assert!(METADATA.contains(&k.as_str()), "metadata keyword {k}");
                segments.last_mut().unwrap().meta.insert(k, v);
            }
            ("data", _) => {
                let (k, v) = key_value(line);
                if k == "COMMENT" {
                    continue;
                }
                assert!(DATA.contains(&k.as_str()), "data keyword {k}");
                let (epoch, value) = v.split_once(' ').expect("epoch value");
                assert!(is_epoch(epoch), "{epoch}");
                let value: f64 = value.trim().parse().expect("a number");
                segments
                    .last_mut()
                    .unwrap()
                    .data
                    .push((k, epoch.into(), value));
            }
            _ => panic!("{line:?} in state {state}"),
        }
    }
    assert_eq!(state, "between", "the last segment is closed");
    (header, segments)
}

fn check(out: &Path, tdm: &Path) -> usize {
    let (header, segments) = parse(&std::fs::read_to_string(tdm).unwrap());
    assert_eq!(header["CCSDS_TDM_VERS"], "2.0");
    assert!(is_epoch(&header["CREATION_DATE"]) && header["ORIGINATOR"] == "soig");
    let mut stems: Vec<_> = std::fs::read_dir(out.join("truth"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    stems.sort();
    assert_eq!(segments.len(), stems.len());
    for (s, path) in segments.iter().zip(&stems) {
        let t = json(path);
        let m = &s.meta;
        // Required (3.3): TIME_SYSTEM, PARTICIPANT_1; RADEC angles need their frame.
        assert_eq!(m["TIME_SYSTEM"], "UTC");
        assert_eq!(m["ANGLE_TYPE"], "RADEC");
        assert_eq!(m["REFERENCE_FRAME"], "ICRF");
        assert_eq!(m["MODE"], "SEQUENTIAL");
        assert_eq!(m["PATH"], "2,1");
        assert_eq!(m["PARTICIPANT_1"], "SENTINEL 3A");
        assert!(m["PARTICIPANT_2"].ends_with(&format!("(NORAD {})", t["norad"])));
        assert_eq!(m["START_TIME"], t["start_utc"].as_str().unwrap());
        let e = &t["ephemeris"];
        let at = |key: &str, k: usize| e[key][k].as_f64().unwrap();
        let want = [
            ("ANGLE_1", at("debris_radec_start_deg", 0)),
            ("ANGLE_2", at("debris_radec_start_deg", 1)),
            ("ANGLE_1", at("debris_radec_mid_deg", 0)),
            ("ANGLE_2", at("debris_radec_mid_deg", 1)),
            ("MAG", t["magnitude"].as_f64().unwrap()),
            ("ANGLE_1", at("debris_radec_end_deg", 0)),
            ("ANGLE_2", at("debris_radec_end_deg", 1)),
        ];
        assert_eq!(s.data.len(), want.len());
        for ((k, epoch, v), (wk, w)) in s.data.iter().zip(want) {
            assert_eq!(k, wk);
            assert!(
                epoch.as_str() >= m["START_TIME"].as_str() && epoch <= &m["STOP_TIME"],
                "{epoch}"
            );
            // Written with 10 decimals of a degree (0.2 micro-arcsecond) and 6 of a magnitude.
            let tol = if k == "MAG" { 5.1e-7 } else { 5.1e-11 };
            assert!((v - w).abs() <= tol, "{k} {v} vs truth {w}");
        }
        assert_eq!(s.data[0].1, m["START_TIME"]);
        assert_eq!(s.data[6].1, m["STOP_TIME"]);
    }
    segments.len()
}

#[test]
fn truth_tdm_follows_the_standard_and_the_truth() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("run");
    ok(run_quickstart(
        &[
            "--set",
            "images=5",
            "--set",
            "stages=[\"render\"]",
            "--set",
            "artifacts.tdm=true",
            "--quiet",
        ],
        &out,
    ));
    assert_eq!(check(&out, &out.join("export/tdm/truth.tdm")), 5);
    ok(soig(&["verify", out.to_str().unwrap()]));
    // `soig export --tdm` of the output writes the same file.
    let dest = tmp.path().join("export");
    ok(soig(&[
        "export",
        out.to_str().unwrap(),
        "--tdm",
        "--out",
        dest.to_str().unwrap(),
    ]));
    assert_eq!(
        std::fs::read(dest.join("tdm/truth.tdm")).unwrap(),
        std::fs::read(out.join("export/tdm/truth.tdm")).unwrap()
    );
    assert!(!dest.join("coco").exists() && !dest.join("ds9").exists());
}
