//! A strategy's run with exogenous signals (docs/hybrids.md, "Signals"): `tests/models/hybrid/p2_grade.toml`
//! is hev_p2 with the road grade and the auxiliary load as `[signals]`, its twin `p2_grade_param.toml` the same
//! file with both as parameters. Constant signals give the twin's run with those parameters (ECMS, DP, the
//! rules); time-varying ones give runs whose every sample, interval end and charge step solve the model's
//! equations written out here by hand, the signals at the time evaluated (t_k, the Runge–Kutta midpoint,
//! t_k+1); uphill costs more fuel than flat; an unknown `--signal` exits 2 naming it; an imported FASTSim
//! hybrid reads the grade from the cycle's column.

use crate::common::{column as col, invsim, simulate_summary, simulate_with, stderr, tmp};
use invsim_runtime::signals::{smoothers, ResolvedSignal};
use invsim_runtime::smoother::Smoother;
use invsim_runtime::Cycle;

const SIGNALS: &str = "tests/models/hybrid/p2_grade.toml";
const TWIN: &str = "tests/models/hybrid/p2_grade_param.toml";

/// The model's parameters (hev_p2's), the gearbox's ratios and the look-ahead of the runs.
const M: f64 = 1500.0;
const GEARS: [f64; 6] = [3.64, 2.09, 1.38, 0.98, 0.76, 0.62];
const LOOKAHEAD: f64 = 5.0;

/// `simulate MODEL --cycle ece --dt 1 --strategy …` with `extra`: the summary, the CSV header and rows.
fn run(
    model: &str,
    extra: &[&str],
    tag: &str,
) -> (serde_json::Value, Vec<String>, Vec<Vec<String>>) {
    let mut args = vec![model, "--cycle", "ece", "--dt", "1"];
    args.extend_from_slice(extra);
    simulate_with(&args, tag)
}

/// The signal model is its twin with `[signals]` grade and P_aux in place of the parameters of those names
/// (defaults the parameters' values, same units): the comparisons below compare the signals' handling only.
#[test]
fn the_signal_model_is_its_twin_with_two_parameters_as_signals() {
    let read = |p: &str| -> toml::Table {
        let text = std::fs::read_to_string(crate::common::root().join(p)).unwrap();
        text.parse().unwrap()
    };
    let (mut a, mut b) = (read(SIGNALS), read(TWIN));
    let signals = a.remove("signals").unwrap();
    let params = b["parameters"].as_table_mut().unwrap();
    let mut names = Vec::new();
    for (name, s) in signals.as_table().unwrap() {
        let p = params.remove(name).unwrap();
        assert_eq!(s["default"], p["value"], "{name}");
        assert_eq!(s["unit"], p["unit"], "{name}");
        names.push(name.as_str());
    }
    assert_eq!(names, ["P_aux", "grade"], "by name");
    assert_eq!(a, b);
}

/// Constant signals (`--signal grade=0.02 --signal P_aux=800`) give the twin's run with `--set grade=0.02
/// --set P_aux=800` under ECMS at a given s, DP and the rules: fuel, ΔSOC, battery energy and the corrected
/// fuel within 10⁻¹² (the smoothed constant is the constant to rounding, its derivative 0 to rounding).
#[test]
fn constant_signals_give_the_twin_s_run_with_those_parameters() {
    for strategy in [
        &["ecms", "--equivalence", "3.4"][..],
        &["dp"],
        &["rule-based"],
    ] {
        let mut extra = vec!["--strategy"];
        extra.extend_from_slice(strategy);
        let given = |how: &str, tag: &str| {
            let mut args = vec![if how == "--signal" { SIGNALS } else { TWIN }];
            args.extend_from_slice(&extra);
            args.extend([how, "grade=0.02", how, "P_aux=800"]);
            args.extend(["--cycle", "ece", "--dt", "1"]);
            simulate_summary(&args, &format!("{tag}-{}", strategy[0])).0
        };
        let (s, p) = (
            given("--signal", "const-signal"),
            given("--set", "const-param"),
        );
        let (hs, hp) = (&s["hybrid"], &p["hybrid"]);
        for key in [
            "fuel_energy_j",
            "delta_soc",
            "battery_energy_j",
            "fuel_energy_corrected_j",
        ] {
            let (x, y) = (hs[key].as_f64().unwrap(), hp[key].as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
                "{strategy:?} {key}: {x} vs {y}"
            );
        }
        assert!(hs["fuel_energy_j"].as_f64().unwrap() > 0.0, "{strategy:?}");
        assert_eq!(s["signals"][0]["source"], "command line (constant)");
        assert_eq!(hs["engine_starts"], hp["engine_starts"], "{strategy:?}");
    }
}

