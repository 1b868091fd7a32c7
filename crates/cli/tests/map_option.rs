//! `--map NAME=FILE.csv` (contract §6) on the command line: the new values are used by `simulate` and
//! `forward` of an ordinary model and of a model with operating modes (every mode that calls the map), and a
//! name no mode knows or data of the wrong arity exit 2 naming the map.

use crate::common::{invsim, json_file, root, stderr, tmp};
use std::path::{Path, PathBuf};

/// The BSFC map of si_engine_maps with every value times `factor`, written to `name`.
fn scaled_bsfc(name: &str, factor: f64) -> PathBuf {
    let text = std::fs::read_to_string(root().join("models/si_engine_maps_bsfc.csv")).expect("CSV");
    let mut out = String::new();
    let mut header_seen = false;
    for line in text.lines() {
        if line.starts_with('#') || !header_seen {
            header_seen |= !line.starts_with('#');
            out.push_str(line);
        } else {
            let mut cells = line.split(',');
            out.push_str(cells.next().expect("row label"));
            for c in cells {
                let v: f64 = c.trim().parse().expect("number");
                out.push_str(&format!(",{}", v * factor));
            }
        }
        out.push('\n');
    }
    let path = tmp(name);
    std::fs::write(&path, out).expect("write");
    path
}

/// si_engine_5speed with the BSFC map of si_engine_maps and an accumulated output through it, in a
/// directory of its own next to a copy of the map's CSV.
fn modal_model_with_map() -> PathBuf {
    let dir = tmp("modal-map");
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::copy(
        root().join("models/si_engine_maps_bsfc.csv"),
        dir.join("si_engine_maps_bsfc.csv"),
    )
    .expect("copy CSV");
    let mut text =
        std::fs::read_to_string(root().join("models/si_engine_5speed.toml")).expect("model");
    text.push_str(
        r#"
[outputs.fuel_bsfc]
expr = "bsfc(w_e, T_e)*max(T_e*w_e, 0)/3.6e9"
unit = "kg/s"
accumulate = true
doc = "fuel mass flow from the BSFC map"

[maps.bsfc]
args = ["w_e", "T_e"]
file = "si_engine_maps_bsfc.csv"
interp = "linear"
extrapolate = "clamp"
unit = "g/kWh"
doc = "brake-specific fuel consumption"
"#,
    );
    let path = dir.join("si_engine_5speed_bsfc.toml");
    std::fs::write(&path, text).expect("write model");
    path
}

/// `integrals.fuel_bsfc` of `command model --cycle ece` with `extra` arguments.
fn fuel_bsfc(command: &str, model: &Path, extra: &[&str], tag: &str) -> f64 {
    let json = tmp(&format!("map-option-{tag}.json"));
    let mut args = vec![
        command,
        model.to_str().expect("utf-8"),
        "--cycle",
        "ece",
        "--summary-json",
        json.to_str().expect("utf-8"),
    ];
    args.extend(extra);
    let o = invsim(&args);
    assert!(o.status.success(), "{tag}: {}", stderr(&o));
    json_file(&json)["integrals"]["fuel_bsfc"]
        .as_f64()
        .expect("fuel_bsfc")
}

/// Doubling every value of a bilinear map doubles the output through it exactly (×2 is exact in binary
/// floating point), so the ratio is 2 to rounding: the new data are the ones used.
#[test]
fn map_replaces_the_values_for_ordinary_and_modal_models() {
    let doubled = scaled_bsfc("bsfc-doubled.csv", 2.0);
    let doubled = format!("bsfc={}", doubled.display());
    let single = root().join("models/si_engine_maps.toml");
    let modal = modal_model_with_map();
    for (command, model, tag) in [
        ("simulate", &single, "single"),
        ("simulate", &modal, "modal"),
        ("forward", &modal, "modal-forward"),
    ] {
        let base = fuel_bsfc(command, model, &[], &format!("{tag}-base"));
        let new = fuel_bsfc(command, model, &["--map", &doubled], &format!("{tag}-map"));
        assert!(base > 0.0, "{tag}: {base}");
        assert!((new / base - 2.0).abs() < 1e-9, "{tag}: {new} / {base}");
    }
}

#[test]
fn map_with_an_unknown_name_or_the_wrong_arity_exits_2() {
    let modal = modal_model_with_map();
    let modal = modal.to_str().expect("utf-8");
    let csv = scaled_bsfc("bsfc-same.csv", 1.0);
    let unknown = format!("nope={}", csv.display());
    let o = invsim(&["simulate", modal, "--cycle", "ece", "--map", &unknown]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("nope") && e.contains("bsfc"), "{e}");
    let one_d = tmp("curve.csv");
    std::fs::write(&one_d, "x,value\n0,1\n1,2\n").expect("write");
    let wrong = format!("bsfc={}", one_d.display());
    let o = invsim(&["simulate", modal, "--cycle", "ece", "--map", &wrong]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("bsfc"), "{}", stderr(&o));
}
