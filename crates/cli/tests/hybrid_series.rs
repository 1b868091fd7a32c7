//! `models/series_hybrid.toml` under `simulate --strategy ecms|dp|rule-based` on UDDS, HWFET and WLTC 3b:
//! ECMS and DP charge-sustaining, the fuel ordered DP ≤ ECMS ≤ rule-based (J1711-corrected) within DP's grid
//! error, the fuel per distance within the range the Nissan Note e-Power's certified figures span; the genset on
//! its best-efficiency line at every sample it runs (speed, torque and fuel power against a numerical
//! minimisation of the Willans fuel power over the speed, and against the closed form), and at every sample the
//! vehicle's and the battery's equations written out by hand: the decided generator power enters the battery's
//! alone.

use crate::common::{column as col, simulate_with};
use serde_json::Value;

const MODEL: &str = "models/series_hybrid.toml";

/// The model's parameters, as in the file.
const M: f64 = 1300.0;
const CD_AF_RHO: f64 = 0.30 * 2.2 * 1.2;
const C_R: f64 = 0.009;
const G_0: f64 = 9.81;
const V_EPS: f64 = 0.1;
const R_W: f64 = 0.31;
const J_W: f64 = 2.0;
const I_R: f64 = 7.388;
const ETA_T: f64 = 0.97;
const J_M: f64 = 0.05;
const V_D: f64 = 1.198e-3;
const E_W: f64 = 0.45;
const P_0_FRICTION: f64 = 0.9e5;
const P_2_FRICTION: f64 = 0.1249;
const K_FL: f64 = 1.751e-3;
const W_MIN: f64 = 125.66;
const ETA_G: f64 = 0.92;
const H_L: f64 = 42.5e6;
const RHO_F: f64 = 745.0;
const K_C: f64 = 0.03;
const K_I: f64 = 1.0e-3;
const P_0: f64 = 150.0;
const U_OC: f64 = 280.0;
const R_I: f64 = 0.2;
const P_AUX: f64 = 300.0;

/// A run of `simulate --dt 1` with `args` (the strategy among them): the summary JSON and the CSV.
fn run(cycle: &str, args: &[&str], tag: &str) -> (Value, Vec<String>, Vec<Vec<String>>) {
    let mut all = vec![MODEL, "--cycle", cycle, "--dt", "1"];
    all.extend_from_slice(args);
    simulate_with(&all, tag)
}

fn hybrid_f64(v: &Value, key: &str) -> f64 {
    v["hybrid"][key]
        .as_f64()
        .unwrap_or_else(|| panic!("hybrid.{key}"))
}

/// The J1711-corrected fuel of a run in litres per 100 km: the fuel energy over the heating value and density.
fn l_per_100km(v: &Value) -> f64 {
    let litres = hybrid_f64(v, "fuel_energy_corrected_j") / (H_L * RHO_F) * 1000.0;
    litres / (v["distance_m"].as_f64().unwrap() / 1.0e5)
}

/// The genset's fuel power at engine power p (W) and speed w (rad/s): the Willans line with the friction mean
/// effective pressure p_0 + p_2 w², (p + c_0 w + c_2 w³ + k_fl p²/w)/e_w.
fn fuel_power(p: f64, w: f64) -> f64 {
    let (c0, c2) = (
        V_D * P_0_FRICTION / (4.0 * std::f64::consts::PI),
        V_D * P_2_FRICTION / (4.0 * std::f64::consts::PI),
    );
    (p + c0 * w + c2 * w.powi(3) + K_FL * p * p / w) / E_W
}

/// The speed in [w_min, 1000 rad/s] of least fuel power for engine power p, by golden-section search (the
/// fuel power is convex in w) to 10⁻¹² rad/s: a reference independent of the model's closed form.
fn best_speed_by_search(p: f64) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (W_MIN, 1000.0);
    while b - a > 1e-12 * b {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if fuel_power(p, x1) <= fuel_power(p, x2) {
            b = x2;
        } else {
            a = x1;
        }
    }
    0.5 * (a + b)
}

/// The closed form of the file: the positive root of 3 c_2 w⁴ + c_0 w² − k_fl p² = 0, floored at w_min.
fn best_speed_closed_form(p: f64) -> f64 {
    let (c0, c2) = (
        V_D * P_0_FRICTION / (4.0 * std::f64::consts::PI),
        V_D * P_2_FRICTION / (4.0 * std::f64::consts::PI),
    );
    let w2 = ((c0 * c0 + 12.0 * c2 * K_FL * p * p).sqrt() - c0) / (6.0 * c2);
    w2.sqrt().max(W_MIN)
}

