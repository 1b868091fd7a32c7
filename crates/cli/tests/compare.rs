//! `invsim compare`: two runs' figures side by side with their differences to the first (against hand
//! values of hand-written summaries, and on two real runs), the refusal of files that are no summaries, the
//! warning for different cycles, and `--plot` overlaying the runs' CSV series.

use crate::common;
use common::{invsim, json_file, stderr, tmp};
use serde_json::{json, Value};

/// A minimal summary with the given cycle and fuel figures (what `simulate --summary-json` writes, cut down).
fn summary(name: &str, cycle: &str, fuel_kg: f64, per_100km: f64) -> String {
    let path = tmp(name);
    let v = json!({
        "model": "m", "cycle": cycle, "duration_s": 1180.0, "distance_m": 10000.0,
        "integrals": {"fuel": fuel_kg}, "integrals_per_100km": {"fuel": per_100km},
        "integral_units": {"fuel": "kg"}, "input": "u", "input_unit": "kg/s", "input_max": 0.04,
        "input_bound_violations": [[10.0, 12.5]],
        "provenance": {"command": "simulate"}
    });
    std::fs::write(&path, v.to_string()).unwrap();
    path.display().to_string()
}

fn figure<'a>(v: &'a Value, name: &str) -> &'a Value {
    v["figures"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["name"] == name)
        .unwrap_or_else(|| panic!("figure {name} in {v}"))
}

#[test]
fn differences_to_the_first_run_are_the_hand_values() {
    let a = summary("hand_a.json", "nedc", 0.5, 5.0);
    let b = summary("hand_b.json", "nedc", 0.55, 5.5);
    let o = invsim(&["compare", &a, &b]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).is_empty(),
        "same cycle: no warning: {}",
        stderr(&o)
    );
    let text = String::from_utf8(o.stdout).unwrap();
    let row = text
        .lines()
        .find(|l| l.starts_with("integrals_per_100km.fuel"))
        .unwrap();
    let cells: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(
        cells,
        [
            "integrals_per_100km.fuel",
            "kg/100",
            "km",
            "5",
            "5.5",
            "+0.5",
            "+10.00",
            "%"
        ]
    );
    assert!(text.contains("run B: ") && text.contains("hand_b.json — m on nedc (simulate)"));
    let o = invsim(&["compare", &a, &b, "--format", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["runs"][1]["label"], "B");
    let fuel = figure(&v, "integrals.fuel");
    assert_eq!(fuel["unit"], "kg");
    assert_eq!(fuel["values"], json!([0.5, 0.55]));
    let d = fuel["differences"][1].as_f64().unwrap();
    let r = fuel["relative_differences"][1].as_f64().unwrap();
    assert!(
        (d - 0.05).abs() < 1e-15 && (r - 0.1).abs() < 1e-12,
        "{d} {r}"
    );
    assert_eq!(fuel["differences"][0], 0.0);
    let t = figure(&v, "time outside the input's bounds");
    assert_eq!(t["values"], json!([2.5, 2.5]));
}

#[test]
fn runs_on_different_cycles_are_compared_with_a_warning() {
    let a = summary("cyc_a.json", "nedc", 0.5, 5.0);
    let b = summary("cyc_b.json", "udds", 0.6, 5.0);
    let o = invsim(&["compare", &a, &b]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("warning: the runs drove different cycles (A drove `nedc`, B drove `udds`)"),
        "{e}"
    );
}

