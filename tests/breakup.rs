//! Breakup clouds (`[population.breakup]`, issue #45): the NASA Standard Breakup Model's laws
//! against an independent numpy implementation (tests/reference/breakup_reference.py, pinned
//! in tests/fixtures/breakup/sbm_reference.json); campaigns/breakup.toml runs, verifies and
//! gives the same digest on one thread and on two, and every fragment it shows is the state an
//! independent back-integration put on its parent's place at the breakup
//! (tests/reference/breakup_cloud_reference.py, pinned in cloud_reference.json), and every
//! object it shows, fragment or belt object, is within 1" of where python-sgp4 + astropy put
//! it from its catalogue entry (the fragments' fitted elements that the run writes,
//! `population/generated.omm.json`; tests/reference/breakup_sky_reference.py, pinned in
//! sky_reference.json), none that the reference puts in the field left out; its truth,
//! COCO annotations and DS9 regions carry the fragments' generated ids. Bad breakup settings
//! are refused naming the field.

// A test writes its fixtures with std::fs.
#![allow(clippy::disallowed_methods)]

mod common;

use std::collections::BTreeMap;

use common::{
    account_for_the_field, arg, assert_refused, json, reference_objects, repo,
    run_on_one_and_two_threads_and_verify, separation_arcsec, soig,
};
use serde_json::Value;
use soig::rng::{Purpose, stream};
use soig::sky::breakup::{Event, ParentKind, area_to_mass_law, draw, moments};

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

fn event(name: &str) -> Event {
    match name {
        "explosion" => Event::Explosion { scaling: 1.0 },
        "catastrophic" => Event::Collision {
            target_kg: 1000.0,
            projectile_kg: 10.0,
            speed_km_s: 10.0,
        },
        "cratering" => Event::Collision {
            target_kg: 1000.0,
            projectile_kg: 0.01,
            speed_km_s: 1.0,
        },
        _ => panic!("{name}"),
    }
}

fn kind(name: &str) -> ParentKind {
    match name {
        "spacecraft" => ParentKind::Spacecraft,
        _ => ParentKind::RocketBody,
    }
}

/// Counts and the exact moments of each area-to-mass law agree with the reference to rounding;
/// the sampled moments of whole clouds (sizes, area-to-mass, speeds, each fragment on its own
/// stream) agree with numpy's within their sampling error.
#[test]
fn sbm_laws_match_the_independent_implementation() {
    let r = json(&repo("tests/fixtures/breakup/sbm_reference.json"));
    for c in r["counts"].as_array().unwrap() {
        let e = event(c["event"].as_str().unwrap());
        let lc = f(&c["lc_min_m"]);
        let want = f(&c["n_above"]);
        assert!((e.count_above(lc) - want).abs() <= 1e-12 * want, "{c}");
        assert_eq!(e.fragments(lc), c["fragments"].as_u64().unwrap(), "{c}");
    }
    for l in r["laws"].as_array().unwrap() {
        let (mean, var) = moments(&area_to_mass_law(
            kind(l["kind"].as_str().unwrap()),
            f(&l["lc_m"]),
        ));
        // The same formulas in floating point: a few ulps.
        assert!((mean - f(&l["chi_mean"])).abs() < 1e-12, "{l}: {mean}");
        assert!((var - f(&l["chi_var"])).abs() < 1e-12, "{l}: {var}");
    }
    // 200 000 fragments here, 4e6 in numpy: the standard error of a mean is sd / sqrt(2e5),
    // 0.0013 for chi (sd 0.56), 0.0013 for nu (sd 0.59), 0.0006 for log10(Lc / Lc_min) (sd
    // 0.27), and of a standard deviation sd / sqrt(4e5), under 0.001: five of them each.
    let n = 200_000u64;
    for c in r["clouds"].as_array().unwrap() {
        let e = event(c["event"].as_str().unwrap());
        let k = kind(c["kind"].as_str().unwrap());
        let lc_min = f(&c["lc_min_m"]);
        let (mut size, mut chi, mut nu) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            let d = draw(&e, k, lc_min, &mut stream(7, i, Purpose::BreakupFragment));
            size.push((d.lc_m / lc_min).log10());
            chi.push(d.area_to_mass.log10());
            nu.push(soig::sky::norm(d.dv_m_s).log10());
        }
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
        let sd = |x: &[f64]| {
            let m = mean(x);
            (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64).sqrt()
        };
        let close = |got: f64, key: &str, tol: f64| {
            assert!((got - f(&c[key])).abs() < tol, "{c}: {key} {got}");
        };
        close(mean(&size), "log_size_mean", 0.003);
        close(mean(&chi), "chi_mean", 0.007);
        close(sd(&chi), "chi_std", 0.005);
        close(mean(&nu), "nu_mean", 0.007);
        close(sd(&nu), "nu_std", 0.005);
    }
}

