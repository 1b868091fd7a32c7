//! Freshness of the vehicle library (no Python needed): re-importing each stored FASTSim file gives exactly
//! the stored model; regenerate with `cargo xtask vehicles`.

use crate::common::vehicle_files;

#[test]
fn stored_models_are_the_import_of_the_stored_vehicle_files() {
    let files = vehicle_files();
    assert!(
        files.len() >= 2,
        "the library holds at least the Fusion and the Leaf: {files:?}"
    );
    for yaml in files {
        let text = std::fs::read_to_string(&yaml).unwrap();
        let source = yaml.file_name().unwrap().to_string_lossy().into_owned();
        let imported = invsim_import::import_fastsim(&text, &source).unwrap();
        let stored = std::fs::read_to_string(yaml.with_extension("toml")).unwrap();
        assert!(
            stored == imported.model,
            "{} is stale: run `cargo xtask vehicles`",
            yaml.with_extension("toml").display()
        );
        assert!(
            stored.contains("FASTSim (NREL, https://github.com/NREL/fastsim), Apache License 2.0")
        );
        assert!(
            text.contains("Apache License 2.0"),
            "{} lacks its attribution",
            yaml.display()
        );
    }
}
