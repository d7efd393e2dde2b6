//! The COCO and DS9 exports (src/product/export/) read back by their own libraries: pycocotools scores
//! the COCO files exactly as `soig eval --mode coco` scores the YOLO text files, and
//! astropy-regions reads the region files back onto the truth sidecars and the COCO boxes.
//! `soig export` of the finished output writes the same bytes as the run's artifact.
//!
//! The Python readers (tests/reference/export_readers.py) need pycocotools and regions in the
//! project's .venv (`bash scripts/setup.sh`); without them the tests print why and pass, unless
//! SOIG_REQUIRE_EXPORT_READERS is set (scripts/test.sh sets it), then they fail.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod common;

use std::path::{Path, PathBuf};

use common::{
    CampaignToml, ELEMENTS_40649, arg, assert_coco_agrees_with_soig_eval,
    assert_coco_bbox_is_label_box, coco_images, digest, export_readers, export_readers_python,
    json, run_quiet, soig,
};
use serde_json::Value;

/// A run of 16 fixed-pointing images in the padded frame (so the DS9 boxes are mapped back
/// from the PNG), split 50/25/25, detected by the streak detector, with both exports.
fn run(dir: &Path) -> PathBuf {
    let campaign = CampaignToml::leo("exports", 7, 16)
        .stages(&["render", "enhance", "dataset", "detect"])
        .debris(ELEMENTS_40649)
        .tables(
            "[enhance]\ngeometry = \"padded\"\n\
             [split]\ntrain = 0.5\nval = 0.25\ntest = 0.25\n\
             [artifacts]\ncoco = true\nds9_regions = true\n",
        )
        .write(&dir.join("exports.toml"));
    let out = dir.join("out");
    let o = run_quiet(&campaign, &out);
    digest(&o);
    out
}

