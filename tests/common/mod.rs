//! What the integration tests share: the repository's copies of the data they read (see
//! campaigns/data/README.md and tests/fixtures/neossat/README.md) and one builder of campaign
//! TOML.

// Each test crate compiles this module and uses its own part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

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

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// The TLE catalogue of 2022-01-22 (the paper's objects and both observers).
pub fn tle_file() -> PathBuf {
    repo("campaigns/data/catalog-2022-01-22.tle")
}

/// A real NEOSSat frame, 512 x 512, 10 s.
pub fn neossat_frame() -> PathBuf {
    repo("tests/fixtures/neossat/NEOS_SCI_2024239174545_cord.fits")
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
        ..Experiment::new(c)
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
