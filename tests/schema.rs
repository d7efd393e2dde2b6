//! `schemas/campaign.schema.json` is the output of `soig schema`; this fails when it is stale.
//! Regenerate with `cargo run -- schema > schemas/campaign.schema.json`.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

#[test]
fn committed_schema_is_current() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("schemas/campaign.schema.json");
    let committed = std::fs::read_to_string(&path).expect("schemas/campaign.schema.json exists");
    let current = soig::campaign::schema_json() + "\n";
    assert!(
        committed == current,
        "schemas/campaign.schema.json is stale: run `cargo run -- schema > schemas/campaign.schema.json`"
    );
}

/// The resolved hash of every committed campaign, as it was before campaigns were composed with
/// `extends` and read the repository's copy of the TLEs: a campaign's
/// hash pins its outputs (results/*/digest.txt), so rewriting a campaign file must keep it.
const CAMPAIGN_HASHES: &[(&str, &str)] = &[
    (
        "campaigns/model-fixed-original.toml",
        "7ef4f89e09b767f98dd3e6271182526899918de04557253c6fa6f3b7ca089bfd",
    ),
    (
        "campaigns/model-fixed-padded.toml",
        "554a2bcb0ee2fc81d3ba24c8b434de70df203cf98d53b06172770c8b2e96769e",
    ),
    (
        "campaigns/model-survey-original.toml",
        "054ed5a3326d0f0ec10f93f261ba4663cfac8f1e9e9398afd121dc61e7ef9e5e",
    ),
    (
        "campaigns/model-survey-rotated.toml",
        "51eb4daed68044a9697103912246eb1134a81d7747c55891381226d3b26877b4",
    ),
    (
        "campaigns/model-fixed-original-mixed.toml",
        "97beecf51a4a9e90e2e940d3ee1f8aca8929905d0794adc77cf89a286c764e69",
    ),
    (
        "campaigns/model-fixed-padded-mixed.toml",
        "7d0517eefd49b39801f5a2622bcf993b729848d595b986453c6db8caafa77507",
    ),
    (
        "campaigns/model-survey-original-mixed.toml",
        "4bbfa9e599e5b22f5930646d296968a876595b08b7ab681692450f5b9e8ecccc",
    ),
    (
        "campaigns/model-survey-rotated-mixed.toml",
        "a31fe3fe72256fe1e4509380e525e04aec06fd20532e794692f4891cce7d7016",
    ),
    (
        "campaigns/model-fixed.toml",
        "9e585bacc9a4f33755fd0b3f3624a9a389d9c65648577224e4c462140ae15dd8",
    ),
    (
        "campaigns/model-survey-stage2.toml",
        "75841b18509f9c33b7811a091446459f9c45788ce5b4c7986fcfdb89fe393b1e",
    ),
    (
        "campaigns/model-survey.toml",
        "30e8f1ec16a661f7d840fa881f86cea42226114e72dd4ee58746c0c14731c534",
    ),
    (
        "campaigns/paper-fixed-original-semisynthetic-small.toml",
        "6dbce2c58118ad14aaa6229e84d47da7915728990c222036593b3a200518f6cd",
    ),
    (
        "campaigns/paper-fixed-original-semisynthetic.toml",
        "27c7d4561af77675b3dfea0d38f14016b4d2ae99b565a529eb8936cd4724338b",
    ),
    (
        "campaigns/paper-fixed-original-small.toml",
        "61e7dbd1cf280adf4bb54bc1f2c3dc9830d17816df3cbe20f6db21dd44fe44b1",
    ),
    (
        "campaigns/paper-fixed-original.toml",
        "a265c9ca2815752a2eb97b8e580f838f9880075de401bcec3b784a831a21cb2c",
    ),
    (
        "campaigns/paper-fixed-padded-semisynthetic-small.toml",
        "a7efe71ff3f09556747f18537fa5865be1877265d8cf6a16ddf36d2b41d2646b",
    ),
    (
        "campaigns/paper-fixed-padded-semisynthetic.toml",
        "c288f59606f3c503277e721c9a4f9676c3ce3538683cd40ed295f0650bd36a6a",
    ),
    (
        "campaigns/paper-fixed-padded-small.toml",
        "b037f52e2f71b8639831ba4b47ba8ae029f4179ad09850433d49b1de15dff388",
    ),
    (
        "campaigns/paper-fixed-padded.toml",
        "eb8dab45133e3fc29267fd2ed376f4339472625eadca6d69cebed554444792c3",
    ),
    (
        "campaigns/paper-survey-original-semisynthetic-small.toml",
        "f90186fbc3e7c2b1444ee721e88ab5e9cbaa0f513cc5fd26a651e4e81bdb3682",
    ),
    (
        "campaigns/paper-survey-original-semisynthetic.toml",
        "8f3c7493f041c8f0fb7e710eee67f9650dbd2e992ba14fd1f5195c6cb9f29980",
    ),
    (
        "campaigns/paper-survey-original-small.toml",
        "294b5675994e0173776486ec0305988e46e66ed63b85da8b930c7bde96617fba",
    ),
    (
        "campaigns/paper-survey-original.toml",
        "7a904f5513dfff5d0ba2340faecf504e38728d1d264079ce70afd3bccec36183",
    ),
    (
        "campaigns/paper-survey-rotated-semisynthetic-small.toml",
        "d796c191eebee732dc6926f7b660ceef08ad4b5241b32b61d086647aa9a7bb72",
    ),
    (
        "campaigns/paper-survey-rotated-semisynthetic.toml",
        "06758e5ac1539de61b2ec277e10583e3508c3b577e831ddc579276325a5aef7b",
    ),
    (
        "campaigns/paper-survey-rotated-small.toml",
        "014d21606a4386ff13df4204b5e132e0870e23f5b4b269e9b4a74088255fd3da",
    ),
    (
        "campaigns/paper-survey-rotated.toml",
        "e97a974ba7f161056a3874fd7b4339c59dbc7b9c8d2c88965c15f4a5f3d1a445",
    ),
    (
        "campaigns/physical-noise.toml",
        "146412cddedd798597320a56f8e9e8d371be2f0d2429af5d6d60b196e3e97beb",
    ),
    (
        "campaigns/quickstart.toml",
        "e1240fa7c096a9809228d0e1866e00d39ba22496da028f54cc2a38d257e5c7e9",
    ),
    (
        "campaigns/quickstart-exports.toml",
        "392d68d9abd59faded48d9ab0191328265cd74c0dba3a44f1ac321a956ee751e",
    ),
    (
        "campaigns/quickstart-multi.toml",
        "a8fb92c4de067f790f06c1fd2c2ef117a11bcf3be95b1f3f983d6adc8783fb68",
    ),
    (
        "campaigns/quickstart-nasa-fragments.toml",
        "032d4ebbfc399a7da711dd167b279593cec6c2149912b69911569f3511221727",
    ),
    (
        "campaigns/survey-quickstart.toml",
        "51b4e0046a486878a8c4af90c3ce8dd4fb195a9ac6babff8b3a66d3c0d38af82",
    ),
    (
        "campaigns/survey-faint.toml",
        "8ad089aa967c720bd23028ffc38c4e8ed09d32de58c468612949e45981d1933d",
    ),
    (
        "campaigns/collect-quickstart.toml",
        "371096f25008c5f6e2440eea2d542da8ce7fea59d213e36ae3192797d07cbdf8",
    ),
    (
        "campaigns/breakup.toml",
        "b1e6dfec07a7489dc8ef3500f53046142fd739fae341d864fae6aea050740956",
    ),
    (
        "campaigns/geo-stare.toml",
        "d4cb0b92ffd2d978c902cba8062653009b7656ff3698747fc482883694e93cad",
    ),
    (
        "campaigns/track-quickstart.toml",
        "c5d62dec9fb0b5ce4d553ffd1ac6b5091f9bdbe8f5048543de3d649696d93ec8",
    ),
    (
        "campaigns/ground-sidereal-leo.toml",
        "9306d929f54888b8edde2414f035522664b346cdedcc26bb87d8d6893fdace44",
    ),
    (
        "campaigns/ground-geo-stare.toml",
        "41158cebba03eff2e25bee2858a024d20ebc4e0b10083f9de2545ceaa1e379ac",
    ),
    (
        "campaigns/ground-geo-track.toml",
        "f2356a0442a167e6ccf694340b110529d151add3a72fb989379bd21fad44a697",
    ),
    (
        "results/campaigns/faint-limit-fixed.toml",
        "e2b3025feb89c7928f19ca993bddcb55c8abecc82003931aca9d4b034102b241",
    ),
    (
        "results/campaigns/faint-limit-survey-semisynthetic.toml",
        "aa38b5972d75f80a5c9ce81554f3f239cf2612f6342abce480b2866c2393e464",
    ),
    (
        "results/campaigns/faint-limit-survey.toml",
        "b0718f5a58db3c86c8306cd058209d7398810426f09b5e9c5d5673e15152b48a",
    ),
    (
        "results/campaigns/faint-limit-survey-science.toml",
        "c81aa244cc24188da2f3b573cf9941466d90bad18967aff792eebd1b8cf22e51",
    ),
    (
        "results/campaigns/faint-limit-survey-calibrated.toml",
        "0f6f44798f37c64243c951ed466d18c51cbf10078a115cbd54e6409e252cafce",
    ),
    (
        "results/campaigns/faint-limit-survey-science-linearised.toml",
        "48ee614e2cef57ec7f36761e9842ee6080a3f2d705321e2ef1f710fbc611a50f",
    ),
    (
        "results/campaigns/faint-limit-survey-calibrated-linearised.toml",
        "22953dc6453ad7e312985b9862d0b7cb370c58615d22335730a461cb9c0fda41",
    ),
    (
        "results/campaigns/faint-limit-survey-linearised.toml",
        "0c3f4c3a0fd48d2508740a5751bc768234d5763e370443ed8871fe6ca0d6262c",
    ),
    (
        "results/campaigns/faint-limit-survey-semisynthetic-linearised.toml",
        "68a43182e4bea2a12dc4bfc9c4cec6624b05b7b5b7be8a13335cb135421ea86d",
    ),
    (
        "results/campaigns/results-fixed-original-semisynthetic.toml",
        "147e7e32437371dd26048d97f29c60918947cee87b17c3c1c5455998693fc59e",
    ),
    (
        "results/campaigns/results-fixed-original-synthetic.toml",
        "57dd1a768a42c0116c61f3cce6bd937de10ba43158fd3d53003bb22d9e34e4d3",
    ),
    (
        "results/campaigns/results-fixed-padded-semisynthetic.toml",
        "a9ae731fccf5d90c8cb8a8f2f16917e7a0644aa5568873113a0bd32a68306f8d",
    ),
    (
        "results/campaigns/results-fixed-padded-synthetic.toml",
        "4369027821d4114c07f210606c0014656e5784738bde3c9688c235f0697ba80a",
    ),
    (
        "results/campaigns/results-survey-original-semisynthetic.toml",
        "428bbfe47688e6f5f3ec64a422af2906da6df875f18649a42b2434b69c5c1851",
    ),
    (
        "results/campaigns/results-survey-original-synthetic.toml",
        "9ec4f8664173716034cf059c8f6ccfa47a02269bfa717dc5d31bb29c789b95bc",
    ),
    // The two rotated rows' hashes cover their YOLO model's sha256: they move when the relay
    // adopts a stage of `survey-rotated` (last: stage 2, 2026-11-30).
    (
        "results/campaigns/results-survey-rotated-semisynthetic.toml",
        "0091cb578076ab83c725433c066d78a584832356589012ed9d0feacb83ee0f2d",
    ),
    (
        "results/campaigns/results-survey-rotated-synthetic.toml",
        "5e9695d8d6238c3b8ae84911b99bb301489c69ea6c26f3eeb6e19b7e321f8c0f",
    ),
];

#[test]
fn every_campaign_in_the_repository_loads_with_its_pinned_hash() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut n = 0;
    // Bases (`base/`) are not campaigns; every campaign beside them is pinned.
    for dir in ["campaigns", "results/campaigns"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let rel = path.strip_prefix(root).unwrap().to_str().unwrap();
                let pinned = CAMPAIGN_HASHES
                    .iter()
                    .find(|(p, _)| *p == rel)
                    .unwrap_or_else(|| panic!("{rel} has no pinned hash"));
                n += 1;
                let c = soig::campaign::Campaign::load(&path).unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(c.hash, pinned.1, "{rel}");
            }
        }
    }
    assert_eq!(n, CAMPAIGN_HASHES.len());
    assert!(n >= 25, "{n} campaigns");
}