/// The run `out` of campaigns/breakup.toml against python-sgp4 + astropy from the catalogue
/// entries the run states (sky_reference.json): every object shown within 1" of its place, and
/// every object the reference puts in the field shown or listed unseen with a reason. Returns
/// (objects shown, fragments among them, unseen).
fn check_sky(out: &std::path::Path) -> (usize, usize, usize) {
    let r = json(&repo("tests/fixtures/breakup/sky_reference.json"));
    // The reference propagated these very elements.
    let (omm, _) = soig::hash::sha256_file(&out.join(soig::population_omm::FILE)).unwrap();
    assert_eq!(r["omm_sha256"], omm);
    assert_eq!(r["fragments"], 79);
    let (mut shown, mut fragments, mut unseen) = (0, 0, 0);
    for frame in r["frames"].as_array().unwrap() {
        let stem = frame["image"].as_str().unwrap();
        let truth = json(&out.join(format!("truth/{stem}.json")));
        assert_eq!(truth["start_utc"], frame["start_utc"], "{stem}");
        let by_id = reference_objects(frame);
        let mut accounted = std::collections::BTreeSet::new();
        for o in truth["objects"].as_array().unwrap() {
            let id = o["norad"].as_u64().unwrap();
            let p = by_id
                .get(&id)
                .unwrap_or_else(|| panic!("{stem}: {id} shown, the reference has it outside"));
            assert!(p["in_field"].as_bool().unwrap(), "{stem}: {id}");
            // As the GEO stare's check (tests/catalogue.rs): python-sgp4 and the sgp4 crate
            // agree to micrometres from the same elements, astropy's TEME -> GCRS differs from
            // soig's by its polar motion; measured 0.030" at most over the 171 shown objects of
            // the 8 frames (124 fragments). 1" is the issue's bar.
            let sep =
                separation_arcsec(&o["ephemeris"]["debris_radec_mid_deg"], &p["radec_mid_deg"]);
            assert!(sep < 1.0, "{stem}: {id} {sep}\" from its catalogue place");
            // 1" is 0.071 px at 14.06"/px; no jitter here, so the first and last trajectory
            // samples land on the reference's pixels of those instants (measured 0.0021 px).
            for (mine, theirs) in [
                ("streak_start_px", "first_sample_px"),
                ("streak_end_px", "last_sample_px"),
            ] {
                let d = |k: usize| f(&o[mine][k]) - f(&p[theirs][k]);
                let off = d(0).hypot(d(1));
                assert!(off < 0.071, "{stem}: {id} {mine} {off} px off");
            }
            accounted.insert(id);
            shown += 1;
            fragments += usize::from(o["source"] == "generated");
        }
        unseen += account_for_the_field(&truth, &by_id, accounted, stem);
    }
    (shown, fragments, unseen)
}