#[test]
fn files_that_are_no_summaries_exit_2_naming_the_file_and_what_was_expected() {
    let a = summary("ok.json", "nedc", 0.5, 5.0);
    let not_json = tmp("not.json");
    std::fs::write(&not_json, "t,v\n0,1\n").unwrap();
    let array = tmp("array.json");
    std::fs::write(&array, "[1, 2]").unwrap();
    let partial = tmp("partial.json");
    std::fs::write(
        &partial,
        r#"{"model": "m", "cycle": "nedc", "duration_s": 1}"#,
    )
    .unwrap();
    for (file, why) in [
        (&not_json, "it is not JSON"),
        (&array, "it is not a JSON object"),
        (
            &partial,
            "its member `distance_m` is missing or not a number",
        ),
    ] {
        let o = invsim(&["compare", &a, file.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{}", file.display());
        let e = stderr(&o);
        assert!(
            e.contains(&format!(
                "{} is not an invsim summary: {why}",
                file.display()
            )) && e.contains("expected the JSON that `invsim simulate` or `invsim forward` writes"),
            "{e}"
        );
    }
    let o = invsim(&["compare", &a, "no/such/file.json"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("cannot read the summary no/such/file.json"));
    let o = invsim(&["compare", &a]);
    assert_eq!(o.status.code(), Some(2), "one run is nothing to compare");
}

/// Run si_engine on the ECE cycle with `sets`, writing `NAME.json` and `NAME.csv`.
fn run(name: &str, sets: &[&str]) -> (String, String) {
    let (json, csv) = (tmp(&format!("{name}.json")), tmp(&format!("{name}.csv")));
    let mut args = vec![
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--summary-json",
        json.to_str().unwrap(),
        "--out",
        csv.to_str().unwrap(),
    ];
    args.extend_from_slice(sets);
    let o = invsim(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    (json.display().to_string(), csv.display().to_string())
}

fn polylines(svg: &str, var: &str) -> Vec<String> {
    let start = svg.find(&format!("data-var=\"{var}\"")).unwrap();
    let end = svg[start..]
        .find("<g class=\"panel\"")
        .map_or(svg.len(), |e| start + e);
    let panel = &svg[start..end];
    panel
        .match_indices("<polyline class=\"series\"")
        .map(|(i, _)| {
            panel[i..]
                .split_once("stroke=\"")
                .unwrap()
                .1
                .split('"')
                .next()
                .unwrap()
                .to_string()
        })
        .collect()
}

#[test]
fn two_real_runs_compare_and_overlay() {
    let (a, _) = run("real_a", &[]);
    let (b, b_csv) = run("real_b", &["--set", "m=1500"]);
    let svg = tmp("overlay.svg");
    let o = invsim(&[
        "compare",
        &a,
        &b,
        "--format",
        "json",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let (ja, jb) = (json_file(a.as_ref()), json_file(b.as_ref()));
    let fa = ja["integrals_per_100km"]["fuel_volume"].as_f64().unwrap();
    let fb = jb["integrals_per_100km"]["fuel_volume"].as_f64().unwrap();
    assert!(fb > fa, "a heavier car uses more fuel");
    let row = figure(&v, "integrals_per_100km.fuel_volume");
    assert_eq!(row["unit"], "l/100 km");
    assert_eq!(row["differences"][1].as_f64().unwrap(), fb - fa);
    assert_eq!(
        row["relative_differences"][1].as_f64().unwrap(),
        (fb - fa) / fa
    );
    // The overlay: the default panels, one curve per run in the runs' colours, the headline with B's change.
    let text = std::fs::read_to_string(&svg).unwrap();
    for var in ["reference", "input", "cum:fuel_volume"] {
        assert_eq!(
            polylines(&text, var),
            ["#D55E00", "#0072B2"],
            "{var}: B under A"
        );
    }
    let pct = format!("({:+.2} %)", 100.0 * (fb - fa) / fa);
    assert!(
        text.contains(&pct) && text.contains("fuel_volume: A "),
        "{pct}"
    );
    // The plot may not replace an input; a series that is not the run's is refused.
    let o = invsim(&[
        "compare",
        &a,
        &b,
        "--plot",
        &b_csv.replace(".csv", ".svg"),
        "--series",
        &b_csv,
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("--series: 1 file(s) for 2 runs"),
        "{}",
        stderr(&o)
    );
    let (f_json, f_csv) = (tmp("fwd.json"), tmp("fwd.csv"));
    let o = invsim(&[
        "forward",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--summary-json",
        f_json.to_str().unwrap(),
        "--out",
        f_csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = invsim(&[
        "compare",
        &a,
        &b,
        "--plot",
        tmp("x.svg").to_str().unwrap(),
        "--series",
        &format!("{},{b_csv}", f_csv.display()),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("it is another run's series"),
        "{}",
        stderr(&o)
    );
    let o = invsim(&["compare", &a, &b, "--plot", &a]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn the_plot_never_replaces_a_summary_or_a_series() {
    let (a, a_csv) = run("keep_a", &[]);
    let (b, _) = run("keep_b", &["--set", "m=1400"]);
    let svg = a.replace(".json", ".svg");
    std::fs::copy(&a_csv, &svg).unwrap();
    let o = invsim(&[
        "compare",
        &a,
        &b,
        "--plot",
        &svg,
        "--series",
        &format!("{svg},{}", b.replace(".json", ".csv")),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("an input of this run"),
        "{}",
        stderr(&o)
    );
}