/// On UDDS, HWFET and WLTC 3b: ECMS (searched s) and DP (default grids) end within 10⁻⁴ of the start charge;
/// DP's fuel is at most ECMS's up to DP's grid error and ECMS's at most 3 % above DP's (the bound;
/// ECMS, pricing each interval as DP does, lies 0.10 to 0.14 % below DP's default grids — docs/hybrids.md
/// gives the figures); the rule-based run, J1711-corrected, at least ECMS's
/// fuel; every figure between 2.5 and 5 l/100 km.
#[test]
fn series_hybrid_strategies_are_ordered_and_charge_sustaining() {
    // DP's spread over SOC grids of 101 to 401 points and split grids of 41 to 161 values on HWFET is 1.1·10⁻³
    // of the fuel (docs/hybrids.md): the tolerance of DP ≤ ECMS.
    let dp_grid_error = 2e-3;
    for cycle in ["udds", "hwfet", "wltc3b"] {
        let (ecms, _, _) = run(cycle, &["--strategy", "ecms"], &format!("ser-ecms-{cycle}"));
        let (dp, _, _) = run(cycle, &["--strategy", "dp"], &format!("ser-dp-{cycle}"));
        let (rb, _, _) = run(
            cycle,
            &["--strategy", "rule-based"],
            &format!("ser-rb-{cycle}"),
        );
        for (name, v) in [("ecms", &ecms), ("dp", &dp)] {
            assert!(
                hybrid_f64(v, "delta_soc").abs() <= 1e-4,
                "{cycle} {name}: ΔSOC {}",
                v["hybrid"]["delta_soc"]
            );
            assert!(v["hybrid"]["charge_sustaining"].as_bool().unwrap());
            assert!(v["input_bound_violations"].as_array().unwrap().is_empty());
        }
        let f_dp = hybrid_f64(&dp, "fuel_energy_corrected_j");
        let f_ecms = hybrid_f64(&ecms, "fuel_energy_corrected_j");
        let f_rb = hybrid_f64(&rb, "fuel_energy_corrected_j");
        assert!(
            f_dp <= f_ecms * (1.0 + dp_grid_error),
            "{cycle}: DP {f_dp} J above ECMS {f_ecms} J"
        );
        assert!(
            f_ecms <= 1.03 * f_dp,
            "{cycle}: ECMS {f_ecms} J vs DP {f_dp} J"
        );
        assert!(
            f_rb >= f_ecms,
            "{cycle}: rules {f_rb} J below ECMS {f_ecms} J"
        );
        assert_eq!(rb["hybrid"]["strategy"], "rule-based");
        assert!(hybrid_f64(&rb, "correction_slope_j") > 0.0);
        assert!(rb["input_bound_violations"].as_array().unwrap().is_empty());
        // The Note e-Power's certified figures: 2.69 l/100 km (JC08, 2016) and 3.52 l/100 km (Japan's WLTC
        // without the extra-high phase, 2020); the band is 2.5 to 5 l/100 km, room for the faster WLTC 3b.
        for (name, v) in [("ecms", &ecms), ("dp", &dp), ("rule-based", &rb)] {
            let l = l_per_100km(v);
            assert!((2.5..=5.0).contains(&l), "{cycle} {name}: {l} l/100 km");
        }
    }
}

