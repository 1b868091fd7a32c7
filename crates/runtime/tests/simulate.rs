//! Tests of the inverse-simulation driver against hand-written models with known answers.

use crate::common;
use common::{LinearR2, NanOutput, SiEngine, FUEL_DENSITY};
use invsim_model_api::{InverseModel, ModelError, ModelInfo};
use invsim_runtime::output::write_csv;
use invsim_runtime::plot::plot_svg;
use invsim_runtime::{
    simulate, Cycle, RunError, SimulateError, SimulationOptions, SimulationResult, Smoother,
    StableError,
};

fn nedc() -> Cycle {
    Cycle::builtin("nedc").expect("built-in NEDC")
}

fn constant_speed(kmh: f64, duration: f64) -> Cycle {
    Cycle {
        tolerance: invsim_runtime::cycle::Tolerance::EPA,
        name: format!("constant {kmh} km/h"),
        time: vec![0.0, duration],
        speed: vec![kmh / 3.6; 2],
        grade: None,
        columns: Vec::new(),
    }
}

fn opts(dt: f64) -> SimulationOptions {
    SimulationOptions {
        dt,
        ..SimulationOptions::default()
    }
}

fn col<'a>(res: &'a SimulationResult, name: &str) -> &'a [f64] {
    res.column(name)
        .unwrap_or_else(|| panic!("column {name} in {:?}", res.columns))
}

/// Steady state (dv/dt = dp_i/dt = 0) reproduces the check values of `si_engine.md`.
#[test]
fn si_engine_steady_state_check_values() {
    let model = SiEngine::new();
    // speed km/h, p_i Pa, ṁ_at g/s; tolerances are half a unit in the last digit given.
    let table = [
        (15.0, 25_498.0, 2.115, 5e-4),
        (50.0, 29_315.0, 8.619, 5e-4),
        (70.0, 33_141.0, 14.27, 5e-3),
        (120.0, 47_713.0, 38.82, 5e-3),
    ];
    for (kmh, p_i, m_at_gps, tol) in table {
        let res = simulate(&model, &constant_speed(kmh, 100.0), &opts(0.1)).unwrap();
        assert_eq!(res.summary.samples, 1001);
        for (k, (&p, &u)) in col(&res, "p_i").iter().zip(col(&res, "m_at")).enumerate() {
            assert!(
                (p - p_i).abs() <= 0.5,
                "{kmh} km/h, sample {k}: p_i = {p}, expected {p_i}"
            );
            assert!(
                (u * 1e3 - m_at_gps).abs() <= tol,
                "{kmh} km/h, sample {k}: m_at = {} g/s",
                u * 1e3
            );
        }
        assert!(res.summary.totals.input_bound_violations.is_empty());
    }
    // 5.67 l/100 km at 50 km/h, from the accumulated fuel volume over the distance.
    let res = simulate(&model, &constant_speed(50.0, 100.0), &opts(0.1)).unwrap();
    let l_per_100km = res.summary.totals.integrals_per_100km["fuel_l"];
    assert!((l_per_100km - 5.67).abs() < 0.005, "{l_per_100km} l/100 km");
    let fuel_kg = res.summary.totals.integrals["fuel"];
    assert!(
        (fuel_kg / FUEL_DENSITY * 1000.0 - res.summary.totals.integrals["fuel_l"]).abs() < 1e-12
    );
    assert!((res.summary.run.distance_m - 50.0 / 3.6 * 100.0).abs() < 1e-9);
}