/// The committed cloud: deterministic across thread counts, verified, each fragment shown
/// in the state the reference integrated back onto its parent, and every object where
/// python-sgp4 puts it from its stated elements (`check_sky`).
#[test]
fn the_breakup_campaign_runs_and_its_fragments_leave_from_the_parent() {
    let tmp = tempfile::tempdir().unwrap();
    let out = run_on_one_and_two_threads_and_verify(&repo("campaigns/breakup.toml"), tmp.path());
    // Measured: 171 objects shown over the 8 frames, 124 of them fragments; 431 unseen.
    assert_eq!(check_sky(&out), (171, 124, 431));
    let reference = json(&repo("tests/fixtures/breakup/cloud_reference.json"));
    // The back-integration (two-body + J2 against SGP4/SDP4's lunisolar terms, an hour) lands
    // every shown fragment within 0.3 km of the parent (measured); 1 km bounds it.
    assert!(f(&reference["max_miss_km"]) < 1.0);
    let pinned: BTreeMap<(String, u64), &Value> = reference["fragments"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| {
            (
                (
                    x["image"].as_str().unwrap().into(),
                    x["id"].as_u64().unwrap(),
                ),
                x,
            )
        })
        .collect();
    let mut shown = 0;
    for k in 0..8 {
        let stem = format!("img_{k:06}");
        let truth = json(&out.join(format!("truth/{stem}.json")));
        for o in truth["objects"].as_array().unwrap() {
            let id = o["norad"].as_u64().unwrap();
            // Exploded: the parent is only its fragments now.
            assert_ne!(id, 90227, "{stem}");
            if o["source"] != "generated" {
                assert_eq!(o["source"], "population", "{stem}");
                continue;
            }
            shown += 1;
            // Ids 90227 x 100000 + 1 ..= 79 (N(>0.2 m) = 6 x 0.2^-1.6 = 78.8).
            let index = id - 9_022_700_000;
            assert!((1..=79).contains(&index), "{stem}: {id}");
            assert_eq!(o["object"], format!("SYN GEO 227 fragment {index}"));
            let p = pinned
                .get(&(stem.clone(), id))
                .unwrap_or_else(|| panic!("{stem}: fragment {id} not in the reference"));
            for j in 0..3 {
                let (got, want) = (
                    f(&o["ephemeris"]["debris_gcrs_km"][j]),
                    f(&p["debris_gcrs_km"][j]),
                );
                // Written and read back as JSON decimals: to a micrometre.
                assert!((got - want).abs() < 1e-9, "{stem}: {id}");
            }
        }
        // COCO and DS9 name each fragment by its id.
        let reg =
            std::fs::read_to_string(out.join(format!("export/ds9/truth/{stem}.reg"))).unwrap();
        for o in truth["objects"].as_array().unwrap() {
            if o["source"] == "generated" {
                let text = format!("(id {})}}", o["norad"]);
                assert!(reg.contains(&text), "{stem}: {text} in {reg}");
            }
        }
    }
    assert_eq!(shown, pinned.len());
    let mut generated = 0;
    for split in ["train", "val"] {
        let coco = json(&out.join(format!("export/coco/{split}.json")));
        for a in coco["annotations"].as_array().unwrap() {
            if a["source"] == "generated" {
                generated += 1;
                let id = a["object_id"].as_u64().unwrap();
                assert_eq!(id / 100_000, 90227, "{a}");
            }
        }
    }
    // Not every shown fragment reaches a label box (a photon must land); most do.
    assert!(
        generated > 0 && generated <= shown,
        "{generated} of {shown}"
    );
}

