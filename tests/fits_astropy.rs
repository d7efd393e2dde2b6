//! The FITS `soig run` writes, read by astropy as an astronomer would: every header card
//! parses, BUNIT is a unit of the FITS standard, the WCS loads, and the keywords of a
//! space-based exposure are there (telescope, instrument, observer and its GCRS state, start,
//! middle and end of the exposure), and the truth's pixel convention is the WCS's (0-based
//! pixel centres). Needs astropy in the project's .venv (scripts/setup.sh);
//! without it the test says so and passes, unless SOIG_REQUIRE_ONNXRUNTIME is set (the test
//! command, scripts/test.sh, sets it after the set-up), when it fails.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::process::Command;

mod common;
use common::{python_with_astropy, quickstart_with, scratch};

const CHECK: &str = r#"
import sys, warnings
from astropy.io import fits
from astropy import units as u
from astropy.time import Time
from astropy.wcs import WCS
warnings.simplefilter("error")  # a card astropy has to fix or guess at fails the test
for path in sys.argv[1:]:
    with fits.open(path) as hdul:
        hdul.verify("exception")
        h = hdul[0].header
        for card in h.cards:
            card.verify("exception")
            _ = card.value
        unit = u.Unit(h["BUNIT"], format="fits")
        for key in ["TELESCOP", "INSTRUME", "OBSERVER", "DATE-OBS", "DATE-AVG", "DATE-END",
                    "OBSPOS-X", "OBSPOS-Y", "OBSPOS-Z", "OBSVEL-X", "OBSVEL-Y", "OBSVEL-Z"]:
            assert key in h, f"{path}: no {key}"
        start, mid, end = (Time(h[k], scale="utc") for k in ["DATE-OBS", "DATE-AVG", "DATE-END"])
        # The cards are truncated to the microsecond, so each is within 1 us of its instant.
        assert abs((mid - start).sec - h["EXPTIME"] / 2) < 2e-6, (mid - start).sec
        assert abs((end - start).sec - h["EXPTIME"]) < 2e-6, (end - start).sec
        # A low Earth orbit: 6500-8000 km from the Earth's centre at 6.5-8 km/s.
        r = sum(h[f"OBSPOS-{a}"] ** 2 for a in "XYZ") ** 0.5
        v = sum(h[f"OBSVEL-{a}"] ** 2 for a in "XYZ") ** 0.5
        assert 6500 < r < 8000 and 6.5 < v < 8, (r, v)
        wcs = WCS(h)
        # The truth's convention (0-based pixel centres at integers) is the WCS's with origin 0:
        # its streak ends and the RA/Dec it says the WCS gives there agree to 1e-6 deg (0.005 px;
        # the cards hold 15+ digits).
        import json
        truth = path.replace("/fits/", "/truth/").replace("_clean.fits", ".fits")[:-5] + ".json"
        t = json.load(open(truth))
        for end in ["start", "end"]:
            (x, y), (ra, dec) = t[f"streak_{end}_px"], t[f"streak_{end}_wcs_radec_deg"]
            wra, wdec = wcs.all_pix2world(x, y, 0)
            assert abs(wra - ra) < 1e-6 and abs(wdec - dec) < 1e-6, (end, wra, wdec, ra, dec)
        print(path.rsplit("/", 1)[-1], unit, h["TELESCOP"], h["DATE-AVG"])
"#;

#[test]
fn astropy_parses_every_card_and_unit_of_both_fits() {
    let Some(python) = python_with_astropy() else {
        return;
    };
    let (_dir, out) = scratch("run");
    let o = quickstart_with(&["images=2", "stages=[\"render\"]"], &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut files: Vec<_> = std::fs::read_dir(out.join("fits"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    // The quickstart writes the noisy and the noise-free FITS of each image.
    assert_eq!(files.len(), 4, "{files:?}");
    let o = Command::new(python)
        .arg("-c")
        .arg(CHECK)
        .args(&files)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{said}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(said.contains("_clean.fits ct "), "{said}");
    assert!(said.contains(".fits adu "), "{said}");
}