/// At every NEDC sample the inverse satisfies the original model dx/dt = f(x) + g(x)u, with dx/dt from the chain
/// rule ∂ψ⁻¹/∂ξ · dξ/dt and the smoother's exact derivatives.
#[test]
fn si_engine_inverse_satisfies_original_equations_on_nedc() {
    let model = SiEngine::new();
    let res = simulate(&model, &nedc(), &opts(0.01)).unwrap();
    let [c1, c2, c3, c4, c5, c6, c7] = model.c;
    let (yd0, yd1, yd2) = (col(&res, "yd_0"), col(&res, "yd_1"), col(&res, "yd_2"));
    let (v, p_i, u) = (col(&res, "v"), col(&res, "p_i"), col(&res, "m_at"));
    let mut dx = [0.0; 2];
    let mut max_dp = 0.0_f64;
    for k in 0..res.len() {
        assert_eq!(v[k], yd0[k], "x1 = ξ1");
        model.rhs(&[v[k], p_i[k]], &[], u[k], &mut dx);
        // dv/dt = ξ̇1 = y_d'.
        let scale_v = (c1 * v[k] * v[k]).abs()
            + (c2 * v[k].abs().powf(1.8)).abs()
            + (c3 * p_i[k]).abs()
            + c4.abs();
        assert!(
            (dx[0] - yd1[k]).abs() <= 1e-8 * scale_v,
            "t = {}: dv/dt {} vs {}",
            res.time()[k],
            dx[0],
            yd1[k]
        );
        // dp_i/dt = ∂x2/∂ξ1 ξ̇1 + ∂x2/∂ξ2 ξ̇2, x2 = (ξ2 − c1ξ1² − c2ξ1^1.8 − c4)/c3.
        let dx2_dxi1 = -(2.0 * c1 * yd0[k] + 1.8 * c2 * yd0[k].abs().powf(0.8)) / c3;
        let dx2_dxi2 = 1.0 / c3;
        let chain = dx2_dxi1 * yd1[k] + dx2_dxi2 * yd2[k];
        let scale_p = (c5 * v[k]).abs() + (c6 * v[k] * p_i[k]).abs() + (c7 * u[k]).abs();
        assert!(
            (dx[1] - chain).abs() <= 1e-8 * scale_p,
            "t = {}: dp_i/dt {} vs {chain}",
            res.time()[k],
            dx[1]
        );
        // The model's fused `invert` agrees with (y^(r) − α)/β.
        let xi = [yd0[k], yd1[k]];
        let u_ab = (yd2[k] - model.alpha(&xi, &[], &[])) / model.beta(&xi, &[], &[]);
        assert!((u_ab - u[k]).abs() <= 1e-12 * (c7 * u[k]).abs().max(scale_p) / c7);
        max_dp = max_dp.max(chain.abs());
    }
    assert!(
        max_dp > 5e3,
        "the cycle excites the manifold dynamics: max |dp_i/dt| = {max_dp}"
    );
}

#[test]
fn sample_count_and_grid_at_dt_0_01() {
    let res = simulate(&SiEngine::new(), &nedc(), &opts(0.01)).unwrap();
    assert_eq!(res.summary.samples, 118_001);
    assert_eq!(res.len(), 118_001);
    assert!(res.data.iter().all(|c| c.len() == 118_001));
    let t = res.time();
    assert_eq!(t[0], 0.0);
    assert_eq!(t[118_000], 1180.0);
    assert_eq!(t[30], 0.3);
    assert_eq!(t[12_345], 123.45);
    assert_eq!(res.summary.run.duration_s, 1180.0);
    assert_eq!(res.summary.dt_s, 0.01);
    assert_eq!(res.summary.engine, "compiled");
    // 1180 s at dt = 0.1 and a non-dividing step: round(duration/dt) + 1 samples.
    assert_eq!(
        simulate(&SiEngine::new(), &nedc(), &opts(0.1))
            .unwrap()
            .summary
            .samples,
        11_801
    );
    assert_eq!(
        simulate(&SiEngine::new(), &nedc(), &opts(0.7))
            .unwrap()
            .summary
            .samples,
        1687
    );
}

#[test]
fn csv_header_column_order_and_round_trip() {
    let res = simulate(&SiEngine::new(), &nedc(), &opts(0.5)).unwrap();
    assert_eq!(
        res.columns,
        ["t", "yd_0", "yd_1", "yd_2", "m_at", "v", "p_i", "fuel", "fuel_l"]
    );
    let mut buf = Vec::new();
    write_csv(&res, &mut buf).unwrap();
    let text = String::from_utf8(buf).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("t,yd_0,yd_1,yd_2,m_at,v,p_i,fuel,fuel_l")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), res.len());
    for (k, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            assert_eq!(
                v.to_bits(),
                res.data[c][k].to_bits(),
                "row {k} column {}",
                res.columns[c]
            );
        }
    }
    assert!(
        text.contains("\n0.5,"),
        "times are written as short decimals"
    );

    let lin = simulate(&LinearR2::minimum_phase(), &nedc(), &opts(1.0)).unwrap();
    assert_eq!(
        lin.columns,
        ["t", "yd_0", "yd_1", "yd_2", "u", "x1", "x2", "x3", "eta1", "u2"]
    );
    let mut buf = Vec::new();
    write_csv(&lin, &mut buf).unwrap();
    assert!(String::from_utf8(buf)
        .unwrap()
        .starts_with("t,yd_0,yd_1,yd_2,u,x1,x2,x3,eta1,u2\n"));
}

