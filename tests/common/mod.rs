//! What the integration tests share: the repository's copies of the data they read (see
//! campaigns/data/README.md and tests/fixtures/neossat/README.md) and one builder of campaign
//! TOML.

// Each test crate compiles this module and uses its own part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

use soig::background::RealFrame;
use soig::campaign::Campaign;
use soig::experiment::{self, Experiment};
use soig::simulate::{self, ImageProducts};

/// Run the `soig` binary under test.
pub fn soig(args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_soig"))
        .args(args)
        .output()
        .expect("soig runs")
}

/// `o`, a run of `soig` that must have succeeded (its stdout and stderr shown if not).
pub fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "soig failed: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// A path as a command-line argument (the tests' paths are UTF-8).
pub fn arg(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A fresh temporary folder and the path `name` inside it (not yet made): where a test's run
/// writes. Keep the folder alive as long as the path is used.
pub fn scratch(name: &str) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join(name);
    (tmp, out)
}

/// The numbers of a JSON array (a bbox, a point), in order; panics if it is not one.
pub fn f64s(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Run the `soig` binary under test from directory `cwd`.
pub fn soig_in(cwd: &Path, args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_soig"))
        .current_dir(cwd)
        .args(args)
        .output()
        .expect("soig runs")
}

/// A command that must fail with exit 2 and a message holding `expect`, without a panic.
pub fn assert_refused(o: &Output, expect: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains(expect), "expected {expect:?} in: {err}");
}

/// `soig run CAMPAIGN --quiet --out OUT`.
pub fn run_quiet(campaign: &Path, out: &Path) -> Output {
    soig(&["run", arg(campaign), "--quiet", "--out", arg(out)])
}

/// `soig run campaigns/quickstart.toml --quiet --set S ... --out OUT`, a `--set` for each of
/// `sets` (`key=value`).
pub fn quickstart_with(sets: &[&str], out: &Path) -> Output {
    let mut args = vec!["--quiet"];
    for s in sets {
        args.extend(["--set", s]);
    }
    run_quickstart(&args, out)
}

/// `soig run campaigns/quickstart.toml ARGS --out OUT`.
pub fn run_quickstart(args: &[&str], out: &Path) -> Output {
    let campaign = repo("campaigns/quickstart.toml");
    let mut all = vec!["run", arg(&campaign)];
    all.extend(args);
    all.extend(["--out", arg(out)]);
    soig(&all)
}

/// `soig run` of the repository's campaign `campaign` with `args`, quietly into a fresh
/// folder, which must succeed: the folder (keep it alive), the output in it and its
/// report/report.json.
pub fn run_report(
    campaign: &str,
    args: &[&str],
) -> (tempfile::TempDir, PathBuf, serde_json::Value) {
    let (tmp, out) = scratch("run");
    let campaign = repo(campaign);
    let mut all = vec!["run", arg(&campaign)];
    all.extend(args);
    all.extend(["--quiet", "--out", arg(&out)]);
    ok(soig(&all));
    let report = json(&out.join("report/report.json"));
    (tmp, out, report)
}

/// `soig run CAMPAIGN --out OUT --quiet` on `threads` rayon threads, which must succeed; its
/// digest.
pub fn run_on_threads(campaign: &Path, out: &Path, threads: &str) -> String {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_soig"))
        .env("RAYON_NUM_THREADS", threads)
        .args(["run", arg(campaign), "--out", arg(out), "--quiet"])
        .output()
        .expect("soig runs");
    digest(&o)
}

/// Run `campaign` into `dir/one` on one thread and `dir/two` on two: the same digest, and
/// `soig verify` accepts the first. Returns `dir/one`.
pub fn run_on_one_and_two_threads_and_verify(campaign: &Path, dir: &Path) -> PathBuf {
    let (one, two) = (dir.join("one"), dir.join("two"));
    assert_eq!(
        run_on_threads(campaign, &one, "1"),
        run_on_threads(campaign, &two, "2"),
        "the digest depends on the thread count"
    );
    let v = soig(&["verify", arg(&one)]);
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stderr));
    one
}

/// A JSON file, parsed; panics naming the file.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(
        &std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The project's Python with the export readers (pycocotools, regions: `scripts/setup.sh`).
