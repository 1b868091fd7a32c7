//! `cargo xtask figures --check`: every figure group renders without error into a scratch directory, every SVG
//! is a complete, non-empty document, and every figure is also committed under `docs/figures/`.

use std::process::Command;

#[test]
fn figures_regenerate_in_check_mode() {
    let root = xtask::workspace_root();
    let rendered = xtask::figures::run(&root, true).unwrap_or_else(|f| panic!("{}", f.message));
    let names: Vec<String> = rendered
        .iter()
        .filter_map(|p| p.file_name().map(|f| f.to_string_lossy().into_owned()))
        .collect();
    for expected in [
        "fig4_kernel.svg",
        "fig5_ece_smoothing.svg",
        "fig7_nedc_inverse_vs_forward.svg",
        "fig7_first_ece_detail.svg",
        "lookahead_effect.svg",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "{expected} not among {names:?}"
        );
    }
    for path in &rendered {
        let text = std::fs::read_to_string(path).unwrap();
        assert!(xtask::figures::is_complete_svg(&text), "{}", path.display());
        assert!(
            path.starts_with(root.join(xtask::figures::CHECK_DIR)),
            "check mode writes nothing to docs/"
        );
    }
}

#[test]
fn figures_subcommand_check_exits_0() {
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["figures", "--check"])
        .output()
        .expect("run xtask");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