/// The model has no brake: the stronger decelerations need ṁ_at < 0, reported as bound violations, not clipped.
#[test]
fn bound_violations_cover_hard_decelerations() {
    let res = simulate(&SiEngine::new(), &nedc(), &opts(0.1)).unwrap();
    let (t, u) = (res.time(), res.input());
    let v = &res.summary.totals.input_bound_violations;
    assert!(!v.is_empty());
    assert!(
        v.windows(2).all(|w| w[0][1] < w[1][0]),
        "disjoint, in order"
    );
    let inside = |tk: f64| v.iter().any(|&[a, b]| a <= tk && tk <= b);
    for k in 0..t.len() {
        let outside = !(0.0..=0.08).contains(&u[k]);
        assert_eq!(inside(t[k]), outside, "t = {}: u = {}", t[k], u[k]);
    }
    // Maximal: the samples just before and after each interval are within the bounds.
    for &[a, b] in v {
        let ia = t.iter().position(|&x| x == a).unwrap();
        let ib = t.iter().position(|&x| x == b).unwrap();
        assert!(ia == 0 || u[ia - 1] >= 0.0);
        assert!(ib + 1 == t.len() || u[ib + 1] >= 0.0);
    }
    // ECE 32 → 10 km/h in 8 s (85–93 s, in each of the four repeats) and EUDC 50 → 0 km/h in 10 s (1150–1160 s).
    for tk in [89.0, 284.0, 479.0, 674.0, 1155.0] {
        assert!(inside(tk), "{tk} s is a hard deceleration: {v:?}");
    }
    // Never clipped: the input really goes negative, and the cruise at 120 km/h is inside the bounds.
    assert!(
        res.summary.totals.input_min < -1e-3,
        "{}",
        res.summary.totals.input_min
    );
    assert!(!inside(1120.0));
    assert!(
        res.summary
            .warnings
            .iter()
            .any(|w| w.contains("m_at") && w.contains("not clipped")),
        "{:?}",
        res.summary.warnings
    );
    assert_eq!(
        res.summary.totals.input_min,
        u.iter().copied().fold(f64::INFINITY, f64::min)
    );
    assert_eq!(
        res.summary.totals.input_max,
        u.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    );
}

#[test]
fn summary_integrals_text_and_json() {
    let res = simulate(&SiEngine::new(), &nedc(), &opts(0.1)).unwrap();
    let s = &res.summary;
    // Trapezoidal rule over the grid.
    let fuel = col(&res, "fuel");
    let trapezoid: f64 = fuel.windows(2).map(|w| 0.05 * (w[0] + w[1])).sum();
    assert!((s.totals.integrals["fuel"] - trapezoid).abs() <= 1e-12 * trapezoid.abs());
    assert!(
        s.totals.integrals["fuel"] > 0.1 && s.totals.integrals["fuel"] < 2.0,
        "{} kg of fuel on the NEDC",
        s.totals.integrals["fuel"]
    );
    assert_eq!(
        s.totals.integrals_per_100km["fuel"],
        s.totals.integrals["fuel"] * 1e5 / s.run.distance_m
    );
    assert!(
        (s.run.distance_m - 11_013.0).abs() < 1.0,
        "{}",
        s.run.distance_m
    );
    assert_eq!(s.relative_degree, 2);
    assert_eq!(s.run.cycle, "nedc");
    assert_eq!(s.run.model, "si_engine");

    let text = s.to_text();
    let fuel_line = text.lines().find(|l| l.starts_with("fuel: ")).expect(&text);
    assert!(
        fuel_line.contains("kg (integral)") && fuel_line.contains("kg/100 km"),
        "{fuel_line}"
    );
    assert!(
        text.lines()
            .any(|l| l.starts_with("fuel_l: ") && l.contains("l/100 km")),
        "{text}"
    );
    assert!(text.contains("samples: 11801\n"), "{text}");
    assert!(text.contains("input bound violations: "), "{text}");
    assert!(!text.contains("tracking error"));

    let json: serde_json::Value = serde_json::to_value(s).unwrap();
    for key in [
        "cycle",
        "duration_s",
        "distance_m",
        "relative_degree",
        "engine",
        "samples",
        "integrals",
        "input_bound_violations",
    ] {
        assert!(json.get(key).is_some(), "{key} in {json}");
    }
    assert!(json.get("max_abs_tracking_error").is_none());
    assert_eq!(
        json["input_bound_violations"][0].as_array().unwrap().len(),
        2
    );
}