/// Without them the test says why and passes, unless SOIG_REQUIRE_EXPORT_READERS is set
/// (scripts/test.sh sets it): then it fails.
pub fn export_readers_python() -> Option<PathBuf> {
    let py = repo(".venv/bin/python3");
    let ok = std::process::Command::new(&py)
        .args(["-c", "import pycocotools.cocoeval, regions"])
        .status()
        .is_ok_and(|s| s.success());
    match (
        ok,
        std::env::var_os("SOIG_REQUIRE_EXPORT_READERS").is_some(),
    ) {
        (true, _) => Some(py),
        (false, true) => panic!(
            "{} lacks pycocotools or regions: run scripts/setup.sh",
            py.display()
        ),
        (false, false) => {
            eprintln!(
                "skipping: {} lacks pycocotools or regions (scripts/setup.sh)",
                py.display()
            );
            None
        }
    }
}

/// `soig eval --labels LABELS --predictions PREDICTIONS ARGS --json`, which must succeed:
/// what it printed.
pub fn eval_json(labels: &Path, predictions: &Path, args: &[&str]) -> serde_json::Value {
    let mut all = vec![
        "eval",
        "--labels",
        arg(labels),
        "--predictions",
        arg(predictions),
    ];
    all.extend_from_slice(args);
    all.push("--json");
    serde_json::from_slice(&ok(soig(&all)).stdout).unwrap()
}

