//! `invsim simulate --gradient` as a user meets it: the summary's `gradient` block and text table, the
//! derivative of fuel in mass against central differences of two `--set` runs, the compiled engine against the
//! interpreter, a run inverted stably (non-causally), the runs not differentiated yet refused with exit 2
//! and the reason, and a map's grid values (a map replaced by `--map`, names refused, sweep columns).

use crate::common;
use common::*;

use serde_json::Value;

fn summary(model: &str, tag: &str, extra: &[&str]) -> (Value, String) {
    let mut args = vec![model, "--cycle", "ece"];
    args.extend_from_slice(extra);
    simulate_summary(&args, &format!("gradient-{tag}"))
}

/// The block has a row per figure (integrals, per 100 km, headline) with the parameters asked for; the text has
/// the table; d fuel/dm is the central difference of two runs at m ± 1e-3 kg (relative step 7.7e-7: the
/// fuel is a sum of ~10³ rounded terms, noise ~1e-13/7.7e-7 relative, far below the 1e-5 asked).
#[test]
fn the_gradient_block_the_table_and_fuel_against_central_differences() {
    let (s, text) = summary("models/si_engine.toml", "base", &["--gradient", "m,C_d"]);
    let g = &s["gradient"];
    for f in [
        "fuel",
        "fuel_per_100km",
        "fuel_volume",
        "headline.l_per_100km",
        "headline.mpg_us",
    ] {
        let row = g[f].as_object().unwrap_or_else(|| panic!("row {f}: {g}"));
        assert_eq!(row.keys().collect::<Vec<_>>(), ["C_d", "m"], "{f}");
    }
    assert!(
        text.contains("gradient (d figure / d parameter):"),
        "{text}"
    );
    assert!(
        text.lines().any(|l| l.trim_start().starts_with("m ")),
        "{text}"
    );
    let fuel = |m: f64| -> f64 {
        let (s, _) = summary(
            "models/si_engine.toml",
            &format!("m{m}"),
            &["--set", &format!("m={m}")],
        );
        s["integrals"]["fuel"].as_f64().expect("fuel")
    };
    let h = 1e-3;
    let fd = (fuel(1300.0 + h) - fuel(1300.0 - h)) / (2.0 * h);
    let exact = g["fuel"]["m"].as_f64().expect("a number");
    assert!(
        (exact - fd).abs() <= 1e-5 * fd.abs(),
        "d fuel/dm = {exact}, central differences {fd}"
    );
}