/// Without the time series the run computes the same summary.
#[test]
fn summary_only_run_matches_the_full_run() {
    let full = simulate(&SiEngine::new(), &nedc(), &opts(0.01)).unwrap();
    let lean = SimulationOptions {
        keep_series: false,
        ..opts(0.01)
    };
    let res = simulate(&SiEngine::new(), &nedc(), &lean).unwrap();
    assert_eq!(res.summary, full.summary);
    assert_eq!(res.columns, full.columns);
    assert!(res.is_empty() && res.data.iter().all(Vec::is_empty));
    let mut buf = Vec::new();
    write_csv(&res, &mut buf).unwrap();
    assert_eq!(
        String::from_utf8(buf).unwrap(),
        "t,yd_0,yd_1,yd_2,m_at,v,p_i,fuel,fuel_l\n"
    );
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("invsim_runtime_empty.svg");
    assert!(plot_svg(&res, &nedc(), &path).is_err());
}

#[test]
fn nan_output_is_detected_with_time_and_name() {
    // √(10 − v): NaN from the first sample at which y_d exceeds 10 m/s (36 km/h): the smoothed ECE reaches it
    // on its short 35 km/h plateau at 133–135 s, which the 35 → 50 km/h ramp lifts.
    let reference = simulate(&SiEngine::new(), &nedc(), &opts(0.1)).unwrap();
    let k = reference
        .column("yd_0")
        .unwrap()
        .iter()
        .position(|&v| v > 10.0)
        .unwrap();
    let expected_t = reference.time()[k];
    match simulate(&NanOutput::new(10.0), &nedc(), &opts(0.1)) {
        Err(SimulateError::Run(RunError::NonFinite { t, quantity, value })) => {
            assert_eq!(quantity, "bad");
            assert_eq!(t, expected_t);
            assert!(value.is_nan());
            assert!((130.0..145.0).contains(&t), "{t}");
            let msg = RunError::NonFinite { t, quantity, value }.to_string();
            assert!(
                msg.contains("bad") && msg.contains(&format!("t = {t} s")),
                "{msg}"
            );
        }
        other => panic!("expected a NonFinite error, got {other:?}"),
    }
}

/// Forced causal integration (`causal: true`; by default unstable zero dynamics are inverted stably, see
/// `tests/stable.rs`).
#[test]
fn unstable_zero_dynamics_are_rejected_at_the_start() {
    let causal = SimulationOptions {
        causal: true,
        ..opts(0.1)
    };
    let err = simulate(&LinearR2::non_minimum_phase(), &nedc(), &causal).unwrap_err();
    match &err {
        SimulateError::UnstableZeroDynamics { t, eigenvalues, .. } => {
            assert_eq!(*t, 0.0);
            assert_eq!(eigenvalues.len(), 1);
            assert!(
                (eigenvalues[0][0] - 0.5).abs() < 1e-6 && eigenvalues[0][1] == 0.0,
                "{eigenvalues:?}"
            );
        }
        other => panic!("expected UnstableZeroDynamics, got {other:?}"),
    }
    let msg = err.to_string();
    for part in [
        "unstable zero dynamics",
        "t = 0 s",
        "0.5",
        "non-minimum phase",
        "stable (non-causal) inversion",
    ] {
        assert!(msg.contains(part), "`{part}` in: {msg}");
    }
}

