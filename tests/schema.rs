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
        "campaigns/model-fixed.toml",
        "1b9bc500f77336791e45700a7f0f5f586c2f60c9d3f3ce499b3812fa21b7ba8d",
    ),
    (
        "campaigns/model-survey-stage2.toml",
        "e499515f4ee08979d30a81570e35d757adf28beedf480bba3665cca8ba569441",
    ),
    (
        "campaigns/model-survey.toml",
        "95cc8e70d4033007e956f3bb5ceec2cb221306b60d6add8daa561c9bbd2f8e3f",
    ),
    (
        "campaigns/paper-fixed-original-semisynthetic-small.toml",
        "109a2690e0f1de29ccdb820e086ceacb389bb66b8109dd2df7220633498d7d72",
    ),
    (
        "campaigns/paper-fixed-original-semisynthetic.toml",
        "b523a7fb91741812201626e36d9a8d47d048326693006b381bc64fb9b26beec6",
    ),
    (
        "campaigns/paper-fixed-original-small.toml",
        "b9a36fdfe558b3feb2d12a6684d13c4092f22abaa40d7a37a60cc5080d183e30",
    ),
    (
        "campaigns/paper-fixed-original.toml",
        "e66cb0d98a1479fbdd9df1acbeb0c6461a56ce1fe03694540c7a50554f12572e",
    ),
    (
        "campaigns/paper-fixed-padded-semisynthetic-small.toml",
        "e83d28c6469948b33a4b93f67f17ddf9c0d4b9c76b019ab27a0d731bbc740afd",
    ),
    (
        "campaigns/paper-fixed-padded-semisynthetic.toml",
        "29427f2e7d03ac180fb510fed27829259d45d83bc3255d2b30b7be3f8b2efd22",
    ),
    (
        "campaigns/paper-fixed-padded-small.toml",
        "6784d6f8436156a7d930fb4bb875cc400e1bcf057bba05e0afa041e27916f6d0",
    ),
    (
        "campaigns/paper-fixed-padded.toml",
        "9620b0e632383709f2b134f5d496b5e21a3ef6b40ebc71cbfc5bf6b4958b585e",
    ),
    (
        "campaigns/paper-survey-original-semisynthetic-small.toml",
        "f219454f957791ad074f790f519fc51a0b044a123ab3a5479a1f82c679f5c335",
    ),
    (
        "campaigns/paper-survey-original-semisynthetic.toml",
        "05a7cbb0da446d3700e9520ecaf9ff5d7016e8b7d5b7ce2fb5235777d51adaed",
    ),
    (
        "campaigns/paper-survey-original-small.toml",
        "bb16fe258bd1cfdaec9acc4253917dff580c49773bae10082cfab7d29a12cb35",
    ),
    (
        "campaigns/paper-survey-original.toml",
        "1e8cd465bfe1c83e6c6009c8e442b8817f04a05771f6ade8d141d2ecb21fb123",
    ),
    (
        "campaigns/paper-survey-rotated-semisynthetic-small.toml",
        "55e53cf7fbdc30613b119db721c69abf69a3a1e469410f84fb5b132c2c375d6c",
    ),
    (
        "campaigns/paper-survey-rotated-semisynthetic.toml",
        "e2284dc84f817deaa7dbe9f4bb4c9e971b52a30d58e6b3a7c67ff5a7c1802b21",
    ),
    (
        "campaigns/paper-survey-rotated-small.toml",
        "39f4e8198f9d04e3cccac3816775d170abd110325125fc038fd4428ab9ab1e0c",
    ),
    (
        "campaigns/paper-survey-rotated.toml",
        "5be59e182afa5a167f37fd704188187a195938452629b255cfa9941bc1b17337",
    ),
    (
        "campaigns/physical-noise.toml",
        "2d8913b8ea331c661832c0d5a1d20ce7f77b6086e8d5b04b3b5bcc49daa5edfc",
    ),
    (
        "campaigns/quickstart.toml",
        "1bb7b5cef0d88dc06ab3db6dbd77e171c7fb8d2583ad46ca98fe192467123fca",
    ),
    (
        "campaigns/survey-quickstart.toml",
        "f958c2280503fbc5042d12a0f76f43877091b83466ae19c70726309b99a6f70f",
    ),
    (
        "results/campaigns/results-fixed-original-semisynthetic.toml",
        "68d58c11ccaa3e5438f4b5db57fa7a7a36dfeaf0a6eb019b01e276f0d551b702",
    ),
    (
        "results/campaigns/results-fixed-original-synthetic.toml",
        "542b4952bf11056c4261565a1af8087944689b272911638bce8a534bd2ed2967",
    ),
    (
        "results/campaigns/results-fixed-padded-semisynthetic.toml",
        "5c5cf1d600a9917c5f6c567acca146393b140afbcb5fcccf673b20c68a65f70b",
    ),
    (
        "results/campaigns/results-fixed-padded-synthetic.toml",
        "741ce1c48781cd56dbbb67262e253c50d926aee8d3c2d5aec3664f6a06ac5daf",
    ),
    (
        "results/campaigns/results-survey-original-semisynthetic.toml",
        "fe149b92c912d5c054af2850b6d71561f8d7f5ca3941effb3832656d12f56182",
    ),
    (
        "results/campaigns/results-survey-original-synthetic.toml",
        "ec52d0dca486f338c5a405c086afb0c132fbaa223e81810f252663fbbfee572d",
    ),
    (
        "results/campaigns/results-survey-rotated-semisynthetic.toml",
        "1d93c2aab7f17b41c7c7dde9e58e6da3154b9a2357300cf4084681209affeef4",
    ),
    (
        "results/campaigns/results-survey-rotated-synthetic.toml",
        "fc78184466f1eb1113f01eed6c7d8e28713f03067a07f5627240d77aefafe1e6",
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
