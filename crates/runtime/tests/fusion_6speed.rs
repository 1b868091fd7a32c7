//! `models/ford_fusion_2012_dynamic_6speed.toml` (FASTSim's Fusion with si_engine's intake-manifold dynamics,
//! its 6-speed automatic, idle, fuel cut-off and the friction brake): on the UDDS, HWFET and WLTC class 3b
//! every mode satisfies its own equations at every sample (v' = y_d' and, with r = 2, v'' = ∂f_v/∂x · f by
//! the chain rule, the built-in cycles flat: the grade and its derivatives 0), the replay through the mode
//! sequence tracks and every gear is used; the engine's calibration (eta_th, xi_aux) is the least-squares fit
//! to FASTSim's efficiency curve at the run's own operating points, and the fuel is the imported quasi-static
//! Fusion's within 2 % on UDDS (docs/vehicles.md, section 4, explains HWFET and WLTC 3b).

use invsim_inversion::{Derivation, Interpreter, Model};
use invsim_model_api::InverseModel;
use invsim_runtime::modes::{simulate_modes, ModalOptions, Switching};
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::path::Path;

use crate::modes::support::{load_repo, partial, spec, speed_schedule, Loaded};

const MODEL: &str = "models/ford_fusion_2012_dynamic_6speed.toml";

fn fusion() -> Loaded {
    load_repo(MODEL)
}

fn repo(rel: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
}

/// The value of parameter `name` as the model file states it (`name = { value = …, … }`).
fn param(text: &str, name: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.split('=').next().map(str::trim) == Some(name))
        .unwrap_or_else(|| panic!("no parameter {name}"));
    let rest = &line[line.find("value =").expect("a value") + 7..];
    rest[..rest.find(',').expect("a comma")]
        .trim()
        .parse()
        .expect("a number")
}

/// The imported quasi-static Fusion (`models/vehicles/ford_fusion_2012.toml`, interpreted) on `cycle` at the
/// same look-ahead (5 s) and step (0.1 s): its fuel, kg.
fn imported_fuel(cycle: &Cycle) -> f64 {
    let path = repo("models/vehicles/ford_fusion_2012.toml");
    let d = Derivation::new(Model::from_path(&path).expect("model")).expect("derivation");
    let m = Interpreter::new(&d).expect("interpreter");
    let opts = SimulationOptions::builder()
        .lookahead(5.0)
        .dt(0.1)
        .build()
        .expect("options");
    simulate(&m, cycle, &opts)
        .expect("the run succeeds")
        .summary
        .totals
        .integrals["fuel"]
}

/// The mean-value engine, quasi-static (dp_i/dt = 0), as a Willans line in the fitted parameters. With the
/// fuel mean effective pressure F = m_fc e_f/V_d, the air charge m_ac = (s_i p_i − y_i) V_d/(R_a T_i) =
/// λ AFs m_fc gives p_i = (k F + y_i)/s_i with k = λ AFs R_a T_i/e_f, and the model's
/// BMEP (1 + 0.0215 ξ k_B) = η_th F − (p_e − p_i) − FMEP_0 (Soltic, FMEP_0 = ξ k_B Π_bl (0.464 +
/// 0.0072 S_p^1.8) bar) solves to F (η_th + k/s_i) = BMEP + p_e − y_i/s_i + ξ k_B (0.0215 BMEP + FMEP_0/ξ).
/// Times q = V_d ω/(4π) this is the fuel power P_fuel = (u0 + ξ u1)/(η_th + k/s_i) with u0 = P + (p_e −
/// y_i/s_i) q and u1 = k_B (0.0215 P + q Π_bl (0.464 + 0.0072 S_p^1.8) 1e5) at brake power P, speed ω.
struct Engine {
    v_d: f64,
    bore: f64,
    stroke: f64,
    p_e: f64,
    s_i: f64,
    y_i: f64,
    s_eps: f64,
    pi_bl: f64,
    k: f64,
}

impl Engine {
    fn read(text: &str) -> Self {
        let p = |n| param(text, n);
        Engine {
            v_d: p("V_d"),
            bore: p("B"),
            stroke: p("S"),
            p_e: p("p_e"),
            s_i: p("s_i"),
            y_i: p("y_i"),
            s_eps: p("S_eps"),
            pi_bl: p("Pi_bl"),
            k: p("lambda") * p("AFs") * p("R_a") * p("T_i") / p("e_f"),
        }
    }