/// `shared/models/internal_dynamics.toml` by hand (s = 1): x1' = x2, x2' = −sin x1 − x2 + x3 + u,
/// x3' = −k x3 + s x1 u, y = x1. Zero dynamics q = −k η + s ξ1 (y^(r) + sin ξ1 + ξ2 − η), ∂q/∂η = −k − s ξ1:
/// with s = −1 unstable where ξ1 > k.
struct InternalDynamics {
    info: ModelInfo,
    k: [f64; 1],
    s: f64,
}

impl InternalDynamics {
    fn new(s: f64) -> Self {
        InternalDynamics {
            info: ModelInfo {
                name: "internal_dynamics".into(),
                source_hash: None,
                description: String::new(),
                state_units: Vec::new(),
                input_unit: None,
                output_unit: None,
                states: vec!["x1".into(), "x2".into(), "x3".into()],
                input: "u".into(),
                output: "y".into(),
                relative_degree: 2,
                n_eta: 1,
                input_min: None,
                input_max: None,
                outputs: vec![],
                parameters: vec!["k".into()],
                ..Default::default()
            },
            k: [2.0],
            s,
        }
    }
}

impl InverseModel for InternalDynamics {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        &self.k
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        invsim_model_api::set_param_checked(&self.info, &mut self.k, name, value)
    }
    fn h(&self, x: &[f64], _w: &[f64]) -> f64 {
        x[0]
    }
    fn psi(&self, x: &[f64], _w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        xi.copy_from_slice(&x[..2]);
        eta[0] = x[2];
    }
    fn psi_inv(
        &self,
        xi: &[f64],
        eta: &[f64],
        _w: &[f64],
        x: &mut [f64],
    ) -> Result<(), ModelError> {
        x[..2].copy_from_slice(xi);
        x[2] = eta[0];
        Ok(())
    }
    fn alpha(&self, xi: &[f64], eta: &[f64], _w: &[f64]) -> f64 {
        -xi[0].sin() - xi[1] + eta[0]
    }
    fn beta(&self, _xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        1.0
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], _w: &[f64], yr: f64, deta: &mut [f64]) {
        deta[0] = -self.k[0] * eta[0] + self.s * xi[0] * (yr + xi[0].sin() + xi[1] - eta[0]);
    }
    fn rhs(&self, x: &[f64], _w: &[f64], u: f64, dx: &mut [f64]) {
        dx[0] = x[1];
        dx[1] = -x[0].sin() - x[1] + x[2] + u;
        dx[2] = -self.k[0] * x[2] + self.s * x[0] * u;
    }
    fn outputs(&self, _x: &[f64], _w: &[f64], _u: f64, _out: &mut [f64]) {}
}

/// With s = −1 and a reference that goes to 3 m/s: stable at the start, unstable once y_d > k = 2; forced causal
/// integration is caught by the monitoring, and (with monitoring off) by the blow-up guard; by default the
/// change of type is reported before anything is integrated (no bounded inverse exists).
#[test]
fn zero_dynamics_becoming_unstable_along_the_run_are_detected() {
    let cycle = Cycle {
        tolerance: invsim_runtime::cycle::Tolerance::EPA,
        name: "up".into(),
        time: vec![0.0, 10.0, 20.0, 100.0],
        speed: vec![0.0, 0.0, 3.0, 3.0],
        grade: None,
        columns: Vec::new(),
    };
    let model = InternalDynamics::new(-1.0);
    let smoother = Smoother::new(&cycle, 5.0).unwrap();
    let mut y = [0.0; 1];
    let crossing = (0..10_000)
        .map(|k| k as f64 * 0.01)
        .find(|&t| {
            smoother.eval(t, &mut y);
            y[0] > 2.0
        })
        .unwrap();
    match simulate(&model, &cycle, &opts(0.01)) {
        Err(SimulateError::Stable(StableError::ZeroDynamicsTypeChange {
            from, to, y_to, ..
        })) => {
            assert_eq!((from.as_str(), to.as_str()), ("0", "1"));
            assert!(y_to > 2.0, "{y_to}");
        }
        other => panic!("expected ZeroDynamicsTypeChange, got {other:?}"),
    }
    let causal = SimulationOptions {
        causal: true,
        ..opts(0.01)
    };
    match simulate(&model, &cycle, &causal) {
        Err(SimulateError::UnstableZeroDynamics {
            t,
            eigenvalues,
            detail,
        }) => {
            assert!(
                t >= crossing - 0.01 && t <= crossing + 1.0 + 1e-9,
                "detected at {t}, crossing {crossing}"
            );
            assert!(
                eigenvalues[0][0] > 0.0 && eigenvalues[0][0] < 0.35,
                "{eigenvalues:?}"
            );
            assert!(detail.contains("positive real part"), "{detail}");
        }
        other => panic!("expected UnstableZeroDynamics, got {other:?}"),
    }
    let no_monitoring = SimulationOptions {
        stability_check_interval: 1e6,
        ..causal.clone()
    };
    match simulate(&model, &cycle, &no_monitoring) {
        Err(SimulateError::UnstableZeroDynamics {
            t,
            eigenvalues,
            detail,
        }) => {
            assert!(detail.contains("blown up"), "{detail}");
            assert!(t > crossing && t < 100.0, "{t}");
            assert!(
                (eigenvalues[0][0] - 1.0).abs() < 1e-3,
                "∂q/∂η = −k + ξ1 = 1 at ξ1 = 3: {eigenvalues:?}"
            );
        }
        other => panic!("expected UnstableZeroDynamics (blow-up), got {other:?}"),
    }
    // The shared model (s = 1) on the NEDC (ξ1 ≥ 0) is minimum phase and runs.
    let res = simulate(&InternalDynamics::new(1.0), &nedc(), &opts(0.1)).unwrap();
    assert_eq!(
        res.columns,
        ["t", "yd_0", "yd_1", "yd_2", "u", "x1", "x2", "x3", "eta1"]
    );
}

