//! `schemas/campaign.schema.json` is the output of `soig schema`; this fails when it is stale.
//! Regenerate with `cargo run -- schema > schemas/campaign.schema.json`.

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
        "c0e995bd630d4241cebeae11f56e27930a65eb9bd0cdbfe7dcbbc456ffd94632",
    ),
    (
        "campaigns/model-fixed-padded-mixed.toml",
        "aa9ca139538d9a6025bc3005513b5ca6e041cc74362ac2607dd8cd7bc6da81e1",
    ),
    (
        "campaigns/model-survey-original-mixed.toml",
        "445e432b9c5beaa8b6537818f6f4441325cca9a6711fe3a955fdb7f596feb6cb",
    ),
    (
        "campaigns/model-survey-rotated-mixed.toml",
        "4903ef84430676555c69d7dcfdc9558ef26f505252539087c8e233aeca203c1c",
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
        "306b688dab717de8219d278fcba0b15850d508f4818e7687e365be701007c8a6",
    ),
    (
        "campaigns/paper-fixed-original-semisynthetic.toml",
        "1a3a8812f1035f7c071103ecd8b2cddb6ca4966bf4a48d0a15cfb85a2b9b8c55",
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
        "b46fc3495cbfd950b59020b3a0ee0f1c00499bf67c404d60c97a6cfb4f3820f7",
    ),
    (
        "campaigns/paper-fixed-padded-semisynthetic.toml",
        "bfe4798140a593e86be38e20f0790610b59298315eb6dab9c3ff08ee95eb305e",
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
        "4b92bb1dc7bededfb1291221821f61c3dad82b8e01c0dde9a2a4e7da5354ce33",
    ),
    (
        "campaigns/paper-survey-original-semisynthetic.toml",
        "55915590697b2c218757457354ac75a4e80c220c7b10509f54fbfb79932d43d0",
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
        "2b454f84ad7ddf297f420e4980a2e4cedcccb5ef14984791d81df60edea1704c",
    ),
    (
        "campaigns/paper-survey-rotated-semisynthetic.toml",
        "36721ffd5571686f7da1b878baa0d51339a674ea06297eb5e003ad4d44a56515",
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
        "campaigns/quickstart-nasa-fragments.toml",
        "032d4ebbfc399a7da711dd167b279593cec6c2149912b69911569f3511221727",
    ),
    (
        "campaigns/survey-quickstart.toml",
        "51b4e0046a486878a8c4af90c3ce8dd4fb195a9ac6babff8b3a66d3c0d38af82",
    ),
    (
        "results/campaigns/results-fixed-original-semisynthetic.toml",
        "feb8eb11cfd10957036e6ac3dc68d8eaa22d347422d19eb18e2da095e4b37c34",
    ),
    (
        "results/campaigns/results-fixed-original-synthetic.toml",
        "57dd1a768a42c0116c61f3cce6bd937de10ba43158fd3d53003bb22d9e34e4d3",
    ),
    (
        "results/campaigns/results-fixed-padded-semisynthetic.toml",
        "f49cc9e55c2804e96bdf461b529f270dfd227d8fa0e303ec40edf7eeb912cebb",
    ),
    (
        "results/campaigns/results-fixed-padded-synthetic.toml",
        "4369027821d4114c07f210606c0014656e5784738bde3c9688c235f0697ba80a",
    ),
    (
        "results/campaigns/results-survey-original-semisynthetic.toml",
        "224434a8b68ea27a20b66d9fc477b66f36f5818cc293f29d4de2ae5b203e9a5a",
    ),
    (
        "results/campaigns/results-survey-original-synthetic.toml",
        "1a32135041fc75d97f6762abe6857ac83437443abb86b6ec93e2e75c04527148",
    ),
    (
        "results/campaigns/results-survey-rotated-semisynthetic.toml",
        "9ccd87884e3fd12305f7256b227033d26f30217fbbe8e8cb70428ad74e3fd563",
    ),
    (
        "results/campaigns/results-survey-rotated-synthetic.toml",
        "faea793b33de6131a370632c4f67e808af65ec208958b42eda557b7025a76d85",
    ),
];

#[test]
fn every_campaign_in_the_repository_loads_with_its_pinned_hash() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    // The semisynthetic campaigns read their real frame from the data folder beside the
    // repository; the tests run without it, checking the campaigns that need only the repository.
    let shared = root.join("../shared/data").is_dir();
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
                let c = match soig::campaign::Campaign::load(&path) {
                    Ok(c) => c,
                    Err(e) if !shared && e.to_string().contains("shared/data") => {
                        eprintln!("{rel}: not checked, ../shared/data is absent");
                        continue;
                    }
                    Err(e) => panic!("{e}"),
                };
                assert_eq!(c.hash, pinned.1, "{rel}");
            }
        }
    }
    assert_eq!(n, CAMPAIGN_HASHES.len());
    assert!(n >= 25, "{n} campaigns");
}
