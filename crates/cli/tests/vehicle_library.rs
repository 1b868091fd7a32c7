//! The vehicle library's FASTSim imports against hand values: the 2026 Pacifica's stop-start and fuel cut-off
//! (the idle fuel they save; its engine efficiency table is 0 at zero load, so fuel over efficiency is 0/0
//! there with a finite limit below the idle floor), and the 2020 Bolt's battery efficiency is the bilinear value of its table at
//! the C-rate of the auxiliary load and the temperature signal `T_res` (22 °C by default, or `--signal`).

use crate::common::{invsim, json_file, num, read_csv, stderr, tmp};

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
fn the_pacifica_stops_its_engine_at_a_standstill_and_cuts_its_fuel_when_decelerating() {
    // At a standstill the engine would burn its idle floor: P_fc = P_aux/eta_alt = 700 W, load
    // 700/211088 = 0.00332 on the table's first segment (0, 0)–(0.005, 0.09338201), P_fc/e = 211088 ·
    // 0.005/0.09338201 = 11 302 W, below P_idle = 13 000 W. Stop-start saves all of it: 13 kW · 100 s.
    let stand = standstill("pacifica_stand.csv", 100);
    let model = "models/vehicles/chrysler_pacifica_2026.toml";
    let fuel = |cycle: &str, tag: &str, extra: &[&str]| {
        let mut args = vec!["--lookahead", "0.5"];
        args.extend_from_slice(extra);
        run(model, cycle, tag, &args)["integrals"]["fuel_energy"]
            .as_f64()
            .unwrap()
    };
    assert_eq!(fuel(&stand, "pac_stand", &[]), 0.0);
    let running = fuel(&stand, "pac_stand_on", &["--set", "v_stop=-1"]);
    assert!(
        (running - 13_000.0 * 100.0).abs() < 1e-9 * running,
        "{running}"
    );
    // 20 m/s for 30 s, braking at 1 m/s² to a stop at 50 s, standing to 60 s. The fuel is cut while the car
    // decelerates at 0.3 m/s² or more above 10 m/s without traction: from the ramp's start to v = 10 m/s at
    // 40 s, 10 s in which the engine would otherwise burn its idle floor (its load is the auxiliary one).
    // The smoothed corner (a = 0.5 s) moves both ends by less than 0.3 s.
    let path = tmp("pacifica_brake.csv");
    let rows: String = (0..=60)
        .map(|t| {
            let v = if t <= 30 {
                20.0
            } else {
                (50.0 - t as f64).max(0.0)
            };
            format!("{t},{v}\n")
        })
        .collect();
    std::fs::write(&path, format!("time_s,speed_mps\n{rows}")).unwrap();
    let brake = path.display().to_string();
    let cut = fuel(&brake, "pac_brake", &[]);
    let no_cut = fuel(&brake, "pac_brake_nocut", &["--set", "v_dfco=1e9"]);
    let saved = no_cut - cut;
    assert!(
        (saved - 13_000.0 * 10.0).abs() < 13_000.0 * 0.3,
        "saved {saved} J"
    );
    // And the stop at 50–60 s: stop-start saves the idle floor there, 13 kW for about 10 s.
    let no_stop = fuel(&brake, "pac_brake_nostop", &["--set", "v_stop=-1"]);
    let saved = no_stop - cut;
    assert!(
        (saved - 13_000.0 * 10.0).abs() < 13_000.0 * 0.3,
        "saved {saved} J"
    );
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

#[test]
fn the_thermal_pacifica_warms_up_as_its_linear_model_says() {
    // Standing from a cold start (T_fc = 295.15 K, T_amb = 22 °C), the engine runs while colder than
    // T_fc_on = 333.15 K (stop-start may not stop it) at a constant load: its auxiliary 700 W. With the idle
    // floor raised to P_idle = 30 kW the fuel power is 30 kW whatever the cold efficiency, so the heat into
    // the engine is constant, Q = f_comb (P_idle − 700 W) = 0.5 · 29 300 = 14 650 W (below the flame's
    // conduction G (T_ad − T) ≈ 27.7 kW), and with the thermostat closed the heat to the ambient is
    // h A (T − T_amb), h = h_fc_stop (set to 300 W/(m² K) so that the loss shows), A = π 0.7²/4. The linear
    // model C dT/dt = Q − h A (T − T_amb) gives T(t) = T_amb + Q/(hA) + (T0 − T_amb − Q/(hA)) e^{−hA t/C}, and
    // the warm-up time to T1: t1 = C/(hA) ln((Q/(hA) − (T0 − T_amb))/(Q/(hA) − (T1 − T_amb))).
    let stand = standstill("pacifica_thrml_stand.csv", 400);
    let model = "models/vehicles/chrysler_pacifica_2026_thrml.toml";
    let csv = tmp("pacifica_thrml_stand_out.csv");
    let csv_arg = csv.display().to_string();
    let set = [
        "--set",
        "P_idle=30000",
        "--set",
        "h_fc_stop=300",
        "--dt",
        "0.1",
        "--out",
        &csv_arg,
    ];
    run(model, &stand, "pac_thrml_stand", &set);
    let (header, rows) = read_csv(&csv);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (t, temp) = (col("t"), col("T_fc"));
    let (c, h, l) = (106_945.694_570_460_9, 300.0, 0.7);
    let ha = h * std::f64::consts::PI * l * l / 4.0;
    let q = 0.5 * (30_000.0 - 700.0);
    let (t0, t_amb, t1) = (295.15, 295.15, 328.15);
    let closed = c / ha * ((q / ha - (t0 - t_amb)) / (q / ha - (t1 - t_amb))).ln();
    // The run's first sample at or above T1, interpolated back to the crossing.
    let k = rows.iter().position(|r| num(&r[temp]) >= t1).unwrap();
    let (a, b) = (&rows[k - 1], &rows[k]);
    let crossing = lerp((num(&a[temp]), num(&a[t])), (num(&b[temp]), num(&b[t])), t1);
    // 33 K: 279.0 s by the closed form; the heat alone (no loss) would take C (T1 − T0)/Q = 240.9 s.
    assert!((closed - 279.0).abs() < 0.1, "{closed}");
    assert!(
        (crossing - closed).abs() < 0.002 * closed,
        "run {crossing} s, closed form {closed} s"
    );
}