/// diesel_gasflow's zero dynamics are inverted stably (non-causally): `--gradient all` on NEDC writes the block
/// with a row per parameter; its one integral, the fuel W_f·T with W_f = 1e-6·u_delta·n_e·n_cyl/120, is linear
/// in u_delta and n_cyl, so d fuel/d u_delta = fuel/u_delta and d fuel/d n_cyl = fuel/n_cyl (to rounding).
/// (The derivatives through η itself are checked against central differences in tests/tests/gradient.rs.)
#[test]
fn a_stable_inversion_writes_the_gradient_block() {
    let json = tmp("gradient-diesel.json");
    let o = invsim(&[
        "simulate",
        "models/diesel_gasflow.toml",
        "--cycle",
        "nedc",
        "--gradient",
        "all",
        "--summary-json",
        json.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = json_file(&json);
    assert_eq!(s["inversion"], "stable", "{s}");
    let row = s["gradient"]["fuel"].as_object().expect("a fuel row");
    assert_eq!(row.len(), 28, "{row:?}");
    let fuel = s["integrals"]["fuel"].as_f64().expect("fuel");
    for (p, value) in [("u_delta", 110.0), ("n_cyl", 6.0)] {
        let d = row[p].as_f64().expect("a number");
        let exact = fuel / value;
        assert!(
            (d - exact).abs() <= 1e-12 * exact,
            "d fuel/d {p} = {d}, fuel/{p} = {exact}"
        );
    }
    assert!(row.values().all(|v| v.as_f64().is_some_and(f64::is_finite)));
}

/// The figure the gradient block calls `f`, from the summary `s`.
fn figure(s: &Value, f: &str) -> f64 {
    let v = match (f.strip_prefix("headline."), f.strip_suffix("_per_100km")) {
        (Some(field), _) => &s["headline"][field],
        (None, Some(name)) if s["integrals_per_100km"].get(name).is_some() => {
            &s["integrals_per_100km"][name]
        }
        _ => &s["integrals"][f],
    };
    v.as_f64().unwrap_or_else(|| panic!("figure {f}"))
}

/// `--engine interpreted` gives the compiled engine's gradient within 1e-12 (si_engine: r = n), compared as
/// p·d figure/dp, the figure's change for a relative change of p, against the figure (a derivative that is 0
/// exactly, d CO2/d rho_f of a volume flow, is rounding in both).
#[test]
fn compiled_and_interpreted_agree() {
    let params = [
        ("m", 1300.0),
        ("C_d", 0.32),
        ("V_d", 2.0e-3),
        ("rho_f", 745.0),
    ];
    let names = params.map(|(n, _)| n).join(",");
    let (c, _) = summary(
        "models/si_engine.toml",
        "c",
        &["--gradient", &names, "--engine", "compiled"],
    );
    let (i, _) = summary(
        "models/si_engine.toml",
        "i",
        &["--gradient", &names, "--engine", "interpreted"],
    );
    let (gc, gi) = (c["gradient"].as_object().expect("block"), &i["gradient"]);
    for (f, row) in gc {
        let scale = figure(&c, f).abs();
        for (p, value) in params {
            let (a, b) = (
                row[p].as_f64().expect("number"),
                gi[f][p].as_f64().expect("number"),
            );
            let tol = 1e-12 * (a.abs() * value).max(scale);
            assert!((a - b).abs() * value <= tol, "d{f}/d{p}: {a} vs {b}");
        }
    }
}

/// Refusals, exit 2, each naming why: an unknown and a repeated parameter, a
/// gearbox parameter named whole or with a gear the gearbox lacks, a model with modes switched quasi-statically.
#[test]
fn runs_not_differentiated_are_refused_with_the_reason() {
    let cases = [
        (
            "models/si_engine_5speed.toml",
            "i_g",
            "set per gear by the model's [gearbox]: differentiate by each gear's value, i_g[1] … i_g[5]",
        ),
        (
            "models/si_engine_5speed.toml",
            "m,i_g[6]",
            "`i_g[6]`: the gearbox has gears 1 … 5",
        ),
        (
            "models/si_engine_5speed.toml",
            "m --switching quasi-static",
            "runs with quasi-static switching are not differentiated yet",
        ),
        (
            "models/si_engine.toml",
            "m,no_such",
            "unknown parameter `no_such`",
        ),
        (
            "models/hev_p2.toml",
            "m --strategy ecms --equivalence 3",
            "runs with --equivalence are not differentiated yet",
        ),
        (
            "models/hev_p2.toml",
            "m --strategy rule-based",
            "runs with dp or rules are not differentiated yet",
        ),
        ("models/si_engine.toml", "m,m", "`m` is named twice"),
    ];
    for (model, names, why) in cases {
        let mut args = vec!["simulate", model, "--cycle", "ece", "--gradient"];
        args.extend(names.split(' '));
        let o = invsim(&args);
        assert_eq!(o.status.code(), Some(2), "{model} {names}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("--gradient: ") && e.contains(why),
            "{model} {names}: {e}"
        );
    }
}

/// `invsim sweep --gradient`: a column `d(FIGURE)/d(PARAMETER)` per figure and parameter, each row's equal to
/// `simulate --gradient` of that variant (the same run), in the CSV and the Parquet file alike, for a model
/// with modes too (a gear's ratio among the parameters).
#[test]
fn sweep_columns_are_each_variants_gradient() {
    let csv = tmp("gradient-sweep.csv");
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--grid",
        "m=1200:1400:3",
        "--gradient",
        "m,C_d",
        "--out",
        csv.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&csv);
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("column {name} in {header:?}"))
    };
    assert_eq!(rows.len(), 3);
    for (row, m) in rows.iter().zip(["1200", "1300", "1400"]) {
        let (s, _) = summary(
            "models/si_engine.toml",
            &format!("sweep-{m}"),
            &["--set", &format!("m={m}"), "--gradient", "m,C_d"],
        );
        for f in ["fuel", "fuel_per_100km", "headline.l_per_100km"] {
            for p in ["m", "C_d"] {
                let want = s["gradient"][f][p].as_f64().expect("a number");
                let got = num(&row[col(&format!("d({f})/d({p})"))]);
                assert_eq!(got, want, "m = {m}: d({f})/d({p})");
            }
        }
    }
    let parquet = tmp("gradient-sweep.parquet");
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--grid",
        "m=1200:1400:3",
        "--gradient",
        "m",
        "--out",
        parquet.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&parquet).expect("parquet written");
    let needle = b"d(fuel)/d(m)";
    assert!(bytes.windows(needle.len()).any(|w| w == needle));
    let modal = tmp("gradient-sweep-modes.csv");
    let o = invsim(&[
        "sweep",
        "models/si_engine_5speed.toml",
        "--cycle",
        "ece",
        "--grid",
        "m=1200:1400:2",
        "--gradient",
        "m,i_g[2]",
        "--out",
        modal.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&modal);
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("column {name} in {header:?}"))
    };
    for (row, m) in rows.iter().zip(["1200", "1400"]) {
        let (s, _) = summary(
            "models/si_engine_5speed.toml",
            &format!("sweep-modes-{m}"),
            &["--set", &format!("m={m}"), "--gradient", "m,i_g[2]"],
        );
        for p in ["m", "i_g[2]"] {
            let want = s["gradient"]["fuel"][p].as_f64().expect("a number");
            let got = num(&row[col(&format!("d(fuel)/d({p})"))]);
            assert_eq!(got, want, "m = {m}: d(fuel)/d({p})");
        }
    }
}