    /// (u0, u1) at speed `w` (rad/s) and brake power `p` (W).
    fn regressors(&self, w: f64, p: f64) -> (f64, f64) {
        let q = self.v_d * w / (4.0 * std::f64::consts::PI);
        let s_p = self.stroke * w / std::f64::consts::PI;
        let f0 = 0.464
            + 0.0072 * ((s_p * s_p + self.s_eps * self.s_eps).powf(0.9) - self.s_eps.powf(1.8));
        let k_b = (0.075 / self.bore).sqrt();
        (
            p + (self.p_e - self.y_i / self.s_i) * q,
            k_b * (0.0215 * p + q * self.pi_bl * f0 * 1e5),
        )
    }

    /// Quasi-static fuel power (W) at `w`, `p` with the calibration `eta_th`, `xi_aux`.
    fn fuel_power(&self, w: f64, p: f64, eta_th: f64, xi_aux: f64) -> f64 {
        let (u0, u1) = self.regressors(w, p);
        (u0 + xi_aux * u1) / (eta_th + self.k / self.s_i)
    }
}

/// The 2×2 linear least squares min Σ_c (α a_c + β b_c − 1)² over the cycles' rows (a_c, b_c).
fn lsq2(rows: &[(f64, f64)]) -> (f64, f64) {
    let (mut aa, mut ab, mut bb, mut a1, mut b1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (a, b) in rows {
        aa += a * a;
        ab += a * b;
        bb += b * b;
        a1 += a;
        b1 += b;
    }
    let det = aa * bb - ab * ab;
    ((a1 * bb - ab * b1) / det, (aa * b1 - ab * a1) / det)
}

#[test]
fn fusion_6speed_satisfies_every_mode_tracks_and_burns_plausible_fuel() {
    let l = fusion();
    let s = spec(&l, speed_schedule(&l));
    let text = std::fs::read_to_string(repo(MODEL)).expect("the model file");
    let engine = Engine::read(&text);
    let (eta_th, xi_aux) = (param(&text, "eta_th"), param(&text, "xi_aux"));
    let e_f = param(&text, "e_f");
    let mut rows = Vec::new();
    let (mut sq, mut sq_ref) = (0.0, 0.0);
    // FASTSim's fuel for the same vehicle (docs/vehicles.md, section 3), kg.
    for (name, fastsim) in [("udds", 0.609), ("hwfet", 0.613), ("wltc3b", 1.156)] {
        let cycle = Cycle::builtin(name).expect("built-in");
        let opts = ModalOptions {
            lookahead: 5.0,
            dt: 0.1,
            switching: Switching::Reentry,
            transition_time: None,
            verify: true,
            keep_series: true,
            operating_points: true,
        };
        let res = simulate_modes(&s, &cycle, &opts).expect("the run succeeds");
        let (mut worst1, mut worst2) = (0.0f64, 0.0f64);
        for k in 0..res.free.len() {
            let model = &l.interps[res.mode[k]];
            let w = vec![0.0; model.info().n_w()];
            let (x, u, y) = (&res.states[k], res.free[k], &res.yref[k]);
            let mut dx = [0.0; 2];
            model.rhs(x, &w, u, &mut dx);
            worst1 = worst1.max((dx[0] - y[1]).abs() / y[1].abs().max(1.0));
            if model.info().relative_degree == 2 {
                let fv = |z: &[f64]| {
                    let mut d = [0.0; 2];
                    model.rhs(z, &w, u, &mut d);
                    d[0]
                };
                let ydd = partial(&fv, x, 0) * dx[0] + partial(&fv, x, 1) * dx[1];
                worst2 = worst2.max((ydd - y[2]).abs() / y[2].abs().max(1.0));
            }
        }
        assert!(worst1 < 1e-8, "{name}: v' − y_d' up to {worst1:e} relative");
        assert!(
            worst2 < 1e-8,
            "{name}: v'' − y_d'' up to {worst2:e} relative"
        );
        let err = res.summary.max_abs_tracking_error.expect("verified");
        assert!(
            err < 1e-3 * cycle.max_speed(),
            "{name}: replay error {err} m/s"
        );
        let total: f64 = res.summary.modes.per_mode.iter().map(|m| m.time_s).sum();
        assert!((total - cycle.duration()).abs() < 1e-9);
        let gears = res.column("gear").expect("gear");
        let top = gears.iter().fold(0.0f64, |a, g| a.max(*g));
        assert!(name == "udds" || top == 6.0, "{name}: top gear {top}");

        // The operating points where the engine burns fuel and delivers power (drive and idle): the engine
        // speed, its brake power, the fuel it burns and the fuel FASTSim's curve gives for that power.
        let col = |c: &str| res.column(c).unwrap_or_else(|| panic!("column {c}"));
        let (n_e, p_e, fuel_k, map_k) =
            (col("n_e"), col("P_e"), col("fuel"), col("fuel_fastsim_map"));
        let (mut u0, mut u1, mut curve, mut burnt, mut qs) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for k in 0..n_e.len() {
            if fuel_k[k] > 0.0 && p_e[k] > 0.0 {
                let w = n_e[k] * std::f64::consts::PI / 30.0;
                let (a, b) = engine.regressors(w, p_e[k]);
                let model_fuel = engine.fuel_power(w, p_e[k], eta_th, xi_aux);
                (u0, u1) = (u0 + a, u1 + b);
                curve += map_k[k] * e_f;
                burnt += fuel_k[k] * e_f;
                qs += model_fuel;
                sq += (model_fuel - map_k[k] * e_f).powi(2);
                sq_ref += (map_k[k] * e_f).powi(2);
            }
        }
        rows.push((u0 / curve, u1 / curve));
        // What the manifold dynamics change: the run's fuel (the throttle air flow, the manifold filling
        // and emptying) against the quasi-static engine at the same points, within 0.05 %.
        assert!(
            (burnt / qs - 1.0).abs() < 5e-4,
            "{name}: dynamic {burnt} against quasi-static {qs} (fuel power sums, W)"
        );
        // The fit's residual on the cycle: this engine's fuel at its operating points against FASTSim's curve.
        assert!(
            (qs / curve - 1.0).abs() < 0.006,
            "{name}: engine {qs} against FASTSim's curve {curve} (fuel power sums, W)"
        );

        let fuel = res.summary.totals.integrals["fuel"];
        let map = res.summary.totals.integrals["fuel_fastsim_map"];
        let imported = imported_fuel(&cycle);
        eprintln!(
            "{name}: fuel {fuel:.4} kg, imported quasi-static {imported:.4} kg ({:+.2} %), \
             FASTSim's curve on this engine {map:.4} kg, FASTSim {fastsim} kg",
            100.0 * (fuel / imported - 1.0)
        );
        // Against the imported quasi-static Fusion on the same cycle, look-ahead and step (docs/vehicles.md):
        // within 2 % on UDDS; on HWFET the coupling's slip in the high gears (w_e = sqrt(w_idle² + w_g²),
        // 12 % at 1500 rpm) and on WLTC 3b with it the fuel burnt at negative brake power (which FASTSim's
        // curve books as none) remain: +7.1 % and +2.6 % measured.
        let ratio = fuel / imported;
        let band = match name {
            "udds" => 0.98..1.02,
            "hwfet" => 1.06..1.08,
            _ => 1.015..1.035,
        };
        assert!(
            band.contains(&ratio),
            "{name}: {fuel} kg vs the imported model's {imported} kg"
        );
        // FASTSim's curve applied to this engine's brake power is FASTSim's figure within 10 % (the
        // drivetrain, road load, idle and braking).
        assert!(
            (map / fastsim - 1.0).abs() < 0.1,
            "{name}: map {map} kg vs FASTSim {fastsim} kg"
        );
    }
    // The calibration: least squares of the relative cycle-fuel error over the three cycles, α = 1/(η_th +
    // k/s_i), β = ξ α, solved in closed form; the stored values are the fit at their own operating points.
    let (alpha, beta) = lsq2(&rows);
    let (eta_fit, xi_fit) = (1.0 / alpha - engine.k / engine.s_i, beta / alpha);
    eprintln!("fit: eta_th {eta_fit:.4}, xi_aux {xi_fit:.4}");
    assert!(
        (eta_fit - eta_th).abs() < 1e-3 && (xi_fit - xi_aux).abs() < 5e-3,
        "stored eta_th {eta_th}, xi_aux {xi_aux}; the fit gives {eta_fit}, {xi_fit}"
    );
    // The fuel-power residual sample by sample, relative (FASTSim's curve depends on the power fraction
    // only, the engine on speed as well): 6.7 % root mean square.
    let rms = (sq / sq_ref).sqrt();
    assert!((0.06..0.075).contains(&rms), "rms residual {rms}");
}
