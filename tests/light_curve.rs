//! The light-curve table (`artifacts.light_curve`, src/product/light_curve.rs) against the truth
//! sidecar of the same image: one row per trajectory sample, its electrons summing to the
//! truth's expected debris electrons and its magnitudes spanning the truth's range.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

mod common;

use common::{CampaignToml, ELEMENTS_40649, digest, run_quiet};

#[test]
fn light_curves_match_the_truth_row_for_row() {
    let tmp = tempfile::tempdir().unwrap();
    let campaign = CampaignToml::leo("curves", 11, 4)
        .stages(&["render"])
        .debris(ELEMENTS_40649)
        .tables("[render]\ntrajectory_samples = 300\n[artifacts]\nlight_curve = true\n")
        .write(&tmp.path().join("curves.toml"));
    let out = tmp.path().join("out");
    digest(&run_quiet(&campaign, &out));
    for i in 0..4 {
        let truth: serde_json::Value = serde_json::from_slice(
            &std::fs::read(out.join(format!("truth/img_{i:06}.json"))).unwrap(),
        )
        .unwrap();
        let path = out.join(format!("truth/img_{i:06}_light_curve.csv"));
        let mut r = csv::Reader::from_path(&path).unwrap();
        let head: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(
            head.join(","),
            "image,object,norad,sample,t_s,utc,magnitude,electrons_per_s,electrons,x_px,y_px"
        );
        let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
        // 300 samples unless the streak was too fast for them (then more, never fewer).
        assert!(rows.len() >= 300, "{}", rows.len());
        let f = |row: &csv::StringRecord, k: usize| row[k].parse::<f64>().unwrap();
        let exposure = truth["exposure_s"].as_f64().unwrap();
        let slice = exposure / rows.len() as f64;
        let mut electrons = 0.0;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(row[0].parse::<u64>().unwrap(), i);
            assert_eq!(&row[1], truth["object"].as_str().unwrap());
            assert_eq!(
                row[2].parse::<u64>().unwrap(),
                truth["norad"].as_u64().unwrap()
            );
            assert_eq!(row[3].parse::<usize>().unwrap(), k);
            // Sample k sits at the centre of the k-th equal slice; the slice is ~1e-2 s, so
            // 1e-9 s is float noise.
            assert!((f(row, 4) - (k as f64 + 0.5) * slice).abs() < 1e-9);
            assert!(row[5].starts_with(&truth["start_utc"].as_str().unwrap()[..10]));
            // The rate over the slice is the sample's electrons (to the last few ulps).
            assert!((f(row, 7) * slice - f(row, 8)).abs() <= 1e-12 * f(row, 8));
            electrons += f(row, 8);
            lo = lo.min(f(row, 6));
            hi = hi.max(f(row, 6));
        }
        // The truth sums the same samples in the same order; the CSV writes each float to its
        // shortest exact form and Rust parses it exactly, so the sum is the same to an ulp or so.
        let want = truth["expected_debris_electrons"].as_f64().unwrap();
        assert!(
            (electrons - want).abs() <= 1e-12 * want,
            "{electrons} vs {want}"
        );
        // serde_json may read the truth's floats an ulp off.
        let (tlo, thi) = (
            truth["magnitude_min"].as_f64().unwrap(),
            truth["magnitude_max"].as_f64().unwrap(),
        );
        assert!(
            (lo - tlo).abs() < 1e-12 && (hi - thi).abs() < 1e-12,
            "{lo} {hi} vs {tlo} {thi}"
        );
    }
}