/// DP on WLTC 3b (the generator's power from about 7 to 48 kW): at every sample with the genset on, its
/// speed, torque and fuel power are those of the best-efficiency point for the engine power P_g/η_g, found
/// here by a golden-section search and by the closed form; with the genset off its speed, torque, power and
/// fuel are 0. At every sample the speed equation η_t i_r T_m/r_w − F_b − F_res = m_eff y_d' and the battery's
/// chemical power U_oc I, I from P_term = P_el(T_m) + P_aux − P_g, hold; the summary's fuel integral is DP's.
#[test]
fn series_hybrid_genset_runs_on_its_best_efficiency_line() {
    let (v, header, rows) = run("wltc3b", &["--strategy", "dp"], "ser-line-wltc3b");
    let names: Vec<String> = v["modes"]["per_mode"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap().to_string())
        .collect();
    let c = |name: &str| col(&header, &rows, name);
    let (mode, y0, y1) = (c("mode"), c("yd_0"), c("yd_1"));
    let (t_m, p_g, f_b) = (c("T_m"), c("P_g"), c("F_b"));
    let (n_e, t_e, p_fuel, p_batt) = (c("n_e"), c("T_e"), c("P_fuel"), c("P_batt"));
    let m_eff = M + (J_W + ETA_T * I_R * I_R * J_M) / (R_W * R_W);
    let mut on = 0;
    let mut powers = Vec::new();
    for k in 0..rows.len() {
        let name = names[mode[k] as usize].as_str();
        if name == "genset" {
            on += 1;
            let p_e = p_g[k] / ETA_G;
            let w = best_speed_by_search(p_e);
            let scale = 1.0 + w;
            assert!(
                (n_e[k] * std::f64::consts::PI / 30.0 - w).abs() <= 1e-6 * scale,
                "t = {k}: n_e {} rpm vs {} rpm at {p_e} W",
                n_e[k],
                w * 30.0 / std::f64::consts::PI
            );
            assert!((best_speed_closed_form(p_e) - w).abs() <= 1e-6 * scale);
            assert!((t_e[k] - p_e / w).abs() <= 1e-6 * (1.0 + t_e[k].abs()));
            let fuel = fuel_power(p_e, w);
            assert!(
                (p_fuel[k] - fuel).abs() <= 1e-9 * fuel,
                "t = {k}: {} W vs {fuel} W",
                p_fuel[k]
            );
            powers.push(p_g[k]);
        } else {
            assert_eq!((n_e[k], t_e[k], p_fuel[k], p_g[k]), (0.0, 0.0, 0.0, 0.0));
        }
        let speed = y0[k];
        let f_res = 0.5 * CD_AF_RHO * speed * speed + M * G_0 * C_R * (speed / V_EPS).tanh();
        let accel = (ETA_T * I_R * t_m[k] / R_W - f_b[k] - f_res) / m_eff;
        assert!(
            (accel - y1[k]).abs() <= 1e-9 * (1.0 + y1[k].abs()),
            "t = {k} {name}: {accel} vs {}",
            y1[k]
        );
        let w_m = I_R * speed / R_W;
        let p_el = w_m * t_m[k] + K_C * t_m[k] * t_m[k] + K_I * w_m * w_m + P_0;
        let p_term = p_el + P_AUX - p_g[k];
        let current = (U_OC - (U_OC * U_OC - 4.0 * R_I * p_term).sqrt()) / (2.0 * R_I);
        assert!(
            (p_batt[k] - U_OC * current).abs() <= 1e-9 * (1.0 + p_term.abs()),
            "t = {k}: P_batt {} vs {}",
            p_batt[k],
            U_OC * current
        );
    }
    // The summary's integral of the fuel power (its outputs at each sample with that sample's decided power)
    // is DP's fuel, the trapezoid over each interval with the interval's power held.
    let integral = v["integrals"]["P_fuel"].as_f64().unwrap();
    let fuel = hybrid_f64(&v, "fuel_energy_j");
    assert!(
        (integral - fuel).abs() <= 1e-9 * fuel,
        "integral {integral} J vs DP's fuel {fuel} J"
    );
    // The run exercises both ends of the line: the 1200 rpm floor and well above it.
    assert!(on > 100, "genset on at {on} samples");
    let top = powers.iter().cloned().fold(0.0, f64::max);
    assert!(top > 30e3, "highest generator power {top} W");
    assert!(powers
        .iter()
        .any(|&p| best_speed_closed_form(p / ETA_G) == W_MIN));
}

/// NEDC repeats its urban segment four times, so a choice that ties at one s ties at the same s in every
/// repeat: ΔSOC(s) jumps by several samples' flips at once, which sharing one sample cannot bridge (the search
/// stopped with exit 2: ΔSOC from −1.8·10⁻³ to +5.2·10⁻³ at s = 3.009). Every differing mode shared with one θ
/// bridges it: charge-sustaining within 10⁻⁴, with and without a gradient (whose search narrows further).
#[test]
fn series_hybrid_bridges_the_nedc_repeated_flips() {
    for (args, tag) in [
        (&["--strategy", "ecms"][..], "ser-nedc"),
        (
            &["--strategy", "ecms", "--gradient", "m"][..],
            "ser-nedc-grad",
        ),
    ] {
        let (v, _, _) = run("nedc", args, tag);
        let h = &v["hybrid"];
        let dsoc = h["delta_soc"].as_f64().unwrap();
        assert!(dsoc.abs() <= 1e-4, "{tag}: ΔSOC {dsoc}");
        assert_eq!(h["charge_sustaining"].as_bool(), Some(true), "{tag}");
        let fuel = h["fuel_energy_corrected_j"].as_f64().unwrap();
        assert!((10.5e6..11.5e6).contains(&fuel), "{tag}: {fuel} J");
    }
}
