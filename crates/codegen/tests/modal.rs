//! A model with operating modes (`models/si_engine_5speed.toml`) through the generator: one module per mode
//! inside the model's module (the gears of one family sharing their first gear's code), the table of modes in the file's order, a registry entry for `modal_by_hash`
//! and none for the single-mode `by_hash`, and the Markdown of every mode.

use std::path::{Path, PathBuf};

fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine_5speed.toml")
}

#[test]
fn one_module_per_mode_and_a_table_of_modes() {
    let out = std::env::temp_dir().join(format!("invsim-codegen-modal-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let g = invsim_codegen::Builder::new()
        .model(model())
        .out_dir(&out)
        .cargo_metadata(false)
        .compile()
        .expect("si_engine_5speed compiles");
    assert_eq!(g.len(), 1);
    let g = &g[0];
    assert_eq!(g.module, "si_engine_5speed");
    assert_eq!(g.modes.len(), 16);
    assert_eq!(g.modes[0], "drive_1");
    assert_eq!(g.modes[15], "idle");
    let text = std::fs::read_to_string(&g.path).expect("written");
    assert!(text.starts_with(&invsim_codegen::header(
        "si_engine_5speed.toml",
        &g.source_hash
    )));
    let file = syn::parse_file(&text).expect("the file is Rust");
    let syn::Item::Mod(outer) = &file.items[0] else {
        panic!("the first item is the model's module")
    };
    let inner: Vec<String> = outer
        .content
        .as_ref()
        .expect("inline module")
        .1
        .iter()
        .filter_map(|i| match i {
            syn::Item::Mod(m) => Some(m.ident.to_string()),
            _ => None,
        })
        .collect();
    let expected: Vec<String> = g
        .modes
        .iter()
        .map(|m| invsim_codegen::mode_module(m))
        .collect();
    assert_eq!(inner, expected);
    assert!(text.contains("pub const MODES: &[&str] = &[\n        \"drive_1\","));
    // The gears of one family share the code of their first gear: 4 modules in full (drive, coast, overrun,
    // idle), 12 that re-export one and give their parameter values.
    assert_eq!(text.matches("pub struct Precomputed {").count(), 4);
    assert_eq!(
        text.matches("pub use super::mode_drive_1::{Model, Params};")
            .count(),
        4
    );
    assert_eq!(
        text.matches("pub use super::mode_coast_1::{Model, Params};")
            .count(),
        4
    );
    let registry = invsim_codegen::registry(std::slice::from_ref(g)).expect("registry");
    assert!(
        registry.contains("pub const NAMES: &[&str] = &[];"),
        "{registry}"
    );
    assert!(
        registry.contains("Some(si_engine_5speed::models())"),
        "{registry}"
    );
    assert!(
        registry.contains("pub fn modal_hash_of_source(bytes: &[u8]) -> Option<&'static str>")
            && registry.contains(&format!("return Some(\"{}\");", g.source_hash)),
        "{registry}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn generate_file_gives_every_mode_and_its_markdown() {
    let (rust, markdown) = invsim_codegen::generate_file(&model()).expect("generates");
    assert!(rust.contains("pub mod mode_overrun_3 {"));
    assert!(markdown.starts_with("model si_engine_5speed with 16 modes\n"));
    assert_eq!(markdown.matches("\n== mode ").count(), 16);
    assert!(
        markdown.contains("== mode idle (role standstill, free input F_b, m_at = m_at_idle) ==")
    );
}

/// A mode whose ψ⁻¹ goes through a lookup map (Newton's method for the actuator state p) and whose y^(r) is
/// not affine in its free input (u + b·u³, Newton's method too) is generated like any other mode: ψ⁻¹ by
/// Newton, then the input in the states (`phi_x`, `solve_input_x`).
#[test]
fn a_mode_with_a_numeric_psi_inv_and_a_non_affine_input_is_generated() {
    const MODEL: &str = r#"
name = "modal_map_nonaffine"
[parameters]
m = 1200.0
tau = 0.3
b = 0.2
[states]
v = { rhs = "(force(p) - 100*tanh(v/0.1))/m" }
p = { rhs = "(u + b*u^3 - brk - p)/tau" }
[inputs.u]
[inputs.brk]
[output]
name = "v"
h = "v"
[modes.drive]
inputs = { brk = 0.0 }
[maps.force]
x = [-2.0, 0.0, 2.0]
values = [-6000.0, 0.0, 6000.0]
smooth = 0.5
"#;
    let dir = std::env::temp_dir().join(format!("invsim-codegen-modal-na-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let path = dir.join("modal_map_nonaffine.toml");
    std::fs::write(&path, MODEL).expect("write the model");
    let (rust, markdown) = invsim_codegen::generate_file(&path).expect("generates");
    syn::parse_file(&rust).expect("the file is Rust");
    for item in [
        "pub mod mode_drive",
        "pub fn psi_inv(",
        "pub fn phi_x(",
        "pub fn solve_input_x(",
        "fn invert_from(",
    ] {
        assert!(rust.contains(item), "{item}");
    }
    assert!(
        markdown.contains("solved numerically by Newton"),
        "{markdown}"
    );
}
