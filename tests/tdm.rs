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

use common::{arg, json, ok, ort_available, quickstart_with, scratch, soig};

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
    let (tmp, out) = scratch("run");
    ok(quickstart_with(
        &["images=5", "stages=[\"render\"]", "artifacts.tdm=true"],
        &out,
    ));
    assert_eq!(check(&out, &out.join("export/tdm/truth.tdm")), 5);
    ok(soig(&["verify", arg(&out)]));
    // `soig export --tdm` of the output writes the same file.
    let dest = tmp.path().join("export");
    ok(soig(&["export", arg(&out), "--tdm", "--out", arg(&dest)]));
    assert_eq!(
        std::fs::read(dest.join("tdm/truth.tdm")).unwrap(),
        std::fs::read(out.join("export/tdm/truth.tdm")).unwrap()
    );
    assert!(!dest.join("coco").exists() && !dest.join("ds9").exists());
}

/// ADES field names (ADES description, version 2017, the optical observation's fields) that
/// soig's PSV may use: a misspelt column fails here.
const ADES_FIELDS: [&str; 24] = [
    "permID", "provID", "artSat", "trkSub", "obsID", "trkID", "mode", "stn", "sys", "ctr", "pos1",
    "pos2", "pos3", "obsTime", "ra", "dec", "rmsRA", "rmsDec", "rmsCorr", "astCat", "mag",
    "rmsMag", "band", "remarks",
];

/// The detections' observations (`artifacts.astrometry`): each detector's TDM follows the
/// standard's keywords (the same parser as the truth's), its PSV is ADES (`# version=2017`,
/// `#` and `!` header lines, then a row of ADES field names and pipe-separated records), and
/// both carry the same angles, one per uncut streak end, in the same order.
#[test]
fn detections_tdm_and_ades_psv() {
    if !ort_available() {
        return;
    }
    let (_tmp, out) = scratch("run");
    ok(quickstart_with(&["artifacts.astrometry=true"], &out));
    ok(soig(&["verify", arg(&out)]));
    let (mut records, mut mags) = (0, 0);
    for det in ["streak", "yolo"] {
        let dir = out.join("report/observations");
        let (header, segments) =
            parse(&std::fs::read_to_string(dir.join(format!("{det}.tdm"))).unwrap());
        assert_eq!(header["CCSDS_TDM_VERS"], "2.0");
        let mut angles = Vec::new();
        for s in &segments {
            let m = &s.meta;
            assert_eq!(m["TIME_SYSTEM"], "UTC");
            assert_eq!(m["ANGLE_TYPE"], "RADEC");
            assert_eq!(m["REFERENCE_FRAME"], "ICRF");
            assert_eq!(m["PARTICIPANT_1"], "SENTINEL 3A");
            assert!(m["PARTICIPANT_2"].starts_with(det));
            assert!(!s.data.is_empty() && s.data.len() % 2 == 0);
            for pair in s.data.chunks(2) {
                assert_eq!(
                    (pair[0].0.as_str(), pair[1].0.as_str()),
                    ("ANGLE_1", "ANGLE_2")
                );
                assert_eq!(pair[0].1, pair[1].1);
                assert!(pair[0].1 == m["START_TIME"] || pair[0].1 == m["STOP_TIME"]);
                angles.push((pair[0].1.clone(), pair[0].2, pair[1].2));
            }
        }
        let text = std::fs::read_to_string(dir.join(format!("{det}.psv"))).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("# version=2017"));
        let columns: Vec<&str> = lines
            .find(|l| !l.starts_with('#') && !l.starts_with('!'))
            .unwrap()
            .split('|')
            .map(str::trim)
            .collect();
        for c in &columns {
            assert!(ADES_FIELDS.contains(c), "{c} is no ADES field");
        }
        let col = |name: &str| columns.iter().position(|c| *c == name).unwrap();
        let rows: Vec<Vec<&str>> = lines
            .map(|l| l.split('|').map(str::trim).collect())
            .collect();
        assert_eq!(
            rows.len(),
            angles.len(),
            "{det}: one PSV record per TDM angle pair"
        );
        for (row, (epoch, ra, dec)) in rows.iter().zip(&angles) {
            assert_eq!(row.len(), columns.len());
            let t = row[col("obsTime")];
            assert!(t.ends_with('Z') && is_epoch(&t[..t.len() - 1]), "{t}");
            assert_eq!(&t[..t.len() - 1], epoch);
            let (r, d): (f64, f64) = (
                row[col("ra")].parse().unwrap(),
                row[col("dec")].parse().unwrap(),
            );
            assert!((0.0..360.0).contains(&r) && (-90.0..=90.0).contains(&d));
            // PSV: 9 decimals of a degree; TDM: 10.
            assert!(
                (r - ra).abs() < 6e-10 && (d - dec).abs() < 6e-10,
                "{r} {d} vs {ra} {dec}"
            );
            assert_eq!((row[col("mode")], row[col("stn")]), ("CCD", "XXX"));
            assert_eq!(row[col("sys")], "ICRF_KM");
            // The streak detector gives an SNR, so an uncertainty; YOLO none.
            assert_eq!(row[col("rmsRA")].is_empty(), det == "yolo");
            // A magnitude comes with its band; a plausible one (the quickstart's are 10-14).
            let mag = row[col("mag")];
            assert_eq!(row[col("band")], if mag.is_empty() { "" } else { "V" });
            if !mag.is_empty() {
                let m: f64 = mag.parse().unwrap();
                assert!((5.0..20.0).contains(&m), "{m}");
                mags += 1;
            }
        }
        records += rows.len();
    }
    assert!(records > 0, "the quickstart's detections give observations");
    assert!(mags > 0, "and magnitudes where both ends are inside");
    let md = std::fs::read_to_string(out.join("report/astrometry.md")).unwrap();
    assert!(md.contains("| streak | all |") && md.contains("| yolo | all |"));
}

/// A catalogue scene's truth TDM (`[population]`, the GEO stare): one segment per object with
/// an ephemeris, in the sidecars' order, each with that object's angles.
#[test]
fn catalogue_scene_tdm_has_every_object() {
    let (_tmp, out) = scratch("run");
    let campaign = common::repo("campaigns/geo-stare.toml");
    ok(soig(&[
        "run",
        arg(&campaign),
        "--set",
        "images=2",
        "--set",
        "stages=[\"render\"]",
        "--set",
        "artifacts.coco=false",
        "--set",
        "artifacts.ds9_regions=false",
        "--set",
        "artifacts.tdm=true",
        "--quiet",
        "--out",
        arg(&out),
    ]));
    let (_, segments) = parse(&std::fs::read_to_string(out.join("export/tdm/truth.tdm")).unwrap());
    let mut want = Vec::new();
    for i in 0..2 {
        let t = json(&out.join(format!("truth/img_{i:06}.json")));
        for o in t["objects"].as_array().unwrap() {
            if !o["ephemeris"].is_null() {
                want.push(o.clone());
            }
        }
    }
    assert!(want.len() > 2, "the stare holds several objects");
    assert_eq!(segments.len(), want.len());
    for (s, o) in segments.iter().zip(&want) {
        assert!(s.meta["PARTICIPANT_2"].ends_with(&format!("(NORAD {})", o["norad"])));
        let start = &o["ephemeris"]["debris_radec_start_deg"];
        assert!((s.data[0].2 - start[0].as_f64().unwrap()).abs() <= 5.1e-11);
        assert!((s.data[1].2 - start[1].as_f64().unwrap()).abs() <= 5.1e-11);
    }
}
