//! Output files of `simulate` and `forward` on success: written in place, through links into the linked file,
//! onto character devices directly, and no temporary file left behind (the refusals are hostile cases in
//! `tests/hostile/`).

use crate::common;
use common::*;

use std::path::Path;

/// A fresh directory of this test.
fn dir(name: &str) -> std::path::PathBuf {
    let d = tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The names in `d`, sorted.
fn names(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn outputs_replace_old_files_and_leave_no_temporary() {
    let d = dir("replace");
    let (out, json, svg) = (d.join("a.csv"), d.join("a.json"), d.join("a.svg"));
    std::fs::write(&out, "old\n").unwrap();
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--out",
        out.to_str().unwrap(),
        "--summary-json",
        json.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&out).unwrap().starts_with("t,yd_0"));
    assert_eq!(json_file(&json)["cycle"], "ece");
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    assert_eq!(names(&d), ["a.csv", "a.json", "a.svg"]);
}

#[test]
fn an_output_through_a_link_is_written_into_the_linked_file() {
    let d = dir("link");
    let target = d.join("target.json");
    std::fs::write(&target, "old\n").unwrap();
    std::os::unix::fs::symlink(&target, d.join("link.json")).unwrap();
    let o = invsim(&[
        "forward",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--summary-json",
        d.join("link.json").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_file(&target)["cycle"], "ece");
    assert!(std::fs::symlink_metadata(d.join("link.json"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(names(&d), ["link.json", "target.json"]);
}

#[test]
fn character_devices_are_written_directly() {
    for cmd in ["simulate", "forward"] {
        let o = invsim(&[
            cmd,
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--dt",
            "1",
            "--out",
            "/dev/null",
            "--summary-json",
            "/dev/stdout",
        ]);
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("\"cycle\": \"ece\""), "{cmd}: {text}");
    }
}

#[test]
fn a_failed_run_leaves_the_old_outputs_and_no_temporary() {
    let d = dir("failed");
    let out = d.join("a.csv");
    std::fs::write(&out, "precious\n").unwrap();
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--dt",
        "-1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "precious\n");
    assert_eq!(names(&d), ["a.csv"]);
}

#[test]
fn an_output_that_is_a_hard_link_to_an_input_is_refused() {
    let d = dir("hardlink");
    let model = d.join("m.toml");
    std::fs::copy(root().join("models/si_engine.toml"), &model).unwrap();
    let before = std::fs::read(&model).unwrap();
    std::fs::hard_link(&model, d.join("alias.csv")).unwrap();
    for cmd in ["simulate", "forward"] {
        let o = invsim(&[
            cmd,
            model.to_str().unwrap(),
            "--cycle",
            "ece",
            "--out",
            d.join("alias.csv").to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", stderr(&o));
        assert!(stderr(&o).contains("the model file"), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&model).unwrap(), before);
    assert_eq!(names(&d), ["alias.csv", "m.toml"]);
}
