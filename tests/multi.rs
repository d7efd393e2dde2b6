//! Several debris objects per frame, or none (`[objects]`, issue #34): a campaign with 1 to 3
//! objects in non-empty frames and a fifth of the frames empty runs, verifies, gives the same
//! digest on one thread and on two, and its labels, truth sidecars, COCO export, DS9 regions
//! and light curves agree object for object; pycocotools scores its COCO export as `soig eval
//! --mode coco` scores its label files. The committed campaigns/quickstart-multi.toml loads.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod common;

use std::path::{Path, PathBuf};

use common::{
    CampaignToml, CocoImage, ELEMENTS_40649, arg, assert_coco_agrees_with_soig_eval,
    assert_coco_bbox_is_label_box, coco_images, digest, export_readers_python, json, repo,
    run_on_threads, soig, tle_object,
};
use serde_json::Value;

/// 30 fixed-pointing images of four objects, 0-3 per frame (20% empty), split 50/25/25,
/// detected by the streak detector, with the COCO, DS9 and light-curve artifacts.
fn campaign(dir: &Path) -> PathBuf {
    CampaignToml::leo("multi", 11, 30)
        .stages(&["render", "enhance", "dataset", "detect"])
        .debris(&tle_object(40386))
        .debris(ELEMENTS_40649)
        .debris(&tle_object(40989))
        .tables(
            "[objects]\nper_frame = { min = 1, max = 3 }\nempty_share = 0.2\n\
             [split]\ntrain = 0.5\nval = 0.25\ntest = 0.25\n\
             [artifacts]\ncoco = true\nds9_regions = true\nlight_curve = true\n",
        )
        .write(&dir.join("multi.toml"))
}

