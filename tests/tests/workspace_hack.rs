//! crates/workspace-hack lists the union of the third-party features: every smaller build (the command line,
//! the Python extension, `cargo xtask`) resolves each shared crate with the same features as
//! `cargo test --workspace`, so that none of them compiles the workspace a second time. Checked with
//! `cargo tree`, which resolves features exactly as a build of the same packages does.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// `cargo tree ARGS -f "{p}|{f}"`: package → the features enabled on it.
fn features(args: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let out = Command::new(cargo)
        .current_dir(&root)
        .args(["tree", "--locked", "--prefix", "none", "-f", "{p}|{f}"])
        .args(args)
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut map: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        // A package printed before ends in " (*)", after its features.
        let line = line.trim_end_matches(" (*)");
        let Some((package, list)) = line.split_once('|') else {
            continue;
        };
        let package = package
            .trim_end_matches(" (*)")
            .trim_end_matches(" (proc-macro)");
        let entry = map.entry(package.to_string()).or_default();
        entry.extend(
            list.split(',')
                .filter(|f| !f.is_empty())
                .map(str::to_string),
        );
    }
    map
}

#[test]
fn every_build_resolves_the_features_of_the_whole_workspace() {
    let all = features(&["--workspace", "-e", "normal,build,dev"]);
    assert!(all.keys().any(|p| p.starts_with("serde v1")), "{all:?}");
    let mut missing = Vec::new();
    for package in ["invsim", "invsim-python", "xtask"] {
        let part = features(&["-p", package, "-e", "normal,build"]);
        for (krate, enabled) in &part {
            let Some(union) = all.get(krate) else {
                continue;
            };
            if enabled != union {
                let lacks: Vec<_> = union.difference(enabled).collect();
                missing.push(format!("{package}: {krate} lacks {lacks:?}"));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "add these features to crates/workspace-hack/Cargo.toml:\n{}",
        missing.join("\n")
    );
}
