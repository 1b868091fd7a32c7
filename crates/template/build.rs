//! Generates the Rust code for `model.toml` into `OUT_DIR/vehicle.rs` (the file is named after the model's
//! `name`). Cargo reruns this when `model.toml` changes; the file is rewritten only when its contents change.

fn main() {
    let out_dir = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR for build scripts");
    if let Err(e) = invsim_codegen::Builder::new()
        .model("model.toml")
        .out_dir(out_dir)
        .compile()
    {
        // A model that cannot be inverted fails the build with the message `invsim derive` prints.
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
