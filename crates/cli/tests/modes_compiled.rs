//! The compiled modes of `models/si_engine_5speed.toml` (one generated module per mode, `invsim-models`)
//! against the interpreter: `simulate` on NEDC and UDDS at dt = 0.01 s with `--engine compiled` and
//! `--engine interpreted` give the same mode sequence and the same states, inputs and fuel within 1e-10
//! relative, the summary names the engine that ran; `--verify` and `forward` run on the compiled modes; a
//! model file that is not built in refuses `--engine compiled` with exit 2 and runs on the interpreter with
//! `--engine auto`.

use crate::common::{invsim, json_file, read_csv, root, stderr, tmp};

fn model() -> String {
    root()
        .join("models/si_engine_5speed.toml")
        .display()
        .to_string()
}

/// Run `simulate` with `engine` on `cycle` at dt = 0.01 s: (CSV, summary JSON, stdout).
fn run(engine: &str, cycle: &str) -> (std::path::PathBuf, serde_json::Value, String) {
    let csv = tmp(&format!("modes-compiled-{engine}-{cycle}.csv"));
    let json = tmp(&format!("modes-compiled-{engine}-{cycle}.json"));
    let o = invsim(&[
        "simulate",
        &model(),
        "--cycle",
        cycle,
        "--dt",
        "0.01",
        "--engine",
        engine,
        "--out",
        csv.to_str().expect("utf-8"),
        "--summary-json",
        json.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{engine} {cycle}: {}", stderr(&o));
    (
        csv,
        json_file(&json),
        String::from_utf8_lossy(&o.stdout).into_owned(),
    )
}

/// Every numeric column of `names` agrees within 1e-10 relative: |a − b| ≤ 1e-10 · max(|a|, |b|, S), S the
/// column's largest |a| (near a zero of a column, e.g. the brake force at its switch, both engines carry
/// rounding errors of order ε·S from cancellation, not ε·|value|); the mode column is equal at every sample.
fn assert_agree(cycle: &str, a: &std::path::Path, b: &std::path::Path, names: &[&str]) {
    let ((ha, ra), (hb, rb)) = (read_csv(a), read_csv(b));
    assert_eq!(ha, hb, "{cycle}: columns");
    assert_eq!(ra.len(), rb.len(), "{cycle}: samples");
    let col = |name: &str| ha.iter().position(|h| h == name).expect(name);
    let mode = col("mode");
    assert!(
        ra.iter().zip(&rb).all(|(x, y)| x[mode] == y[mode]),
        "{cycle}: mode sequence"
    );
    for name in names {
        let j = col(name);
        let num = |r: &Vec<String>| r[j].parse::<f64>().expect("number");
        let scale = ra.iter().map(|r| num(r).abs()).fold(0.0, f64::max);
        for (k, (x, y)) in ra.iter().zip(&rb).enumerate() {
            let (x, y) = (num(x), num(y));
            let bound = 1e-10 * x.abs().max(y.abs()).max(scale);
            assert!(
                (x - y).abs() <= bound,
                "{cycle}: {name} at sample {k}: compiled {x:e}, interpreted {y:e}"
            );
        }
    }
}

#[test]
fn compiled_modes_equal_the_interpreter_on_nedc_and_udds() {
    for cycle in ["nedc", "udds"] {
        let (ca, sa, ta) = run("compiled", cycle);
        let (cb, sb, tb) = run("interpreted", cycle);
        assert_eq!(sa["engine"], "compiled", "{cycle}");
        assert_eq!(sb["engine"], "interpreted", "{cycle}");
        assert!(ta.contains("engine: compiled"), "{ta}");
        assert!(tb.contains("engine: interpreted"), "{tb}");
        assert!(sa["modes"]["switches"].is_u64(), "{cycle}: switches");
        assert_eq!(
            sa["modes"]["switches"], sb["modes"]["switches"],
            "{cycle}: switches"
        );
        assert_agree(
            cycle,
            &ca,
            &cb,
            &["v", "p_i", "m_at", "F_b", "fuel", "fuel_volume"],
        );
        // The summary's integrals (fuel mass and volume) within 1e-10 relative.
        let (fa, fb) = (&sa["integrals"], &sb["integrals"]);
        let fa = fa.as_object().expect("integrals");
        for (k, va) in fa {
            let (x, y) = (
                va.as_f64().expect("number"),
                fb[k].as_f64().expect("number"),
            );
            assert!(
                (x - y).abs() <= 1e-10 * x.abs().max(y.abs()),
                "{cycle}: integral {k}: {x:e} vs {y:e}"
            );
        }
    }
}

#[test]
fn verify_and_forward_run_on_the_compiled_modes() {
    let o = invsim(&["simulate", &model(), "--cycle", "ece", "--verify"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("engine: compiled"), "{text}");
    let json = tmp("modes-compiled-forward.json");
    let o = invsim(&[
        "forward",
        &model(),
        "--cycle",
        "ece",
        "--summary-json",
        json.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(json_file(&json)["engine"], "compiled");
}

#[test]
fn an_edited_model_file_runs_on_the_interpreter() {
    let text = std::fs::read_to_string(model()).expect("model");
    let edited = tmp("modes-compiled-edited.toml");
    std::fs::write(&edited, format!("{text}\n# edited\n")).expect("write");
    let path = edited.to_str().expect("utf-8");
    let o = invsim(&["simulate", path, "--cycle", "ece", "--engine", "compiled"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no compiled code"), "{}", stderr(&o));
    let o = invsim(&["simulate", path, "--cycle", "ece"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("engine: interpreted"));
}
