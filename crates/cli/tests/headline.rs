//! The summary leads with the model's headline in the units people report: a shipped conventional car in
//! l/100 km, mpg and CO₂ g/km, the BEV in kWh/100 km and mpgge, text and JSON alike (for `simulate` and
//! `forward`); the Fusions say which of their fuel figures is the model's answer.

use crate::common;
use common::*;

use serde_json::Value;

/// `invsim ARGS --summary-json`: the text summary and the JSON.
fn run(name: &str, args: &[&str]) -> (String, Value) {
    let json = tmp(&format!("headline_{name}.json"));
    let mut all = args.to_vec();
    all.extend(["--summary-json", json.to_str().unwrap()]);
    let o = invsim(&all);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        json_file(&json),
    )
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn close(a: f64, b: f64, rel: f64) {
    assert!(
        (a - b).abs() <= rel * b.abs(),
        "{a} is not {b} within {rel}"
    );
}

/// The line of the text summary that starts with `prefix`.
fn line<'t>(text: &'t str, prefix: &str) -> &'t str {
    text.lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line `{prefix}…` in:\n{text}"))
}

/// si_engine on the NEDC: the first line is the headline, l/100 km as the `fuel_volume` integral per 100 km,
/// mpg = 235.2146 (US) and 282.4809 (UK) over it, CO₂ = its litres × 0.745 kg/l × 3.17307 kg/kg per km.
#[test]
fn a_conventional_car_leads_with_litres_mpg_and_co2() {
    let (text, s) = run(
        "si_nedc",
        &["simulate", "models/si_engine.toml", "--cycle", "nedc"],
    );
    let first = text.lines().next().unwrap_or("");
    assert!(
        first.starts_with(
            "headline: 6.846 l/100 km = 34.36 mpg (US) = 41.26 mpg (UK), CO2 161.8 g/km (petrol;"
        ),
        "{first}"
    );
    assert_eq!(text.lines().nth(1), Some("model: si_engine"));
    assert!(line(&text, "fuel_volume:").ends_with("(the model's answer: the headline)"));
    assert!(!line(&text, "fuel:").contains("headline"));

    let keys: Vec<&String> = s.as_object().unwrap().keys().collect();
    assert_eq!(keys[0], "headline", "the JSON leads with it too");
    let h = &s["headline"];
    assert_eq!(h["output"], "fuel_volume");
    assert_eq!(h["kind"], "fuel");
    assert_eq!(h["fuel"], "petrol");
    let l100 = f(&h["l_per_100km"]);
    assert_eq!(l100, f(&s["integrals_per_100km"]["fuel_volume"]));
    // 100 km / 1.609344 km/mi = 62.137 mi on l100 / 3.785411784 US gal (l100 / 4.54609 UK gal).
    close(
        f(&h["mpg_us"]),
        100.0 * 3.785_411_784 / (1.609_344 * l100),
        1e-12,
    );
    close(
        f(&h["mpg_uk"]),
        100.0 * 4.546_09 / (1.609_344 * l100),
        1e-12,
    );
    let km = f(&s["distance_m"]) / 1000.0;
    let co2_g = f(&s["integrals"]["fuel_volume"]) * 0.745 * 3.173_074 * 1000.0;
    close(f(&h["co2_g_per_km"]), co2_g / km, 1e-6);
    // The litres and kilograms are the model's own two integrals (density rho_f = 745 kg/m³).
    close(f(&h["kg"]), f(&s["integrals"]["fuel"]), 1e-12);
}

/// `--set rho_f`: the headline's density is the model's parameter, so its kg follow the litres.
#[test]
fn the_density_is_the_models_parameter() {
    let (_, s) = run(
        "si_rho",
        &[
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--set",
            "rho_f=760",
        ],
    );
    let h = &s["headline"];
    assert_eq!(f(&h["density_kg_per_m3"]), 760.0);
    close(f(&h["kg"]), f(&s["integrals"]["fuel"]), 1e-12);
}