/// si_engine_maps' BSFC map as a `--map` CSV with a seventh speed row (700 rad/s), its value (2, 2) (200 rad/s,
/// 30 N m) set to `v22`.
fn bsfc_csv(tag: &str, v22: f64) -> String {
    let path = tmp(&format!("gradient-bsfc-{tag}.csv"));
    let text = format!(
        "w_e \\ T_e,10,30,60,90,120,150,180\n\
         100,980,520,345,300,285,280,290\n\
         200,900,{v22},320,280,262,255,262\n\
         300,880,455,310,272,255,248,255\n\
         400,900,462,315,276,258,252,262\n\
         500,950,485,328,287,268,262,275\n\
         600,1020,515,345,300,280,275,292\n\
         700,1100,550,365,315,295,290,310\n"
    );
    std::fs::write(&path, text).expect("written");
    path.to_str().expect("utf-8").to_string()
}

/// `--map bsfc=FILE.csv` with a grid of seven speeds: the grid values are those of the map in use
/// (`bsfc[7,7]` exists only in it), the table names them, and d fuel_bsfc/d bsfc[2,2] equals the central
/// difference of two runs with that value moved by ±1 g/kWh (the figure is linear in the map's values: exact
/// to rounding); without `--map` the seventh row is refused with the grid's extent.
#[test]
fn grid_values_of_a_replaced_map() {
    let model = "models/si_engine_maps.toml";
    let run = |tag: &str, v22: f64, extra: &[&str]| {
        let csv = bsfc_csv(tag, v22);
        let map = format!("bsfc={csv}");
        let mut args = vec![model, "--cycle", "ece", "--dt", "0.1", "--map", &map];
        args.extend_from_slice(extra);
        simulate_summary(&args, &format!("gradient-map-{tag}"))
    };
    let (s, text) = run("base", 470.0, &["--gradient", "m,bsfc[2,2],bsfc[7,7]"]);
    let g = &s["gradient"]["fuel_bsfc"];
    assert!(text.contains("  bsfc[2,2] "), "{text}");
    assert_eq!(
        g["bsfc[7,7]"].as_f64(),
        Some(0.0),
        "700 rad/s is never reached"
    );
    let exact = g["bsfc[2,2]"].as_f64().expect("a number");
    let f = |s: &Value| s["integrals"]["fuel_bsfc"].as_f64().expect("a number");
    let d = (f(&run("plus", 471.0, &[]).0) - f(&run("minus", 469.0, &[]).0)) / 2.0;
    assert!(
        exact > 0.0 && (exact - d).abs() <= 1e-9 * d,
        "{exact:e} vs {d:e}"
    );
    let o = invsim(&[
        "simulate",
        model,
        "--cycle",
        "ece",
        "--gradient",
        "bsfc[7,7]",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("i = 1 … 6 along its x grid"),
        "{}",
        stderr(&o)
    );
}

/// Grid values named wrong exit 2 with the name and what was expected: an index off the grid, a 1-D index of a
/// 2-D map, a value named twice (the whole map and one of its values), a map the model lacks (the list of
/// known names says the maps' grid values).
#[test]
fn grid_values_named_wrong_are_refused_with_what_is_expected() {
    let cases = [
        (
            "bsfc[7,1]",
            "`bsfc[7,1]` is not a grid value of its map: name one as bsfc[i,j] with i = 1 … 6 along its x \
             grid and j = 1 … 7 along its y grid",
        ),
        ("eta_vol[3]", "`eta_vol[3]` is not a grid value of its map: name one as eta_vol[i,j] with i = 1 … 8"),
        ("bsfc,bsfc[2,2]", "`bsfc[2,2]` is named twice"),
        ("no_map[1]", "unknown parameter `no_map[1]`"),
        ("no_map[1]", "the maps' grid values eta_vol[i,j] with i = 1 … 8"),
    ];
    for (names, why) in cases {
        let o = invsim(&[
            "simulate",
            "models/si_engine_maps.toml",
            "--cycle",
            "ece",
            "--gradient",
            names,
        ]);
        assert_eq!(o.status.code(), Some(2), "{names}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains("--gradient: ") && e.contains(why),
            "{names}: {e}"
        );
    }
}

/// `invsim sweep --gradient m,bsfc[2,2]`: the grid value's column `d(FIGURE)/d(bsfc[2,2])` (its comma kept
/// inside the brackets) equals `simulate --gradient` of that variant.
#[test]
fn sweep_columns_of_a_grid_value() {
    let csv = tmp("gradient-sweep-map.csv");
    let model = "models/si_engine_maps.toml";
    let o = invsim(&[
        "sweep",
        model,
        "--cycle",
        "ece",
        "--grid",
        "m=1200:1400:2",
        "--gradient",
        "m,bsfc[2,2]",
        "--out",
        csv.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&csv);
    let name = "d(fuel_bsfc)/d(bsfc[2,2])";
    let col = header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("{name} in {header:?}"));
    for (row, m) in rows.iter().zip(["1200", "1400"]) {
        let (s, _) = summary(
            model,
            &format!("sweep-map-{m}"),
            &["--set", &format!("m={m}"), "--gradient", "bsfc[2,2]"],
        );
        let want = s["gradient"]["fuel_bsfc"]["bsfc[2,2]"]
            .as_f64()
            .expect("a number");
        assert!(want > 0.0);
        assert_eq!(num(&row[col]), want, "m = {m}");
    }
}
