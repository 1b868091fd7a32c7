//! The vehicle library's FASTSim imports against hand values: the 2026 Pacifica's fuel power at a standstill
//! is its idle floor (its engine efficiency table is 0 at zero load, so fuel over efficiency is 0/0 there with a
//! finite limit below the floor), and the 2020 Bolt's battery efficiency is the bilinear value of its table at
//! the C-rate of the auxiliary load and the temperature signal `T_res` (22 °C by default, or `--signal`).

use crate::common::{invsim, json_file, stderr, tmp};

/// A cycle standing still for `seconds`.
fn standstill(name: &str, seconds: usize) -> String {
    let path = tmp(name);
    let rows: String = (0..=seconds).map(|t| format!("{t},0.0\n")).collect();
    std::fs::write(&path, format!("time_s,speed_mps\n{rows}")).unwrap();
    path.display().to_string()
}

/// The summary JSON of `simulate MODEL --cycle CYCLE EXTRA…`.
fn run(model: &str, cycle: &str, tag: &str, extra: &[&str]) -> serde_json::Value {
    let json = tmp(&format!("{tag}.json"));
    let json_arg = json.display().to_string();
    let mut args = vec![
        "simulate",
        model,
        "--cycle",
        cycle,
        "--summary-json",
        &json_arg,
    ];
    args.extend_from_slice(extra);
    let o = invsim(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    json_file(&json)
}

#[test]
fn the_pacifica_burns_its_idle_floor_at_a_standstill() {
    // P_fc = P_aux/eta_alt = 700 W, load 700/211088 = 0.00332 on the table's first segment (0, 0)–(0.005,
    // 0.09338201): P_fc/e = 211088 · 0.005/0.09338201 = 11 302 W, below the floor P_idle = 13 000 W.
    let cycle = standstill("pacifica_stand.csv", 100);
    let s = run(
        "models/vehicles/chrysler_pacifica_2026.toml",
        &cycle,
        "pacifica_stand",
        &[],
    );
    let fuel = s["integrals"]["fuel_energy"].as_f64().unwrap();
    assert!((fuel - 13_000.0 * 100.0).abs() < 1e-9 * fuel, "{fuel}");
}

/// Linear interpolation between (x0, y0) and (x1, y1) at x.
fn lerp((x0, y0): (f64, f64), (x1, y1): (f64, f64), x: f64) -> f64 {
    y0 + (y1 - y0) * (x - x0) / (x1 - x0)
}

#[test]
fn the_bolt_reads_its_battery_table_at_the_c_rate_and_temperature() {
    // At a standstill the terminal power is the auxiliary load, P_el = 250 W: C = 250/(237.6e6 J/3600 s)
    // = 0.003788, between the table's C-rates −0.1 and 0.1 (rows 4 and 5 of
    // `pt_type.BEV.res.eff_interp.CRateTemperature.data.values`); the chemical power is P_el/eta.
    let c = 250.0 / (237.6e6 / 3600.0);
    let rows = [
        // (C-rate, [efficiency at 0, 23, 30, 45 °C])
        (
            -0.1,
            [0.9964599999999999, 0.997862182940346, 0.99823, 0.998602],
        ),
        (0.1, [0.996494, 0.997883658588665, 0.998247, 0.998645]),
    ];
    let eta = |t: f64, (t0, k0): (f64, usize), (t1, k1): (f64, usize)| {
        let at = |r: usize| lerp((t0, rows[r].1[k0]), (t1, rows[r].1[k1]), t);
        lerp((rows[0].0, at(0)), (rows[1].0, at(1)), c)
    };
    let cycle = standstill("bolt_stand.csv", 100);
    let model = "models/vehicles/chevrolet_bolt_2020.toml";
    for (tag, extra, expected) in [
        ("bolt_22", vec![], eta(22.0, (0.0, 0), (23.0, 1))),
        (
            "bolt_40",
            vec!["--signal", "T_res=40"],
            eta(40.0, (30.0, 2), (45.0, 3)),
        ),
    ] {
        let s = run(model, &cycle, tag, &extra);
        let power = s["integrals"]["battery_power"].as_f64().unwrap();
        let hand = 250.0 / expected * 100.0;
        assert!(
            (power - hand).abs() < 1e-9 * hand,
            "{tag}: {power} vs {hand}"
        );
    }
}