/// The grade and the auxiliary load of the time-varying runs, sampled every 5 s over the ECE-15's 195 s: an
/// uphill grade of 0 … 4 % (mean 2 %) and a load of 200 … 1000 W.
fn time_varying() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let t: Vec<f64> = (0..=40).map(|i| 5.0 * i as f64).collect();
    let tau = std::f64::consts::TAU;
    let grade = t
        .iter()
        .map(|t| 0.02 + 0.02 * (tau * t / 60.0).sin())
        .collect();
    let load = t
        .iter()
        .map(|t| 600.0 + 400.0 * (tau * t / 45.0).cos())
        .collect();
    (t, grade, load)
}

/// The signal file of [`time_varying`] (`t,grade,P_aux`), written once per test process.
fn signal_file() -> String {
    let path = tmp("p2-grade-signals.csv");
    let (t, grade, load) = time_varying();
    let mut text = String::from("t,grade,P_aux\n");
    for k in 0..t.len() {
        text.push_str(&format!("{:?},{:?},{:?}\n", t[k], grade[k], load[k]));
    }
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// hev_p2's mode families (its CSV's `mode` indices named by the summary).
#[derive(Clone, Copy, PartialEq, Debug)]
enum Family {
    Hybrid,
    Electric,
    Brake,
    Stop,
}

/// One instant of a run: the reference's speed v and acceleration a, the grade and the auxiliary load.
#[derive(Clone, Copy)]
struct Instant {
    v: f64,
    a: f64,
    grade: f64,
    load: f64,
}

/// hev_p2's equations by hand: (T_e, T_m, F_b) from m_eff v' = F_w − F_b − F_res with the family's inputs,
/// F_w = η_t i_g i_f (c_on T_e + T_m)/r_w, F_res = ½ ρ C_d A_f v² + m g (c_r tanh(v/v_ε) + grade)/√(1 + grade²),
/// m_eff = m + (J_w + η_t (i_g i_f)² (J_m + c_on J_e))/r_w².
fn inputs(f: Family, ig: f64, at: Instant, d: f64) -> (f64, f64, f64) {
    let (cd, af, cr, rho, g0, v_eps) = (0.29, 2.2, 0.009, 1.2, 9.81, 0.1);
    let (r_w, j_w, i_f, eta_t, j_e, j_m) = (0.31, 2.4, 3.7, 0.95, 0.15, 0.03);
    let on = if f == Family::Hybrid { 1.0 } else { 0.0 };
    let m_eff = M + (j_w + eta_t * (ig * i_f).powi(2) * (j_m + on * j_e)) / (r_w * r_w);
    let f_res = 0.5 * rho * cd * af * at.v * at.v
        + M * g0 * (cr * (at.v / v_eps).tanh() + at.grade) / (1.0 + at.grade * at.grade).sqrt();
    let need = m_eff * at.a + f_res;
    let torque = need * r_w / (eta_t * ig * i_f);
    let force = |t_m: f64| eta_t * ig * i_f * t_m / r_w;
    match f {
        Family::Hybrid => (torque - d, d, 0.0),
        Family::Electric => (0.0, torque, 0.0),
        Family::Brake => (0.0, d, force(d) - need),
        Family::Stop => (0.0, 0.0, -need),
    }
}

/// The fuel and battery chemical powers and soc' of hev_p2 at `at` with inputs (T_e, T_m):
/// P_fuel = c_on max(w_in, w_idle)(T_e + V_d p_me0/(4π) + k_fl T_e²)/e_w, w_in = i_g i_f v/r_w,
/// P_el = w_in T_m + k_c T_m² + k_i w_in² + P_0, I_b = (U_oc − √(U_oc² − 4 R_i (P_el + P_aux)))/(2 R_i),
/// P_batt = U_oc I_b, soc' = −I_b/Q.
fn powers(f: Family, ig: f64, at: Instant, (t_e, t_m): (f64, f64)) -> (f64, f64, f64) {
    let (r_w, i_f, v_d, e_w, p_me0, k_fl, w_idle) =
        (0.31, 3.7, 1.798e-3, 0.38, 1.3e5, 1.2e-3, 104.7);
    let (k_c, k_i, p_0, u_oc, r_i, q) = (0.02, 1.5e-3, 150.0, 270.0, 0.25, 17333.0);
    let w_in = ig * i_f * at.v / r_w;
    let on = if f == Family::Hybrid { 1.0 } else { 0.0 };
    let pi = std::f64::consts::PI;
    let p_fuel = on * w_in.max(w_idle) * (t_e + v_d * p_me0 / (4.0 * pi) + k_fl * t_e * t_e) / e_w;
    let p_el = w_in * t_m + k_c * t_m * t_m + k_i * w_in * w_in + p_0;
    let i_b = (u_oc - (u_oc * u_oc - 4.0 * r_i * (p_el + at.load)).sqrt()) / (2.0 * r_i);
    (p_fuel, u_oc * i_b, -i_b / q)
}

/// The family of each mode of a run, by the names in its summary.
fn families(v: &serde_json::Value) -> Vec<Family> {
    let modes = v["modes"]["per_mode"].as_array().unwrap();
    let family = |m: &serde_json::Value| match m["name"].as_str().unwrap() {
        n if n.starts_with("hybrid") => Family::Hybrid,
        n if n.starts_with("electric") => Family::Electric,
        n if n.starts_with("brake") => Family::Brake,
        _ => Family::Stop,
    };
    modes.iter().map(family).collect()
}

/// ECMS at s = 3.4 on the ECE-15 with the time-varying grade and load of [`time_varying`]: at every sample the
/// chosen mode's vehicle equation holds with the grade at t_k (the CSV's smoothed `grade`); each interval's
/// end, d held, solved by hand with the signals at t_k+1, prices the run's fuel and battery energies (their
/// trapezoids); and the charge follows each interval's Runge–Kutta step, here Simpson's rule since soc' does
/// not depend on soc, with the reference and the load at t_k, the midpoint and t_k+1 (the smoothers evaluated
/// here as the run evaluates them).
#[test]
fn time_varying_signals_solve_every_mode_s_equations_at_the_times_evaluated() {
    let file = signal_file();
    let (g, p) = (format!("grade={file}"), format!("P_aux={file}"));
    let strategy = ["--strategy", "ecms", "--equivalence", "3.4"];
    let mut extra = strategy.to_vec();
    extra.extend(["--signal", &g, "--signal", &p]);
    let (v, header, rows) = run(SIGNALS, &extra, "varying");
    assert_eq!(v["signals"][0]["source"], format!("command line ({file})"));
    let family = families(&v);
    let c = |name: &str| col(&header, &rows, name);
    let (mode, gear, t) = (c("mode"), c("gear"), c("t"));
    let (y0, y1, grade, load) = (c("yd_0"), c("yd_1"), c("grade"), c("P_aux"));
    let (t_e, t_m, f_b, soc) = (c("T_e"), c("T_m"), c("F_b"), c("soc"));
    let (p_fuel, p_batt) = (c("P_fuel"), c("P_batt"));
    let at = |k: usize| Instant {
        v: y0[k],
        a: y1[k],
        grade: grade[k],
        load: load[k],
    };
    // The smoothed reference and signals at the intervals' midpoints.
    let cycle = Cycle::builtin("ece").unwrap();
    let reference = Smoother::new(&cycle, LOOKAHEAD).unwrap();
    let (ts, gs, ls) = time_varying();
    let raw = |name: &str, values: Vec<f64>| ResolvedSignal {
        name: name.into(),
        source: String::new(),
        time: ts.clone(),
        values,
    };
    let smoothed = smoothers(&[raw("grade", gs), raw("P_aux", ls)], LOOKAHEAD);
    let mid = |tm: f64| {
        let (mut y, mut gr, mut l) = ([0.0; 2], [0.0; 2], [0.0; 2]);
        reference.eval(tm, &mut y);
        smoothed[0].eval(tm, &mut gr);
        smoothed[1].eval(tm, &mut l);
        Instant {
            v: y[0],
            a: y[1],
            grade: gr[0],
            load: l[0],
        }
    };
    let (mut fuel, mut battery) = (0.0, 0.0);
    let n = rows.len();
    for k in 0..n {
        let f = family[mode[k] as usize];
        let ig = if gear[k] >= 1.0 {
            GEARS[gear[k] as usize - 1]
        } else {
            GEARS[0]
        };
        // The sample: the run's inputs are the equation's at t_k's grade.
        let (e, m, b) = inputs(f, ig, at(k), t_m[k]);
        let scale = 1.0 + e.abs() + m.abs() + b.abs();
        let off = [t_e[k] - e, t_m[k] - m, f_b[k] - b];
        assert!(
            off.iter().all(|x| x.abs() <= 1e-9 * scale),
            "t = {}: {f:?} ({}, {}, {}) vs ({e}, {m}, {b})",
            t[k],
            t_e[k],
            t_m[k],
            f_b[k]
        );
        let (pf0, pb0, q0) = powers(f, ig, at(k), (t_e[k], t_m[k]));
        assert!((pf0 - p_fuel[k]).abs() <= 1e-9 * (1.0 + pf0.abs()));
        assert!((pb0 - p_batt[k]).abs() <= 1e-9 * (1.0 + pb0.abs()));
        if k + 1 == n {
            break;
        }
        // The interval's end and midpoint in the same mode with d = T_m(t_k) held.
        let h = t[k + 1] - t[k];
        let end = at(k + 1);
        let (e1, m1, _) = inputs(f, ig, end, t_m[k]);
        let (pf1, pb1, q1) = powers(f, ig, end, (e1, m1));
        let middle = mid(0.5 * (t[k] + t[k + 1]));
        let (em, mm, _) = inputs(f, ig, middle, t_m[k]);
        let (_, _, qm) = powers(f, ig, middle, (em, mm));
        fuel += 0.5 * h * (pf0 + pf1);
        battery += 0.5 * h * (pb0 + pb1);
        let step = h / 6.0 * (q0 + 4.0 * qm + q1);
        assert!(
            (soc[k + 1] - soc[k] - step).abs() <= 1e-12,
            "t = {}: Δsoc {} vs {step}",
            t[k],
            soc[k + 1] - soc[k]
        );
    }
    let h = &v["hybrid"];
    let (f_run, b_run) = (
        h["fuel_energy_j"].as_f64().unwrap(),
        h["battery_energy_j"].as_f64().unwrap(),
    );
    assert!(f_run > 1e5, "the engine runs: {f_run} J");
    assert!((fuel - f_run).abs() <= 1e-9 * f_run, "{fuel} vs {f_run}");
    assert!(
        (battery - b_run).abs() <= 1e-9 * (f_run + b_run.abs()),
        "{battery} vs {b_run}"
    );
}

/// Uphill (the grade of [`time_varying`], 0 … 4 %) costs more fuel than flat (`--signal grade=0`), the same
/// load, at the same s: the J1711-corrected fuel rises by more than the climbing work m g ∫ sin θ v dt itself
/// (the engine converts fuel to work at well under 100 %).
#[test]
fn uphill_costs_more_fuel_than_flat() {
    let file = signal_file();
    let p = format!("P_aux={file}");
    let g = format!("grade={file}");
    let corrected = |grade: &str, tag: &str| {
        let extra = [
            "--strategy",
            "ecms",
            "--equivalence",
            "3.4",
            "--signal",
            grade,
            "--signal",
            &p,
        ];
        let (v, header, rows) = run(SIGNALS, &extra, tag);
        let (t, y0, gr) = (
            col(&header, &rows, "t"),
            col(&header, &rows, "yd_0"),
            col(&header, &rows, "grade"),
        );
        // m g ∫ sin θ v dt by trapezoids, sin θ = grade/√(1 + grade²).
        let rise = |k: usize| M * 9.81 * gr[k] / (1.0 + gr[k] * gr[k]).sqrt() * y0[k];
        let work: f64 = (1..t.len())
            .map(|k| 0.5 * (t[k] - t[k - 1]) * (rise(k - 1) + rise(k)))
            .sum();
        (
            v["hybrid"]["fuel_energy_corrected_j"].as_f64().unwrap(),
            work,
        )
    };
    let (uphill, work) = corrected(&g, "uphill");
    let (flat, none) = corrected("grade=0", "flat");
    assert_eq!(none, 0.0);
    assert!(work > 1e5, "climbing work {work} J");
    assert!(
        uphill - flat > work,
        "uphill {uphill} J, flat {flat} J, climbing work {work} J"
    );
}

/// An unknown `--signal` name in a strategy's run exits 2 naming it and the signals the model declares, as a
/// run without a strategy does; so does a decided input given as a signal, and any signal for hev_p2, which
/// declares none.
#[test]
fn an_unknown_signal_in_a_strategy_run_exits_2_naming_it() {
    let cases = [
        (
            SIGNALS,
            "slope=0.1",
            "unknown signal `slope`",
            "grade, P_aux",
        ),
        (SIGNALS, "T_m=5", "unknown signal `T_m`", "grade, P_aux"),
        (
            "models/hev_p2.toml",
            "grade=0.02",
            "unknown signal `grade`",
            "no signals",
        ),
    ];
    for (model, given, says, known) in cases {
        for strategy in ["ecms", "dp", "rule-based"] {
            let o = invsim(&[
                "simulate",
                model,
                "--cycle",
                "ece",
                "--strategy",
                strategy,
                "--signal",
                given,
            ]);
            assert_eq!(o.status.code(), Some(2), "{model} {given} {strategy}");
            let e = stderr(&o);
            assert!(e.contains(says) && e.contains(known), "{e}");
            assert!(!e.contains("panicked"), "{e}");
        }
    }
}

/// An imported FASTSim hybrid (`models/vehicles/toyota_prius_2016.toml`) has the road grade as the signal
/// `grade`, as the conventional and electric imports do: under its own rules a cycle file's grade column of
/// 2 % gives the run of `--signal grade=0.02` on the same trace (the same figures), and more fuel than the
/// flat road.
#[test]
fn an_imported_hybrid_reads_the_cycle_s_grade_column() {
    let model = "models/vehicles/toyota_prius_2016.toml";
    let ece = Cycle::builtin("ece").unwrap();
    let path = tmp("ece-graded.csv");
    let mut text = String::from("time_s,speed_mps,grade\n");
    for (t, v) in ece.time.iter().zip(&ece.speed) {
        text.push_str(&format!("{t:?},{v:?},0.02\n"));
    }
    std::fs::write(&path, text).unwrap();
    let fuel = |cycle: &str, extra: &[&str], tag: &str| {
        let mut args = vec![
            model,
            "--cycle",
            cycle,
            "--dt",
            "1",
            "--strategy",
            "rule-based",
        ];
        args.extend_from_slice(extra);
        let (v, _) = simulate_summary(&args, tag);
        let source = v["signals"][0]["source"].as_str().unwrap().to_string();
        (v["hybrid"]["fuel_energy_j"].as_f64().unwrap(), source)
    };
    let (column, from_column) = fuel(path.to_str().unwrap(), &[], "prius-column");
    let (given, from_line) = fuel("ece", &["--signal", "grade=0.02"], "prius-given");
    let (flat, _) = fuel("ece", &[], "prius-flat");
    assert_eq!(from_column, "cycle column grade");
    assert_eq!(from_line, "command line (constant)");
    assert!(
        (column - given).abs() <= 1e-12 * given,
        "{column} vs {given}"
    );
    assert!(column > 1.1 * flat, "uphill {column} J, flat {flat} J");
}
