//! `soig enhance`: the paper's FITS -> PNG conversion on its own gives, on a soig FITS, the PNG
//! the run wrote, byte for byte; bad inputs end with exit 2 and leave no output.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::path::{Path, PathBuf};

mod common;
use common::{CampaignToml, ELEMENTS_40649, arg, run_quiet, soig};

/// A run of 4 small fixed-pointing images (FITS and PNG); returns its folder.
fn small_run(dir: &Path) -> (PathBuf, PathBuf) {
    let campaign = CampaignToml::leo("small", 11, 4)
        .debris(ELEMENTS_40649)
        .tables("[sensor]\nwidth_px = 256\nheight_px = 256\nfov_radius_deg = 0.025\n[render]\ntrajectory_samples = 500\n")
        .write(&dir.join("small.toml"));
    let out = dir.join("run");
    let o = run_quiet(&campaign, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (campaign, out)
}

fn find(dir: &Path, name: &str) -> PathBuf {
    for sub in ["train", "val", "test"] {
        let p = dir.join("images").join(sub).join(name);
        if p.is_file() {
            return p;
        }
    }
    panic!("{name} not in {}", dir.display());
}

#[test]
fn a_soig_fits_converts_to_the_png_the_run_wrote() {
    let tmp = tempfile::tempdir().unwrap();
    let (campaign, run) = small_run(tmp.path());
    let fits: Vec<String> = (0..4)
        .map(|i| {
            run.join("fits")
                .join(format!("img_{i:06}.fits"))
                .to_str()
                .unwrap()
                .to_string()
        })
        .collect();
    let out = tmp.path().join("enhanced");
    let mut args = vec!["enhance", "--campaign", arg(&campaign)];
    args.extend(fits.iter().map(String::as_str));
    args.extend(["--out", arg(&out)]);
    let o = soig(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for i in 0..4 {
        let name = format!("img_{i:06}.png");
        assert_eq!(
            std::fs::read(out.join(&name)).unwrap(),
            std::fs::read(find(&run, &name)).unwrap(),
            "{name}"
        );
    }
    // The manifest verifies, and a flag that changes the enhancement changes the PNG.
    let v = soig(&["verify", arg(&out)]);
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stdout));
    let other = tmp.path().join("gamma");
    let o = soig(&[
        "enhance",
        "--campaign",
        arg(&campaign),
        &fits[0],
        "--gamma",
        "1.0",
        "--out",
        arg(&other),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_ne!(
        std::fs::read(other.join("img_000000.png")).unwrap(),
        std::fs::read(out.join("img_000000.png")).unwrap()
    );
}

#[test]
fn bad_inputs_fail_cleanly_and_leave_the_inputs_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, run) = small_run(tmp.path());
    let fits_dir = run.join("fits");
    let fits = fits_dir.join("img_000000.fits");
    let fits = arg(&fits);
    let png = find(&run, "img_000000.png");
    let before = std::fs::read_dir(&fits_dir).unwrap().count();
    let out = tmp.path().join("out");
    // The inputs and options, the output folder, and what the error says.
    for (args, to, expect) in [
        (vec![arg(&png)], &out, "already an 8-bit enhanced image"),
        (vec!["/nonexistent/x.fits"], &out, "/nonexistent/x.fits"),
        (vec![fits], &fits_dir, "refusing to write"),
        (
            vec![fits, "--clahe-tiles", "0x8"],
            &out,
            "--clahe-tiles 0x8",
        ),
        (vec![fits, "--gamma", "NaN"], &out, "--gamma NaN"),
        (vec![fits, fits], &out, "same file stem"),
    ] {
        let mut a = vec!["enhance"];
        a.extend(args);
        a.extend(["--out", arg(to)]);
        let o = soig(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {err}");
        assert!(err.contains(expect), "{a:?}: {err}");
        assert!(!out.exists(), "{a:?} left an output");
    }
    assert_eq!(std::fs::read_dir(run.join("fits")).unwrap().count(), before);
}