/// Bytes of every file under `dir`, by relative path.
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn exports_agree_with_labels_truth_and_soig_eval() {
    let tmp = tempfile::tempdir().unwrap();
    let out = run(tmp.path());
    let export = out.join("export");

    // `soig export` of the finished output: the same files, byte for byte, and it verifies.
    let again = tmp.path().join("again");
    let o = soig(&["export", arg(&out), "--out", arg(&again)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The same files, and the export's own manifest, which marks the folder as soig's export.
    let mut exported = tree(&again);
    exported.retain(|(p, _)| p != Path::new("manifest.json"));
    assert_eq!(tree(&export), exported);
    for dir in [&out, &again] {
        let o = soig(&["verify", arg(dir)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    // Exporting again into its own earlier export replaces it (#43: refused before).
    let o = soig(&["export", arg(&out), "--out", arg(&again)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(tree(&export), {
        let mut t = tree(&again);
        t.retain(|(p, _)| p != Path::new("manifest.json"));
        t
    });

    // Labels, truth and COCO agree: every image of every split, each label line one
    // annotation whose box is the truth's label box in the PNG frame. The label file rounds
    // the normalised box to 6 decimals: at most 0.5e-6 x 1088 px = 5.4e-4 px per edge, so
    // 1.1e-3 px on a width.
    let mut images = 0;
    for im in coco_images(&export, &out) {
        images += 1;
        let (stem, truth) = (&im.stem, &im.truth);
        let file = im.image["file_name"].as_str().unwrap();
        assert!(file.starts_with(&format!("images/{}/", im.split)), "{file}");
        let (w, h) = image::image_dimensions(out.join(file)).unwrap();
        assert_eq!(
            (im.image["width"].as_u64(), im.image["height"].as_u64()),
            (Some(w.into()), Some(h.into()))
        );
        assert_eq!(im.annotations.len(), im.labels.lines().count(), "{stem}");
        let ann = &im.annotations[0];
        let got = assert_coco_bbox_is_label_box(ann, &truth["label_box_final_px"], stem);
        // The annotation names its object (#45): the campaign's debris, its NORAD number.
        assert_eq!(ann["object_id"], truth["norad"], "{stem}");
        assert_eq!(ann["object"], truth["object"], "{stem}");
        assert_eq!(ann["source"], "debris", "{stem}");
        // serde_json's default float parser may miss the written value by an ulp.
        let area = ann["area"].as_f64().unwrap();
        assert!(
            (area - got[2] * got[3]).abs() <= 1e-12 * area,
            "{stem}: area {area}"
        );
    }
    assert_eq!(images, 16);

    let Some(py) = export_readers_python() else {
        return;
    };
    // pycocotools on the COCO files, soig eval on the text files: the same figures.
    let coco = assert_coco_agrees_with_soig_eval(&py, &export, &out);
    assert_eq!(coco["categories"], serde_json::json!(["debris"]));

    assert_ds9_regions_agree(&py, &export, &out);
}

/// astropy-regions reads the truth back (0-based pixels, as soig's), and each detection's
/// polygon is its COCO box moved from the PNG's padded frame to the FITS pixels.
fn assert_ds9_regions_agree(py: &Path, export: &Path, out: &Path) {
    // The files hold a thousandth of a pixel: 5e-4 px, and float noise beside it.
    let tol = 5.0e-4 + 1e-9;
    let stems: Vec<String> = json(&export.join("coco/test.json"))["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|im| format!("img_{:06}", im["id"].as_u64().unwrap()))
        .collect();
    let files: Vec<String> = stems
        .iter()
        .flat_map(|s| {
            [
                export.join(format!("ds9/truth/{s}.reg")),
                export.join(format!("ds9/streak/{s}.reg")),
            ]
        })
        .map(|p| p.to_str().unwrap().to_string())
        .collect();
    let mut args = vec!["regions"];
    args.extend(files.iter().map(String::as_str));
    let read = export_readers(py, &args);
    let dets = json(&export.join("coco/detections_streak.json"));
    let close = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < tol)
    };
    let xy = |r: &Value| -> Vec<f64> {
        r["xy"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    for (s, pair) in stems.iter().zip(files.chunks(2)) {
        let truth = json(&out.join(format!("truth/{s}.json")));
        let t = read[&pair[0]].as_array().unwrap();
        assert_eq!(t.len(), 2, "{s}: {t:?}");
        assert_eq!(t[0]["kind"], "LinePixelRegion");
        let text = format!(
            "{} (NORAD {})",
            truth["object"].as_str().unwrap(),
            truth["norad"]
        );
        assert_eq!(t[0]["text"], text.as_str());
        let p = |k: &str, i: usize| truth[k][i].as_f64().unwrap();
        let line = [
            p("streak_start_px", 0),
            p("streak_start_px", 1),
            p("streak_end_px", 0),
            p("streak_end_px", 1),
        ];
        assert!(close(&xy(&t[0]), &line), "{s}: {t:?} vs {line:?}");
        let b = &truth["label_box_px"];
        let f = |k: &str| b[k].as_f64().unwrap();
        let rect = [
            (f("x_min") + f("x_max")) / 2.0,
            (f("y_min") + f("y_max")) / 2.0,
            f("x_max") - f("x_min"),
            f("y_max") - f("y_min"),
            0.0,
        ];
        assert_eq!(t[1]["kind"], "RectanglePixelRegion");
        assert!(close(&xy(&t[1]), &rect), "{s}: {t:?} vs {rect:?}");

        let pad = truth["frame"]["matrix"][0][2].as_f64().unwrap();
        assert!(pad > 0.0);
        let id = s[4..].parse::<u64>().unwrap();
        let boxes: Vec<&Value> = dets
            .as_array()
            .unwrap()
            .iter()
            .filter(|d| d["image_id"] == id)
            .collect();
        let polys = read[&pair[1]].as_array().unwrap();
        assert_eq!(polys.len(), boxes.len(), "{s}");
        for (poly, d) in polys.iter().zip(boxes) {
            let bb: Vec<f64> = d["bbox"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            // PNG edges to 0-based pixel centres (- 0.5), then the border off.
            let (x1, y1) = (bb[0] - 0.5 - pad, bb[1] - 0.5 - pad);
            let (x2, y2) = (x1 + bb[2], y1 + bb[3]);
            assert_eq!(poly["kind"], "PolygonPixelRegion");
            assert!(
                close(&xy(poly), &[x1, y1, x2, y1, x2, y2, x1, y2]),
                "{s}: {poly} vs {bb:?}"
            );
        }
    }
}

#[test]
fn export_refuses_an_output_that_does_not_verify_and_a_folder_inside_it() {
    let tmp = tempfile::tempdir().unwrap();
    let out = run(tmp.path());
    let o = soig(&["export", arg(&out), "--out", arg(&out.join("x"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("lies inside the output"));
    assert!(!out.join("x").exists());
    // A folder holding a user's file is not written into: the export goes whole into a new
    // (or empty) folder, never over a file of the user's.
    let mine = tmp.path().join("mine");
    std::fs::create_dir_all(mine.join("coco")).unwrap();
    std::fs::write(mine.join("coco/test.json"), "the user's").unwrap();
    let o = soig(&["export", arg(&out), "--out", arg(&mine)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("refusing to overwrite it"));
    assert_eq!(
        std::fs::read_to_string(mine.join("coco/test.json")).unwrap(),
        "the user's"
    );
    // Another soig output (not an export) is not replaced by an export either.
    let other = tmp.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("tables.md"), "soig's").unwrap();
    soig::manifest::Manifest::build(&other, "h", serde_json::json!({}), &[])
        .unwrap()
        .write(&other)
        .unwrap();
    let o = soig(&["export", arg(&out), "--out", arg(&other)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("not an export"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(other.join("tables.md")).unwrap(),
        "soig's"
    );
    std::fs::write(out.join("labels/test/extra.txt"), "0 0.5 0.5 0.1 0.1\n").unwrap();
    let o = soig(&["export", arg(&out), "--out", arg(&tmp.path().join("e"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("does not verify"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!tmp.path().join("e").exists());
}