#[test]
fn several_objects_or_none_per_frame_agree_everywhere() {
    let tmp = tempfile::tempdir().unwrap();
    let c = campaign(tmp.path());
    let out = tmp.path().join("one");
    let one = run_on_threads(&c, &out, "1");
    let two = run_on_threads(&c, &tmp.path().join("two"), "2");
    assert_eq!(one, two, "the digest depends on the thread count");
    let o = soig(&["verify", arg(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A run killed after 5 images resumes them (their light curves among their files) and
    // ends with the same digest.
    let resumed = tmp.path().join("resumed");
    let killed = std::process::Command::new(env!("CARGO_BIN_EXE_soig"))
        .env("RAYON_NUM_THREADS", "1")
        .env("SOIG_TEST_ABORT_AT", "render:5")
        .args(["run", arg(&c), "--out", arg(&resumed), "--quiet"])
        .output()
        .unwrap();
    assert!(!killed.status.success());
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_soig"))
        .args(["run", arg(&c), "--out", arg(&resumed)])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("(and 5 resumed)"), "{text}");
    assert_eq!(digest(&o), one);

    // Per image: label lines, truth objects with a label, COCO annotations, DS9 lines and
    // light-curve rows agree. A label file rounds the normalised box to 6 decimals: at most
    // 0.5e-6 x 1024 px = 5.1e-4 px per edge, so 1.1e-3 px on a width.
    let export = out.join("export");
    let (mut images, mut empty, mut most, mut objects) = (0, 0, 0, 0);
    let mut shown = std::collections::BTreeMap::<u64, usize>::new();
    for CocoImage {
        annotations: mine,
        stem,
        labels,
        truth,
        ..
    } in coco_images(&export, &out)
    {
        images += 1;
        assert!(truth.get("object").is_none(), "{stem}: a one-object truth");
        let listed = truth["objects"].as_array().unwrap();
        for o in listed {
            // Turned into the field, not where its orbit puts it: marked so (#45).
            assert_eq!(o["source"], "placed", "{stem}");
            *shown.entry(o["norad"].as_u64().unwrap()).or_default() += 1;
        }
        let labelled: Vec<&Value> = listed
            .iter()
            .filter(|o| !o["label_box_final_px"].is_null())
            .collect();
        assert_eq!(labels.lines().count(), labelled.len(), "{stem}");
        assert_eq!(mine.len(), labelled.len(), "{stem}");
        objects += listed.len();
        most = most.max(listed.len());
        if listed.is_empty() {
            empty += 1;
            assert_eq!(labels, "", "{stem}: an empty frame's label file is empty");
        }
        for (o, a) in labelled.iter().zip(&mine) {
            assert_coco_bbox_is_label_box(a, &o["label_box_final_px"], &stem);
            // Each annotation names its object: id and source as in the truth (#45).
            assert_eq!(a["object_id"], o["norad"], "{stem}");
            assert_eq!(a["source"], "placed", "{stem}");
            assert_eq!(a["object"], o["object"], "{stem}");
        }
        // One streak line per object in the DS9 truth regions, in the truth's order, each
        // labelled with its name and NORAD number.
        let reg = std::fs::read_to_string(export.join(format!("ds9/truth/{stem}.reg"))).unwrap();
        let lines: Vec<&str> = reg.lines().filter(|l| l.starts_with("line(")).collect();
        assert_eq!(lines.len(), listed.len(), "{stem}: {reg}");
        for (line, o) in lines.iter().zip(listed) {
            let text = format!(
                "# text={{{} (NORAD {})}}",
                o["object"].as_str().unwrap(),
                o["norad"]
            );
            assert!(line.ends_with(&text), "{stem}: {line}");
        }
        // The light curve: each object's rows in turn, as many as its trajectory samples
        // (at least render.trajectory_samples, 2000).
        let rows: Vec<csv::StringRecord> =
            csv::Reader::from_path(out.join(format!("truth/{stem}_light_curve.csv")))
                .unwrap()
                .into_records()
                .map(|r| r.unwrap())
                .collect();
        let mut at = 0;
        for o in listed {
            assert_eq!(&rows[at][1], o["object"].as_str().unwrap(), "{stem}");
            assert_eq!(&rows[at][3], "0", "{stem}");
            let n = rows[at + 1..]
                .iter()
                .position(|r| &r[3] == "0")
                .map_or(rows.len() - at, |p| p + 1);
            assert!(n >= 2000, "{stem}: {n} samples");
            at += n;
        }
        assert_eq!(at, rows.len(), "{stem}: rows beyond its objects");
    }
    assert_eq!(images, 30);
    // Seed 11 gives frames of every kind: some empty, some with three objects.
    assert!(
        empty > 0 && most == 3,
        "{empty} empty frames, at most {most}"
    );
    // The manifest's debris mix counts the images that show each object.
    let manifest = json(&out.join("manifest.json"));
    let mix = manifest["debris_mix"].as_array().unwrap();
    for m in mix {
        let norad = m["norad"].as_u64().unwrap();
        assert!(m["images"].as_u64().unwrap() as usize <= shown.get(&norad).copied().unwrap_or(0));
    }
    assert!(
        objects > images - empty,
        "{objects} objects in {images} images"
    );

    // The report counts every labelled object of the test split.
    let report = json(&out.join("report/report.json"));
    let test_labels: usize = std::fs::read_dir(out.join("labels/test"))
        .unwrap()
        .map(|e| {
            std::fs::read_to_string(e.unwrap().path())
                .unwrap()
                .lines()
                .count()
        })
        .sum();
    assert_eq!(
        report["objects"].as_u64(),
        Some(test_labels as u64),
        "{report}"
    );

    // pycocotools on the COCO files scores as soig eval on the text files.
    if let Some(py) = export_readers_python() {
        assert_coco_agrees_with_soig_eval(&py, &export, &out);
    }
}

#[test]
fn object_counts_are_checked_and_the_committed_campaign_loads() {
    let c = repo("campaigns/quickstart-multi.toml");
    let loaded = soig::campaign::Campaign::load(&c).unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.resolved.objects.is_some());
    for (objects, field) in [
        ("per_frame = { min = 3, max = 1 }", "objects.per_frame.max"),
        ("per_frame = 101", "objects.per_frame"),
        ("per_frame = 2\nempty_share = 1.5", "objects.empty_share"),
    ] {
        let e = CampaignToml::new("bad", 1, 2)
            .debris(ELEMENTS_40649)
            .tables(&format!("[objects]\n{objects}\n"))
            .text();
        let err = soig::campaign::Campaign::from_toml(&e, Path::new("bad.toml"))
            .err()
            .unwrap_or_else(|| panic!("{objects} accepted"))
            .to_string();
        assert!(
            err.contains(field) && err.contains("bad.toml:"),
            "{objects}: {err}"
        );
    }
}
