//! Helpers shared by the command-line tests: running the `invsim` binary from the repository root, temporary
//! files, the optional reference material in `../shared`, and a model with modes loaded as the library's
//! plant with derivatives of its parameters.
#![allow(dead_code)] // each test binary uses a different subset

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run `invsim` with `args` from the repository root.
pub fn invsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_invsim"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run invsim")
}

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path in this test process's temporary directory.
pub fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("invsim-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// `../shared/<rel>` if the reference material is there; says so and returns `None` if not.
pub fn shared(rel: &str) -> Option<String> {
    let p = root().join("../shared").join(rel);
    if !p.exists() {
        eprintln!("skipping: ../shared not found");
        return None;
    }
    Some(p.display().to_string())
}

pub fn json_file(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// The CSV written by a command: header and records.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).expect("the command wrote its CSV");
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let header = reader
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    let rows = reader
        .records()
        .map(|r| r.expect("record").iter().map(String::from).collect())
        .collect();
    (header, rows)
}

/// A CSV field as a number.
pub fn num(s: &str) -> f64 {
    s.parse().unwrap_or_else(|_| panic!("`{s}` is a number"))
}

/// A CSV column by name as numbers.
pub fn column(header: &[String], rows: &[Vec<String>], name: &str) -> Vec<f64> {
    let j = header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("column {name}"));
    rows.iter().map(|r| num(&r[j])).collect()
}

/// `invsim simulate ARGS --summary-json TAG.json`, which must succeed: the summary and the standard output.
pub fn simulate_summary(args: &[&str], tag: &str) -> (Value, String) {
    let json = tmp(&format!("{tag}.json"));
    let mut all = vec!["simulate"];
    all.extend_from_slice(args);
    all.extend(["--summary-json", json.to_str().unwrap()]);
    let o = invsim(&all);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    (
        json_file(&json),
        String::from_utf8_lossy(&o.stdout).into_owned(),
    )
}

/// `invsim simulate ARGS --out TAG.csv --summary-json TAG.json`, which must succeed: the summary and the CSV.
pub fn simulate_with(args: &[&str], tag: &str) -> (Value, Vec<String>, Vec<Vec<String>>) {
    let csv = tmp(&format!("{tag}.csv"));
    let mut all = args.to_vec();
    all.extend(["--out", csv.to_str().unwrap()]);
    let (summary, _) = simulate_summary(&all, tag);
    let (header, rows) = read_csv(&csv);
    (summary, header, rows)
}

/// The model with modes at `model` (a path from the repository root) as the library's plant.
pub fn modal_plant(
    model: &str,
    engine: invsim_loader::EngineChoice,
) -> invsim_runtime::modes::ModalPlant {
    match invsim_loader::load(&root().join(model), engine)
        .unwrap_or_else(|e| panic!("{model}: {e}"))
    {
        invsim_loader::Loaded::Modal(m) => m.plant,
        invsim_loader::Loaded::Single(_) => panic!("{model} has modes"),
    }
}

/// The derivatives `names` of the plant's parameters (`all`: every one, each gearbox parameter per gear).
pub fn modal_wrt(
    p: &invsim_runtime::modes::ModalPlant,
    names: &[&str],
) -> invsim_runtime::gradient::ModalWrt {
    let parameters = p.parameters();
    let names: Vec<String> = names.iter().map(|n| n.to_string()).collect();
    let params = invsim_runtime::gradient::resolve_modal(&parameters, p.gear_parameters(), &names)
        .expect("known names");
    let modes = p.metas().map(|m| (m.gear, &m.own_parameters[..]));
    invsim_runtime::gradient::ModalWrt::new(params, &parameters, modes)
}

/// The value of derivative c of `wrt` in the plant: the parameter's in the first mode that takes it.
pub fn moved_value(
    p: &invsim_runtime::modes::ModalPlant,
    wrt: &invsim_runtime::gradient::ModalWrt,
    c: usize,
) -> f64 {
    p.models()
        .zip(&wrt.columns)
        .find(|(_, col)| col[c].is_some())
        .map(|(m, _)| m.params()[wrt.params[c].param])
        .expect("a mode that takes it")
}