/// Minimum-phase linear model from an off-equilibrium η(0) at constant speed:
/// η(t) = η_eq + (η0 − η_eq) e^{−(k+c)t}, η_eq = (b + c a0) v / (k + c), u = a0 v − η.
#[test]
fn stable_zero_dynamics_match_the_analytic_transient() {
    let model = LinearR2::minimum_phase();
    let [a0, _a1, k, b, c] = model.p();
    let lambda = k + c;
    let v = 36.0 / 3.6;
    let eta_eq = (b + c * a0) * v / lambda;
    let eta0 = -3.0;
    let o = SimulationOptions {
        eta0: Some(vec![eta0]),
        ..opts(0.05)
    };
    let res = simulate(&model, &constant_speed(36.0, 20.0), &o).unwrap();
    let (t, eta, u) = (res.time(), col(&res, "eta1"), res.input());
    let mut max_err = 0.0_f64;
    for i in 0..t.len() {
        let exact = eta_eq + (eta0 - eta_eq) * (-lambda * t[i]).exp();
        max_err = max_err.max((eta[i] - exact).abs());
        assert!((u[i] - (a0 * v - eta[i])).abs() < 1e-12 * (a0 * v));
        assert_eq!(col(&res, "x3")[i], eta[i]);
    }
    assert!(max_err < 2e-9, "max |η − η_exact| = {max_err:e}");
    assert!(max_err > 0.0);
    // Accumulated output u² by the trapezoidal rule (the end values differ: 23² vs about 10²).
    let trapezoid: f64 = u
        .windows(2)
        .map(|w| 0.025 * (w[0] * w[0] + w[1] * w[1]))
        .sum();
    assert!(
        (res.summary.totals.integrals["u2"] - trapezoid).abs() <= 1e-12 * trapezoid,
        "{trapezoid}"
    );
    assert!((u[0] - 23.0).abs() < 1e-9 && u[u.len() - 1] < 10.1);

    // Without eta0 the run starts in the equilibrium and stays there.
    let res = simulate(&model, &constant_speed(36.0, 20.0), &opts(0.05)).unwrap();
    assert!(
        col(&res, "eta1").iter().all(|&e| (e - eta_eq).abs() < 1e-9),
        "{:?}",
        &col(&res, "eta1")[..3]
    );
}

