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

#[test]
fn every_campaign_in_the_repository_loads() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut n = 0;
    for dir in [root.join("campaigns"), root.join("results/campaigns")] {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                soig::campaign::Campaign::load(&path).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
    }
    assert!(n >= 25, "{n} campaigns");
}