/// The resolved population: the belt's 400 objects less the exploded parent, then its
/// round(N(>0.2 m)) = round(78.8) = 79 fragments (all on closed orbits above the Earth: none
/// left out), each with the model's area of its size, ids in order.
#[test]
fn the_cloud_holds_n_above_lc_fragments() {
    let c = soig::campaign::Campaign::load(&repo("campaigns/breakup.toml")).unwrap();
    let (catalogued, cloud): (Vec<_>, Vec<_>) = c
        .world
        .population
        .iter()
        .partition(|b| b.generated.is_none());
    assert_eq!(catalogued.len(), 399);
    assert!(catalogued.iter().all(|b| b.norad != 90227));
    assert_eq!(
        cloud.len() as u64,
        Event::Explosion { scaling: 1.0 }.fragments(0.2)
    );
    assert_eq!(cloud.len(), 79);
    for (k, b) in cloud.iter().enumerate() {
        assert_eq!(b.norad, 9_022_700_001 + k as u64);
        // Sizes from 0.2 m: areas from 0.556945 x 0.2^2.0047077 = 0.0221096 m^2.
        let area = b.generated.unwrap().area_m2;
        assert!(area >= 0.0221096, "{}: {area}", b.norad);
    }
}

/// Collisions: a catastrophic one (10 kg at 10 km/s on 1000 kg: 500 J/g) destroys the
/// parent into round(0.1 x 1010^0.75 x 0.2^-1.71) = round(280.9) = 281 fragments, less any the collision
/// speeds (log-normal about 0.9 chi + 2.9) throw off a closed orbit; a cratering one (10 kg at
/// 0.5 km/s: 1.25 J/g) leaves the parent and round(0.1 x 2.5^0.75 x 0.2^-1.71) = 3 fragments.
#[test]
fn collisions_destroy_their_parent_only_when_catastrophic() {
    let collision = |speed: &str| {
        let sets: Vec<String> = [
            "population.breakup.kind=\"collision\"",
            "population.breakup.target_mass_kg=1000.0",
            "population.breakup.projectile_mass_kg=10.0",
            &format!("population.breakup.impact_speed_km_s={speed}"),
        ]
        .map(String::from)
        .into();
        let c =
            soig::campaign::Campaign::load_with_overrides(&repo("campaigns/breakup.toml"), &sets)
                .unwrap();
        let parent = c.world.population.iter().any(|b| b.norad == 90227);
        let cloud: Vec<u64> = c
            .world
            .population
            .iter()
            .filter(|b| b.generated.is_some())
            .map(|b| b.norad - 9_022_700_000)
            .collect();
        (parent, cloud)
    };
    let (parent, cloud) = collision("10.0");
    assert!(!parent);
    assert!(cloud.iter().all(|k| (1..=281).contains(k)), "{cloud:?}");
    // Measured: 271 of the 281; ten have no SGP4 orbit through their state and are left out.
    assert!(cloud.len() <= 281 && cloud.len() > 250, "{}", cloud.len());
    let (parent, cloud) = collision("0.5");
    assert!(parent);
    assert_eq!(cloud, [1, 2, 3]);
}

fn refused_with(set: &str, expect: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let c = repo("campaigns/breakup.toml");
    let out = tmp.path().join("o");
    let o = soig(&["run", arg(&c), "--out", arg(&out), "--set", set]);
    assert_refused(&o, expect);
    assert!(!out.exists(), "a refused run wrote {}", out.display());
}

#[test]
fn bad_breakup_settings_are_refused_naming_the_field() {
    refused_with(
        "population.breakup.kind=\"collision\"",
        "field `population.breakup.impact_speed_km_s`: a collision needs it",
    );
    refused_with(
        "population.breakup.scaling=-1",
        "field `population.breakup.scaling`",
    );
    refused_with(
        "population.breakup.lc_min_m=0.0001",
        "field `population.breakup.lc_min_m`",
    );
    // 6 x 0.002^-1.6 = 124 883 fragments.
    refused_with(
        "population.breakup.lc_min_m=0.002",
        "more than 99999: raise it",
    );
    refused_with(
        "population.breakup.epoch=\"2022-01-22T02:00:00 UTC\"",
        "field `population.breakup.epoch`",
    );
    refused_with("population.breakup.parent=12345", "NORAD 12345 is not in");
    refused_with("population.breakup.parent=41335", "the observer itself");
}
