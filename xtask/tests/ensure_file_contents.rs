//! `ensure_file_contents`, through which every generated file goes: write mode writes only what changed,
//! check mode writes nothing and names the stale file and the command that regenerates it; and the tasks built
//! on it (`docs`, `golden`) fail on a stale tree and pass on a fresh one.

use std::path::{Path, PathBuf};
use xtask::{ensure_file_contents, Check};

/// A fresh scratch directory under the workspace's `target/`.
fn scratch(name: &str) -> PathBuf {
    let dir = xtask::workspace_root()
        .join("target/xtask-ensure-test")
        .join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A scratch workspace holding a copy of `models/` (its subdirectories too).
fn scratch_root(name: &str) -> PathBuf {
    let root = scratch(name);
    copy_tree(
        &xtask::workspace_root().join("models"),
        &root.join("models"),
    );
    root
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let target = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_tree(&p, &target);
        } else {
            std::fs::copy(&p, target).unwrap();
        }
    }
}

fn modified(path: &Path) -> std::time::SystemTime {
    std::fs::metadata(path).unwrap().modified().unwrap()
}

#[test]
fn write_mode_writes_only_what_changed() {
    let file = scratch("write").join("sub/dir/a.txt");
    assert_eq!(ensure_file_contents(&file, "one", Check::Write), Ok(true));
    let before = modified(&file);
    std::thread::sleep(std::time::Duration::from_millis(20));
    assert_eq!(ensure_file_contents(&file, "one", Check::Write), Ok(false));
    assert_eq!(
        modified(&file),
        before,
        "an unchanged file is not rewritten"
    );
    assert_eq!(ensure_file_contents(&file, "two", Check::Write), Ok(true));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "two");
}

#[test]
fn check_mode_names_the_stale_file_and_the_command_and_writes_nothing() {
    let dir = scratch("check");
    let file = dir.join("b.txt");
    let exact = Check::Exact {
        command: "cargo xtask regen",
    };
    let missing = ensure_file_contents(&file, "new", exact).unwrap_err();
    assert!(
        missing
            .message
            .contains("b.txt is missing: run `cargo xtask regen`"),
        "{}",
        missing.message
    );
    assert!(!file.exists(), "check mode writes nothing");
    std::fs::write(&file, "old").unwrap();
    let stale = ensure_file_contents(&file, "new", exact).unwrap_err();
    assert_eq!(stale.code, 1);
    assert!(
        stale
            .message
            .contains("b.txt is stale: run `cargo xtask regen`"),
        "{}",
        stale.message
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "old");
    assert_eq!(ensure_file_contents(&file, "old", exact), Ok(false));
    // `Exists` only asks for the file (figures are pictures, not golden files).
    let exists = Check::Exists {
        command: "cargo xtask regen",
    };
    assert_eq!(ensure_file_contents(&file, "new", exists), Ok(false));
    assert!(ensure_file_contents(&dir.join("c.txt"), "x", exists).is_err());
}

#[test]
fn stale_files_are_shown_relative_to_the_workspace_root() {
    let root = xtask::workspace_root();
    let odd = root.join("tests/../docs/./README.md");
    assert_eq!(xtask::shown_path(&odd), Path::new("docs/README.md"));
}

#[test]
fn docs_check_fails_on_a_stale_tree_and_passes_once_regenerated() {
    let root = scratch_root("docs");
    let err = xtask::docs::run(&root, true).unwrap_err();
    assert!(
        err.message.contains("is missing: run `cargo xtask docs`"),
        "{}",
        err.message
    );
    assert!(!root.join("docs").exists(), "check mode writes nothing");
    let written = xtask::docs::run(&root, false).unwrap();
    assert!(
        written.contains(&PathBuf::from("docs/README.md")),
        "{written:?}"
    );
    assert_eq!(xtask::docs::run(&root, true), Ok(Vec::new()));
    assert_eq!(
        xtask::docs::run(&root, false),
        Ok(Vec::new()),
        "nothing left to write"
    );
    std::fs::write(root.join("docs/README.md"), "edited by hand").unwrap();
    std::fs::write(root.join("docs/models/orphan.md"), "left over").unwrap();
    let err = xtask::docs::run(&root, true).unwrap_err();
    for stale in ["README.md is stale", "docs/models/orphan.md is stale"] {
        assert!(err.message.contains(stale), "{stale} in {}", err.message);
    }
}

#[test]
fn golden_check_fails_on_a_stale_file_and_passes_once_blessed() {
    let root = scratch_root("golden");
    let err = xtask::golden::run(&root, false).unwrap_err();
    assert!(
        err.message
            .contains("is missing: run `cargo xtask golden --bless`"),
        "{}",
        err.message
    );
    xtask::golden::run(&root, true).unwrap();
    assert!(xtask::golden::run(&root, false).is_ok());
    let golden = root.join(xtask::golden::GOLDEN);
    std::fs::write(&golden, "// edited\n").unwrap();
    let err = xtask::golden::run(&root, false).unwrap_err();
    assert!(
        err.message
            .contains("si_engine.rs is stale: run `cargo xtask golden --bless`"),
        "{}",
        err.message
    );
}
