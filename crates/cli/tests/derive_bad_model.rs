//! `invsim derive` on a model that cannot be loaded or inverted exits with status 2 and prints
//! `invsim: error: ` and the library's message — the same text `cargo xtask gen` prints (checked by
//! `xtask/tests/xtask_gen_bad_model.rs` against the same library message).

use std::path::Path;
use std::process::Command;

#[test]
fn derive_on_a_bad_model_prints_the_library_message() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut models = vec![
        root.join("xtask/tests/bad_model.toml"),
        root.join("xtask/tests/no_such_model.toml"),
    ];
    if let Ok(entries) = std::fs::read_dir(root.join("../shared/models")) {
        models.extend(
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| {
                    p.file_name()
                        .and_then(|f| f.to_str())
                        // bad_nonaffine is a valid non-affine model since contract §5.
                        .is_some_and(|f| f.starts_with("bad_") && f != "bad_nonaffine.toml")
                }),
        );
    }
    for model in models {
        let Err(e) = invsim_inversion::derive_file(&model) else {
            panic!("{} derives, it is not a bad model", model.display());
        };
        let run = Command::new(env!("CARGO_BIN_EXE_invsim"))
            .arg("derive")
            .arg(&model)
            .output()
            .expect("run invsim");
        assert_eq!(
            run.status.code(),
            Some(2),
            "{}: exit status",
            model.display()
        );
        assert_eq!(
            String::from_utf8_lossy(&run.stderr),
            format!("invsim: error: {e}\n"),
            "{}",
            model.display()
        );
    }
}