/// Minimum-phase linear model on the NEDC, against the variation-of-constants solution
/// η(t_{k+1}) = e^{−λ dt} η(t_k) + ∫ e^{−λ(t_{k+1}−s)} w(s) ds, w = (b + c a0) y_d + c a1 ẏ_d + c ÿ_d,
/// with the integral by 16-point Gauss–Legendre per step (exact to rounding for the C^∞ reference).
#[test]
fn stable_zero_dynamics_match_variation_of_constants_on_nedc() {
    let model = LinearR2::minimum_phase();
    let [a0, a1, k, b, c] = model.p();
    let lambda = k + c;
    let cycle = nedc();
    let dt = 0.1;
    let res = simulate(&model, &cycle, &opts(dt)).unwrap();
    let smoother = Smoother::new(&cycle, 5.0).unwrap();
    let (nodes, weights) = gauss_legendre(16);
    let w = |s: f64| {
        let mut y = [0.0; 3];
        smoother.eval(s, &mut y);
        (b + c * a0) * y[0] + c * a1 * y[1] + c * y[2]
    };
    let (t, eta) = (res.time(), col(&res, "eta1"));
    assert_eq!(eta[0], 0.0, "equilibrium at rest");
    let mut exact = 0.0;
    let mut max_err = 0.0_f64;
    let mut max_eta = 0.0_f64;
    for i in 1..t.len() {
        let (ta, tb) = (t[i - 1], t[i]);
        let h = tb - ta;
        let integral: f64 = nodes
            .iter()
            .zip(&weights)
            .map(|(x, wt)| {
                let s = ta + 0.5 * h * (x + 1.0);
                0.5 * h * wt * (-lambda * (tb - s)).exp() * w(s)
            })
            .sum();
        exact = (-lambda * h).exp() * exact + integral;
        max_err = max_err.max((eta[i] - exact).abs());
        max_eta = max_eta.max(exact.abs());
    }
    assert!(max_eta > 10.0, "{max_eta}");
    assert!(
        max_err < 1e-9 * max_eta,
        "max |η − η_exact| = {max_err:e} (max |η| = {max_eta})"
    );
}

/// The open-loop replay of the sampled input (linear between grid points) follows y_d to O(dt²): below 1e-4 at
/// dt = 0.01 s and 1e-2 at dt = 0.1 s, about 100 times apart.
#[test]
fn verification_tracks_the_reference() {
    let verified = |dt: f64, model: &dyn InverseModel| {
        let o = SimulationOptions {
            verify: true,
            ..opts(dt)
        };
        let res = simulate(model, &nedc(), &o).unwrap();
        let max = res.summary.max_abs_tracking_error.unwrap();
        let rms = res.summary.rms_tracking_error.unwrap();
        assert!(
            rms <= max,
            "{}: max {max:e}, rms {rms:e}",
            res.summary.run.model
        );
        let json = serde_json::to_value(&res.summary).unwrap();
        assert!(json.get("max_abs_tracking_error").is_some());
        assert!(res.summary.to_text().contains("max abs tracking error: "));
        max
    };
    let models: [&dyn InverseModel; 2] = [&SiEngine::new(), &LinearR2::minimum_phase()];
    for model in models {
        let (fine, coarse) = (verified(0.01, model), verified(0.1, model));
        assert!(
            fine < 1e-4 && coarse < 1e-2,
            "{}: {fine:e} at dt = 0.01, {coarse:e} at dt = 0.1",
            model.info().name
        );
        let ratio = coarse / fine;
        assert!(
            (30.0..300.0).contains(&ratio),
            "{}: O(dt²) expected, ratio {ratio}",
            model.info().name
        );
    }
}

/// With v^1.8 undefined for v < 0 (as in generated code without the regularisation), the forward replay cannot
/// continue at a standstill where rounding makes the simulated speed slightly negative: a clear error naming
/// the time and the state.
#[test]
fn verification_stops_with_a_clear_error_where_the_original_model_is_undefined() {
    let mut model = SiEngine::new();
    model.strict_domain = true;
    let o = SimulationOptions {
        verify: true,
        ..opts(0.1)
    };
    match simulate(&model, &nedc(), &o) {
        Err(e @ SimulateError::Verification { t, .. }) => {
            let text = e.to_string();
            assert!(nedc().speed_at(t) == 0.0, "at a standstill: t = {t}");
            assert!(
                text.contains("verification failed") && text.contains("state v = "),
                "{text}"
            );
        }
        other => panic!("expected a verification error, got {other:?}"),
    }
    // The inverse itself is unaffected.
    assert!(simulate(&model, &nedc(), &opts(0.1)).is_ok());
}