/// tests/reference/export_readers.py with these arguments: what the libraries read, as JSON.
pub fn export_readers(py: &Path, args: &[&str]) -> serde_json::Value {
    let out = std::process::Command::new(py)
        .arg(repo("tests/reference/export_readers.py"))
        .args(args)
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// pycocotools on the COCO export of run `out` (in `export`: its test split and the streak
/// detector's detections) and `soig eval --mode coco` on the run's text files give the same
/// AP, AP50, AP75 and AR100, to the last bit: soig's COCO metric repeats pycocotools' (and
/// numpy's) arithmetic step for step (crates/detect/src/metrics/), on the same floats. Returns
/// pycocotools' figures.
pub fn assert_coco_agrees_with_soig_eval(
    py: &Path,
    export: &Path,
    out: &Path,
) -> serde_json::Value {
    let coco = export_readers(
        py,
        &[
            "coco",
            arg(&export.join("coco/test.json")),
            arg(&export.join("coco/detections_streak.json")),
        ],
    );
    let soig_eval = eval_json(
        &out.join("labels/test"),
        &out.join("report/predictions/streak"),
        &["--mode", "coco", "--images", arg(&out.join("images/test"))],
    );
    assert!(
        coco["ap50"].as_f64().unwrap() > 0.0,
        "a test set the detector finds nothing in tests nothing: {coco}"
    );
    for k in ["ap", "ap50", "ap75", "ar100"] {
        assert_eq!(
            coco[k].as_f64(),
            soig_eval[k].as_f64(),
            "{k}: pycocotools {coco}, soig {soig_eval}"
        );
    }
    coco
}

pub fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// The TLE catalogue of 2022-01-22 (the paper's objects and both observers).
pub fn tle_file() -> PathBuf {
    repo("campaigns/data/catalog-2022-01-22.tle")
}

/// The real NEOSSat frames of tests/fixtures/neossat/.
pub const NEOSSAT_FRAMES: [&str; 3] = [
    "NEOSSAT_240__30_2020214095318.fits",
    "NEOSSAT_240__30_2026025124741.fits",
    "NEOS_SCI_2024239174545_cord.fits",
];

/// NEOSSat frame `name` of tests/fixtures/neossat/, loaded.
pub fn real_frame(name: &str) -> RealFrame {
    RealFrame::load(&repo("tests/fixtures/neossat").join(name)).unwrap()
}

/// A real NEOSSat frame, 512 x 512, 10 s.
pub fn neossat_frame() -> PathBuf {
    repo("tests/fixtures/neossat/NEOS_SCI_2024239174545_cord.fits")
}

/// The repository's .venv Python when it has astropy; else None, the test saying it skips
/// (a failure where SOIG_REQUIRE_ONNXRUNTIME says the set-up is complete).
pub fn python_with_astropy() -> Option<PathBuf> {
    let python = repo(".venv/bin/python3");
    let has_astropy = std::process::Command::new(&python)
        .args(["-c", "import astropy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_astropy {
        assert!(
            std::env::var_os("SOIG_REQUIRE_ONNXRUNTIME").is_none(),
            "no astropy in .venv: run scripts/setup.sh"
        );
        eprintln!("skipped: no astropy in .venv (scripts/setup.sh installs it)");
    }
    has_astropy.then_some(python)
}

/// The body of an object table for NORAD `norad` of `tle_file()`.
pub fn tle_object(norad: u64) -> String {
    format!("tle_file = \"{}\"\nnorad = {norad}", tle_file().display())
}

/// The paper's NORAD 40649, which has no public TLE: the orbit of its Table 1.
pub const ELEMENTS_40649: &str = "norad = 40649\nelements = { period_min = 375.48, inclination_deg = 52.78, apogee_km = 20490.0, perigee_km = 1235.0 }";

/// A campaign's TOML text, written in this order (tests count lines): `name`, `seed`, `images`,
/// further top-level keys, `[observer]` (SENTINEL 3A unless set), each `[[debris]]`, then
/// further tables.
pub struct CampaignToml {
    head: String,
    top: String,
    observer: String,
    debris: Vec<String>,
    tables: String,
}

impl CampaignToml {
    pub fn new(name: &str, seed: u64, images: u32) -> CampaignToml {
        CampaignToml {
            head: format!("name = \"{name}\"\nseed = {seed}\nimages = {images}\n"),
            top: String::new(),
            observer: tle_object(41335),
            debris: Vec::new(),
            tables: String::new(),
        }
    }

    /// `new` with the LEO object of the TLE file (NORAD 37476) as its first debris: most
    /// tests' one moving object.
    pub fn leo(name: &str, seed: u64, images: u32) -> CampaignToml {
        CampaignToml::new(name, seed, images).debris(&tle_object(37476))
    }

    /// The run's `stages`, in order (a top-level key).
    pub fn stages(self, stages: &[&str]) -> CampaignToml {
        let quoted: Vec<String> = stages.iter().map(|s| format!("\"{s}\"")).collect();
        self.top(&format!("stages = [{}]\n", quoted.join(", ")))
    }

    /// Top-level keys (e.g. `stages = [...]`), which TOML wants before the first table.
    pub fn top(mut self, keys: &str) -> CampaignToml {
        self.top.push_str(keys);
        self
    }

    /// The body of the `[observer]` table.
    pub fn observer(mut self, body: &str) -> CampaignToml {
        self.observer = body.to_string();
        self
    }

    /// One more `[[debris]]` table with this body.
    pub fn debris(mut self, body: &str) -> CampaignToml {
        self.debris.push(body.to_string());
        self
    }

    /// Tables after the objects, e.g. `[sensor]\nwidth_px = 256\n`.
    pub fn tables(mut self, toml: &str) -> CampaignToml {
        self.tables.push_str(toml);
        self
    }

    pub fn text(&self) -> String {
        let debris: String = self
            .debris
            .iter()
            .map(|d| format!("[[debris]]\n{d}\n"))
            .collect();
        format!(
            "{}{}[observer]\n{}\n{debris}{}\n",
            self.head, self.top, self.observer, self.tables
        )
    }

    /// The campaign, named `name` in messages; panics with the error.
    pub fn load(&self, name: &str) -> Campaign {
        Campaign::from_toml(&self.text(), Path::new(name)).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Write the text to `path` and return it.
    pub fn write(&self, path: &Path) -> PathBuf {
        std::fs::write(path, self.text()).unwrap();
        path.to_path_buf()
    }
}

/// Images of 512 px at the paper's pixel scale (0.7"; field radius 0.05 deg), seed 11, 4
/// images, of a LEO (NORAD 37476) and a GEO object (40989) in pointing `mode`; `tables` go
/// between `[pointing]` and `[sensor]`.
pub fn leo_and_geo(name: &str, mode: &str, tables: &str) -> CampaignToml {
    CampaignToml::leo(name, 11, 4)
        .debris(&tle_object(40989))
        .tables(&format!(
            "[pointing]\nmode = \"{mode}\"\n{tables}[sensor]\nwidth_px = 512\nheight_px = 512\nfov_radius_deg = 0.05\n"
        ))
}

/// `images` images of 128 px (field radius 0.0125 deg, 300 trajectory samples) of a LEO
/// (NORAD 37476) and 40649, every stage to detect, split 0.5 / 0.2 / 0.3, with `tables`
/// after: the small detecting run the resume and shard tests interrupt and merge.
pub fn small_detecting_run(name: &str, seed: u64, images: u32, tables: &str) -> CampaignToml {
    CampaignToml::leo(name, seed, images)
        .stages(&["render", "enhance", "dataset", "detect"])
        .debris(ELEMENTS_40649)
        .tables("[sensor]\nwidth_px = 128\nheight_px = 128\nfov_radius_deg = 0.0125\n[render]\ntrajectory_samples = 300\n[split]\ntrain = 0.5\nval = 0.2\ntest = 0.3\n")
        .tables(tables)
}

/// The digest a `soig` command that must succeed printed.
pub fn digest(o: &Output) -> String {
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
        .lines()
        .find_map(|l| l.strip_prefix("digest "))
        .unwrap_or_else(|| panic!("no digest in {stdout}"))
        .to_string()
}

/// Images 0..n of a campaign as `soig run` renders them, in memory, without the 8-bit product.
pub fn rendered(c: &Campaign, n: u64) -> Vec<ImageProducts> {
    let x = Experiment {
        product: None,
        ..experiment::of(c)
    };
    let inputs = experiment::inputs(c).unwrap();
    (0..n)
        .map(|i| simulate::image(&x, &inputs, i).unwrap())
        .collect()
}

/// Whether ONNX Runtime is there for the YOLO detector: else the test says why and passes,
/// unless SOIG_REQUIRE_ONNXRUNTIME is set (the test command sets it), so the detector tests
/// can never pass by skipping there.
pub fn ort_available() -> bool {
    match soig::detect::yolo::find_onnxruntime() {
        Ok(_) => true,
        Err(e) if std::env::var_os("SOIG_REQUIRE_ONNXRUNTIME").is_some() => panic!("{e}"),
        Err(e) => {
            eprintln!("skipping: {e}");
            false
        }
    }
}

/// The files whose sha256 differs between the manifests of outputs `a` and `b` (or that only
/// one lists): what a digest mismatch is made of, for the failure message.
#[allow(dead_code)]
pub fn differing_files(a: &Path, b: &Path) -> Vec<String> {
    let files = |dir: &Path| -> std::collections::BTreeMap<String, String> {
        let text = std::fs::read_to_string(dir.join("manifest.json")).unwrap_or_default();
        let m: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        m["files"]
            .as_object()
            .map(|f| {
                f.iter()
                    .map(|(k, v)| (k.clone(), v["sha256"].as_str().unwrap_or("").to_string()))
                    .collect()
            })
            .unwrap_or_default()
    };
    let (fa, fb) = (files(a), files(b));
    let mut names: Vec<String> = fa.keys().chain(fb.keys()).cloned().collect();
    names.sort();
    names.dedup();
    names.retain(|n| fa.get(n) != fb.get(n));
    names
}

/// A COCO annotation's bbox is the truth's label box in the final frame (pixel centres at
/// integers there, so its edges are +0.5), as written: to a thousandth of a pixel (1e-3, and
/// a tenth of it for the float noise of the subtraction). Returns the bbox.
pub fn assert_coco_bbox_is_label_box(
    annotation: &serde_json::Value,
    label_box_final_px: &serde_json::Value,
    stem: &str,
) -> Vec<f64> {
    let edge = |k: &str| label_box_final_px[k].as_f64().unwrap() + 0.5;
    let want = [
        edge("x_min"),
        edge("y_min"),
        edge("x_max") - edge("x_min"),
        edge("y_max") - edge("y_min"),
    ];
    let got = f64s(&annotation["bbox"]);
    for k in 0..4 {
        assert!(
            (got[k] - want[k]).abs() < 1.1e-3,
            "{stem}: bbox {got:?}, truth {want:?}"
        );
    }
    got
}

/// The COCO export of run `out` (`artifacts.coco`, in `out/export/coco`) against its label files
/// and truth sidecars, image by image: one annotation per label line and per labelled object
/// of the truth (the image's own, or each of `objects` with `[objects]`), each bbox its label
/// box (`assert_coco_bbox_is_label_box`). Returns the number of annotations.
pub fn assert_coco_agrees_with_labels_and_truth(out: &Path) -> usize {
    let mut annotations = 0;
    for im in coco_images(&out.join("export"), out) {
        let (truth, stem) = (&im.truth, &im.stem);
        let boxes: Vec<&serde_json::Value> = match truth["objects"].as_array() {
            Some(objects) => objects.iter().map(|o| &o["label_box_final_px"]).collect(),
            None => vec![&truth["label_box_final_px"]],
        };
        let boxes: Vec<_> = boxes.into_iter().filter(|b| !b.is_null()).collect();
        assert_eq!(im.labels.lines().count(), boxes.len(), "{stem}");
        assert_eq!(im.annotations.len(), boxes.len(), "{stem}");
        for (a, b) in im.annotations.iter().zip(boxes) {
            assert_coco_bbox_is_label_box(a, b, stem);
        }
        annotations += im.annotations.len();
    }
    annotations
}

/// One image of a run's COCO export, beside what the run wrote for it.
pub struct CocoImage {
    pub split: &'static str,
    /// Its COCO `images` entry and its annotations, in the file's order.
    pub image: serde_json::Value,
    pub annotations: Vec<serde_json::Value>,
    /// `img_NNNNNN`, the text of its label file and its truth sidecar.
    pub stem: String,
    pub labels: String,
    pub truth: serde_json::Value,
}

/// Every image of the COCO export in `export` (`coco/{split}.json` of each split that has
/// one) of the run in `out`, split by split.
pub fn coco_images(export: &Path, out: &Path) -> Vec<CocoImage> {
    let mut images = Vec::new();
    for split in ["train", "val", "test"] {
        let path = export.join(format!("coco/{split}.json"));
        if !path.exists() {
            continue;
        }
        let coco = json(&path);
        let anns = coco["annotations"].as_array().unwrap();
        for im in coco["images"].as_array().unwrap() {
            let id = im["id"].as_u64().unwrap();
            let stem = format!("img_{id:06}");
            let labels_file = out.join(format!("labels/{split}/{stem}.txt"));
            images.push(CocoImage {
                split,
                image: im.clone(),
                annotations: anns
                    .iter()
                    .filter(|a| a["image_id"] == id)
                    .cloned()
                    .collect(),
                labels: std::fs::read_to_string(&labels_file)
                    .unwrap_or_else(|e| panic!("{}: {e}", labels_file.display())),
                truth: json(&out.join(format!("truth/{stem}.json"))),
                stem,
            });
        }
    }
    images
}

/// Arcseconds between two (RA, Dec) in degrees, given as JSON pairs (a small-angle form: the
/// catalogue checks compare places under 1" apart).
pub fn separation_arcsec(a: &serde_json::Value, b: &serde_json::Value) -> f64 {
    let (ra1, de1) = (a[0].as_f64().unwrap(), a[1].as_f64().unwrap());
    let (ra2, de2) = (b[0].as_f64().unwrap(), b[1].as_f64().unwrap());
    let dra = ((ra1 - ra2 + 540.0) % 360.0 - 180.0) * de1.to_radians().cos();
    dra.hypot(de1 - de2) * 3600.0
}

/// Pixels between two pixel positions given as JSON pairs.
pub fn px_off(a: &serde_json::Value, b: &serde_json::Value) -> f64 {
    let d = |k: usize| a[k].as_f64().unwrap() - b[k].as_f64().unwrap();
    d(0).hypot(d(1))
}

/// A reference frame's objects (python-sgp4 + astropy, tests/reference/), by NORAD number.
pub fn reference_objects(
    frame: &serde_json::Value,
) -> std::collections::BTreeMap<u64, &serde_json::Value> {
    frame["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| (o["norad"].as_u64().unwrap(), o))
        .collect()
}

/// The truth's unseen objects, each with a reason, join the `accounted` (shown) ones; then
/// every object the reference puts in the field must be one of them. Returns how many were
/// unseen.
pub fn account_for_the_field(
    truth: &serde_json::Value,
    reference: &std::collections::BTreeMap<u64, &serde_json::Value>,
    mut accounted: std::collections::BTreeSet<u64>,
    stem: &str,
) -> usize {
    let unseen = truth["unseen"].as_array().unwrap();
    for u in unseen {
        assert!(!u["reason"].as_str().unwrap().is_empty());
        accounted.insert(u["norad"].as_u64().unwrap());
    }
    for (norad, r) in reference {
        if r["in_field"].as_bool().unwrap() {
            assert!(
                accounted.contains(norad),
                "{stem}: NORAD {norad} is in the field but neither shown nor unseen"
            );
        }
    }
    unseen.len()
}