/// The BEV on the NEDC: kWh/100 km as the `energy` integral per 100 km, Wh/mi = 10 × 1.609344 × it, mpgge =
/// 3370.5 / (1.609344 × it); `forward` leads with it too.
#[test]
fn the_bev_leads_with_kwh_per_100km_and_mpgge() {
    for command in ["simulate", "forward"] {
        let (text, s) = run(
            &format!("bev_{command}"),
            &[command, "models/bev.toml", "--cycle", "nedc"],
        );
        let first = text.lines().next().unwrap_or("");
        assert!(first.starts_with("headline: "), "{command}: {first}");
        assert!(
            first.contains(" kWh/100 km = ") && first.contains(" mpgge"),
            "{first}"
        );
        assert!(first.contains("the output energy"), "{first}");
        let h = &s["headline"];
        assert_eq!(
            (&h["output"], &h["kind"]),
            (&Value::from("energy"), &Value::from("electricity"))
        );
        let k = f(&h["kwh_per_100km"]);
        assert_eq!(k, f(&s["integrals_per_100km"]["energy"]));
        assert!(k > 5.0 && k < 30.0, "{command}: {k} kWh/100 km");
        close(f(&h["wh_per_mi"]), 10.0 * 1.609_344 * k, 1e-12);
        close(f(&h["mpgge"]), 3370.5 / (1.609_344 * k), 1e-12);
    }
}

/// The imported quasi-static Fusion reports its fuel as kg and J (`fuel`, `fuel_energy`); the dynamic one has
/// `fuel`, `fuel_fastsim_map`, `fuel_volume` and more: each summary says which is the model's answer.
#[test]
fn the_fusions_say_which_fuel_figure_is_the_answer() {
    let (text, s) = run(
        "fusion_import",
        &[
            "simulate",
            "models/vehicles/ford_fusion_2012.toml",
            "--cycle",
            "udds",
        ],
    );
    assert!(text.starts_with("headline: "), "{text}");
    assert!(line(&text, "fuel:").ends_with("(the model's answer: the headline)"));
    assert!(!line(&text, "fuel_energy:").contains("answer"));
    let h = &s["headline"];
    assert_eq!(h["output"], "fuel");
    // kg → litres at petrol's default 745 kg/m³.
    close(f(&h["litres"]), f(&s["integrals"]["fuel"]) / 0.745, 1e-12);

    let (text, s) = run(
        "fusion_dynamic",
        &[
            "simulate",
            "models/ford_fusion_2012_dynamic.toml",
            "--cycle",
            "ece",
        ],
    );
    assert_eq!(s["headline"]["output"], "fuel_volume");
    for (output, answer) in [
        ("fuel_volume:", true),
        ("fuel:", false),
        ("fuel_fastsim_map:", false),
        ("fuel_idle:", false),
    ] {
        assert_eq!(
            line(&text, output).ends_with("(the model's answer: the headline)"),
            answer,
            "{output}"
        );
    }
}

/// A model without `[headline]` has no headline: its summary starts with the model as before.
#[test]
fn a_model_without_a_headline_has_none() {
    let (text, s) = run(
        "driveline",
        &["simulate", "models/driveline.toml", "--cycle", "ece"],
    );
    assert!(text.starts_with("model: driveline"), "{text}");
    assert!(s.get("headline").is_none());
}

/// The BEV's sweep rows carry its headline's columns, `kwh_per_100km` and `mpgge`, and no fuel's.
#[test]
fn a_bev_sweep_has_the_electric_headline_columns() {
    let out = tmp("headline_bev_sweep.csv");
    let o = invsim(&[
        "sweep",
        "models/bev.toml",
        "--cycle",
        "ece",
        "--grid",
        "m=1400:1800:2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&out);
    let at = |name: &str| header.iter().position(|h| h == name);
    assert!(at("l_per_100km").is_none(), "{header:?}");
    let (k, g) = (at("kwh_per_100km").unwrap(), at("mpgge").unwrap());
    let per = at("energy_per_100km").unwrap();
    for row in &rows {
        assert_eq!(num(&row[k]), num(&row[per]));
        close(num(&row[g]), 3370.5 / (1.609_344 * num(&row[k])), 1e-12);
    }
    assert!(
        num(&rows[1][k]) > num(&rows[0][k]),
        "a heavier car draws more"
    );
}