#[test]
fn invalid_options_are_rejected() {
    let model = SiEngine::new();
    for dt in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        let e = simulate(&model, &nedc(), &opts(dt)).unwrap_err();
        assert!(
            matches!(e, SimulateError::Run(RunError::InvalidDt(_))),
            "{e:?}"
        );
        assert!(e.to_string().contains("positive, finite"), "{e}");
    }
    for a in [0.0, -5.0, f64::NAN] {
        let e = simulate(
            &model,
            &nedc(),
            &SimulationOptions {
                lookahead: a,
                ..opts(0.1)
            },
        )
        .unwrap_err();
        assert!(matches!(e, SimulateError::InvalidLookahead(_)), "{e:?}");
    }
    let lin = LinearR2::minimum_phase();
    let e = simulate(
        &lin,
        &nedc(),
        &SimulationOptions {
            eta0: Some(vec![0.0, 1.0]),
            ..opts(0.1)
        },
    )
    .unwrap_err();
    assert!(
        matches!(e, SimulateError::InvalidEta0 { .. })
            && e.to_string().contains("1 internal coordinates"),
        "{e}"
    );
}

#[test]
fn plot_svg_writes_both_panels() {
    let cycle = nedc();
    let res = simulate(&SiEngine::new(), &cycle, &opts(0.01)).unwrap();
    let path =
        std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("invsim_runtime_plot_test.svg");
    let _ = std::fs::remove_file(&path);
    plot_svg(&res, &cycle, &path).unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.contains("<svg") && svg.trim_end().ends_with("</svg>"));
    for label in [
        "km/h",
        "cycle",
        "y_d (smoothed)",
        "m_at",
        "lower bound",
        "upper bound",
        "t [s]",
        "nedc",
    ] {
        assert!(svg.contains(label), "label `{label}` in the SVG");
    }
    assert!(
        svg.matches("<polyline").count() >= 4,
        "cycle, y_d, input, the lower bound (the upper one, 0.08 kg/s, is off the input's scale)"
    );
    assert!(
        svg.len() > 20_000 && svg.len() < 2_000_000,
        "{} bytes",
        svg.len()
    );
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_n).
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let legendre = |z: f64| {
        let (mut p1, mut p2) = (1.0, 0.0);
        for j in 0..n {
            let p3 = p2;
            p2 = p1;
            p1 = ((2 * j + 1) as f64 * z * p2 - j as f64 * p3) / (j + 1) as f64;
        }
        (p1, n as f64 * (z * p1 - p2) / (z * z - 1.0))
    };
    let mut nodes = Vec::with_capacity(n);
    let mut weights = Vec::with_capacity(n);
    for i in 0..n {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (p, dp) = legendre(z);
            let dz = p / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        let (_, dp) = legendre(z);
        nodes.push(z);
        weights.push(2.0 / ((1.0 - z * z) * dp * dp));
    }
    (nodes, weights)
}

#[test]
fn options_builder_validates_once() {
    let o = SimulationOptions::builder()
        .lookahead(3.0)
        .dt(0.05)
        .engine("interpreted")
        .verify(true)
        .build()
        .unwrap();
    assert_eq!(
        (o.lookahead, o.dt, o.engine.as_str()),
        (3.0, 0.05, "interpreted")
    );
    assert!(o.verify && o.keep_series && !o.causal);
    assert_eq!(
        SimulationOptions::builder().build().unwrap(),
        SimulationOptions::default()
    );
    assert_eq!(
        SimulationOptions::default().lookahead,
        invsim_runtime::inverse::DEFAULT_LOOKAHEAD
    );
    let bad = |b: invsim_runtime::SimulationOptionsBuilder| b.build().unwrap_err().to_string();
    assert!(bad(SimulationOptions::builder().dt(0.0)).starts_with("invalid output step dt = 0 s"));
    assert!(bad(SimulationOptions::builder().lookahead(f64::NAN)).starts_with("invalid look-ahead"));
    assert!(bad(SimulationOptions::builder().rtol(-1.0)).contains("rtol = -1"));
    assert!(
        bad(SimulationOptions::builder().stability_check_interval(0.0))
            .starts_with("invalid stability check interval")
    );
}
