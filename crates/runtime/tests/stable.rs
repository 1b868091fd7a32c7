//! Stable (non-causal) inversion of unstable zero dynamics (`invsim_runtime::stable`): linear non-minimum-phase
//! and mixed models against their exact bounded solutions (including the pre-actuation before t = 0), causal
//! blow-up against bounded stable inverses, forward replay (`verify`), and the built-in `diesel_gasflow`
//! (non-minimum phase) and `driveline` (minimum phase, lightly damped zero dynamics) models on the NEDC.

use invsim_model_api::{set_param_checked, InverseModel, ModelError, ModelInfo};
use invsim_runtime::{
    simulate, Cycle, SimulateError, SimulationOptions, SimulationResult, Smoother, StableError,
    ZeroDynamicsClass,
};

// --- the linear test models --------------------------------------------------------------------------------

/// x1' = −a x1 + η + u, η' = b η + k x1, y = x1, i.e. G(s) = (s − b)/((s + p1)(s + p2)) with a = p1 + p2 + b and
/// k = −(p1 p2 + a b). Relative degree 1, ξ = x1, α = −a ξ + η, β = 1, zero dynamics η' = b η + k ξ: for b > 0 an
/// unstable zero (non-minimum phase) while the plant's poles −p1, −p2 are stable.
///
/// The exact stable inverse for a reference y_d is the bounded solution of η' = b η + k y_d,
/// η(t) = −k ∫_t^∞ e^{−b(τ−t)} y_d(τ) dτ (Devasia, Chen & Paden 1996, the unstable part integrated backward), and
/// u = ẏ_d + a y_d − η.
struct LinearNmp {
    info: ModelInfo,
    p: [f64; 3],
}

impl LinearNmp {
    fn new(p1: f64, p2: f64, b: f64) -> Self {
        let a = p1 + p2 + b;
        let k = -(p1 * p2 + a * b);
        LinearNmp {
            info: ModelInfo {
                name: "linear_nmp".into(),
                source_hash: None,
                description: String::new(),
                state_units: Vec::new(),
                input_unit: None,
                output_unit: None,
                states: vec!["x1".into(), "x2".into()],
                input: "u".into(),
                output: "y".into(),
                relative_degree: 1,
                n_eta: 1,
                input_min: None,
                input_max: None,
                outputs: vec![],
                parameters: vec!["a".into(), "b".into(), "k".into()],
                ..Default::default()
            },
            p: [a, b, k],
        }
    }
}

impl InverseModel for LinearNmp {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        &self.p
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        set_param_checked(&self.info, &mut self.p, name, value)
    }
    fn h(&self, x: &[f64], _w: &[f64]) -> f64 {
        x[0]
    }
    fn psi(&self, x: &[f64], _w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        xi[0] = x[0];
        eta[0] = x[1];
    }
    fn psi_inv(
        &self,
        xi: &[f64],
        eta: &[f64],
        _w: &[f64],
        x: &mut [f64],
    ) -> Result<(), ModelError> {
        x[0] = xi[0];
        x[1] = eta[0];
        Ok(())
    }
    fn alpha(&self, xi: &[f64], eta: &[f64], _w: &[f64]) -> f64 {
        -self.p[0] * xi[0] + eta[0]
    }
    fn beta(&self, _xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        1.0
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], _w: &[f64], _yr: f64, deta: &mut [f64]) {
        deta[0] = self.p[1] * eta[0] + self.p[2] * xi[0];
    }
    fn rhs(&self, x: &[f64], _w: &[f64], u: f64, dx: &mut [f64]) {
        let [a, b, k] = self.p;
        dx[0] = -a * x[0] + x[1] + u;
        dx[1] = b * x[1] + k * x[0];
    }
    fn outputs(&self, _x: &[f64], _w: &[f64], _u: f64, _out: &mut [f64]) {}
}

/// Mixed zero dynamics: x1' = −a x1 + η1 + η2 + u, η1' = b η1 + k1 x1 (unstable, b > 0), η2' = −c η2 + k2 x1
/// (stable), y = x1; zeros at b and −c. Exact: η1 = −k1 ∫_t^∞ e^{−b(τ−t)} y_d dτ (backward), η2 = k2 ∫_{−∞}^t
/// e^{−c(t−τ)} y_d dτ (forward), u = ẏ_d + a y_d − η1 − η2. With a = 3, b = 0.5, c = 2, k1 = −2, k2 = 1 the
/// plant's characteristic polynomial is s³ + 4.5 s² + 4.5 s + 1.5 (stable).
struct LinearMixed {
    info: ModelInfo,
    p: [f64; 5],
}

impl LinearMixed {
    fn new() -> Self {
        LinearMixed {
            info: ModelInfo {
                name: "linear_mixed".into(),
                source_hash: None,
                description: String::new(),
                state_units: Vec::new(),
                input_unit: None,
                output_unit: None,
                states: vec!["x1".into(), "x2".into(), "x3".into()],
                input: "u".into(),
                output: "y".into(),
                relative_degree: 1,
                n_eta: 2,
                input_min: None,
                input_max: None,
                outputs: vec![],
                parameters: ["a", "b", "c", "k1", "k2"]
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
                ..Default::default()
            },
            p: [3.0, 0.5, 2.0, -2.0, 1.0],
        }
    }
}

impl InverseModel for LinearMixed {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        &self.p
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        set_param_checked(&self.info, &mut self.p, name, value)
    }
    fn h(&self, x: &[f64], _w: &[f64]) -> f64 {
        x[0]
    }
    fn psi(&self, x: &[f64], _w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        xi[0] = x[0];
        eta.copy_from_slice(&x[1..]);
    }
    fn psi_inv(
        &self,
        xi: &[f64],
        eta: &[f64],
        _w: &[f64],
        x: &mut [f64],
    ) -> Result<(), ModelError> {
        x[0] = xi[0];
        x[1..].copy_from_slice(eta);
        Ok(())
    }
    fn alpha(&self, xi: &[f64], eta: &[f64], _w: &[f64]) -> f64 {
        -self.p[0] * xi[0] + eta[0] + eta[1]
    }
    fn beta(&self, _xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        1.0
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], _w: &[f64], _yr: f64, deta: &mut [f64]) {
        let [_, b, c, k1, k2] = self.p;
        deta[0] = b * eta[0] + k1 * xi[0];
        deta[1] = -c * eta[1] + k2 * xi[0];
    }
    fn rhs(&self, x: &[f64], _w: &[f64], u: f64, dx: &mut [f64]) {
        let [a, b, c, k1, k2] = self.p;
        dx[0] = -a * x[0] + x[1] + x[2] + u;
        dx[1] = b * x[1] + k1 * x[0];
        dx[2] = -c * x[2] + k2 * x[0];
    }
    fn outputs(&self, _x: &[f64], _w: &[f64], _u: f64, _out: &mut [f64]) {}
}

// --- exact solutions -----------------------------------------------------------------------------------------

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton's method on P_n).
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut w) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                let dp = {
                    let (mut p0, mut p1) = (1.0, z);
                    for k in 2..=n {
                        let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                        p0 = p1;
                        p1 = p2;
                    }
                    n as f64 * (z * p1 - p0) / (z * z - 1.0)
                };
                x[i] = z;
                w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
                break;
            }
        }
    }
    (x, w)
}

/// The exponentially weighted integrals of the reference, evaluated to ~1e-13 by Gauss–Legendre quadrature on
/// panels of 0.5 s (the reference is C-infinity, smooth on the kernel's scale) with exact tails where it is
/// constant:
/// B(t) = ∫_t^∞ e^{−λ(τ−t)} y_d(τ) dτ (backward) and F(t) = ∫_{−∞}^t e^{−λ(t−τ)} y_d(τ) dτ (forward).
struct Weighted {
    lambda: f64,
    lo: f64,
    w: f64,
    /// B at the panel boundaries lo + p w, F likewise.
    b: Vec<f64>,
    f: Vec<f64>,
    gl: (Vec<f64>, Vec<f64>),
}

impl Weighted {
    fn new(smoother: &Smoother, lambda: f64, lo: f64, hi: f64) -> Self {
        let w = 0.5;
        let panels = ((hi - lo) / w).ceil() as usize;
        let gl = gauss_legendre(16);
        let y = |t: f64| smoother.derivative(0, t);
        let (y_lo, y_hi) = (y(lo - 1e3), y(lo + panels as f64 * w + 1e3));
        let mut b = vec![0.0; panels + 1];
        let mut f = vec![0.0; panels + 1];
        b[panels] = y_hi / lambda;
        f[0] = y_lo / lambda;
        let decay = (-lambda * w).exp();
        let quad = |a: f64, c: f64, weight: &dyn Fn(f64) -> f64| -> f64 {
            let (m, r) = (0.5 * (a + c), 0.5 * (c - a));
            gl.0.iter()
                .zip(&gl.1)
                .map(|(x, wt)| wt * r * weight(m + r * x) * y(m + r * x))
                .sum()
        };
        for p in (0..panels).rev() {
            let a = lo + p as f64 * w;
            b[p] = quad(a, a + w, &|s| (-lambda * (s - a)).exp()) + decay * b[p + 1];
        }
        for p in 1..=panels {
            let c = lo + p as f64 * w;
            f[p] = quad(c - w, c, &|s| (-lambda * (c - s)).exp()) + decay * f[p - 1];
        }
        Weighted {
            lambda,
            lo,
            w,
            b,
            f,
            gl,
        }
    }

    fn partial(&self, smoother: &Smoother, a: f64, c: f64, weight: &dyn Fn(f64) -> f64) -> f64 {
        let (m, r) = (0.5 * (a + c), 0.5 * (c - a));
        self.gl
            .0
            .iter()
            .zip(&self.gl.1)
            .map(|(x, wt)| wt * r * weight(m + r * x) * smoother.derivative(0, m + r * x))
            .sum()
    }

    fn panel(&self, t: f64) -> usize {
        (((t - self.lo) / self.w).floor().max(0.0) as usize).min(self.b.len() - 2)
    }

    fn backward(&self, smoother: &Smoother, t: f64) -> f64 {
        let p = self.panel(t);
        let c = self.lo + (p + 1) as f64 * self.w;
        let l = self.lambda;
        self.partial(smoother, t, c, &|s| (-l * (s - t)).exp())
            + (-l * (c - t)).exp() * self.b[p + 1]
    }

    fn forward(&self, smoother: &Smoother, t: f64) -> f64 {
        let p = self.panel(t);
        let a = self.lo + p as f64 * self.w;
        let l = self.lambda;
        self.partial(smoother, a, t, &|s| (-l * (t - s)).exp()) + (-l * (t - a)).exp() * self.f[p]
    }
}

/// A cycle that starts to move at t = 0 (so the stable inverse needs input before t = 0) and ends at rest.
fn ramp_cycle() -> Cycle {
    Cycle {
        tolerance: invsim_runtime::cycle::Tolerance::EPA,
        name: "ramps".into(),
        time: vec![0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0],
        speed: vec![0.0, 5.0, 5.0, 8.0, 8.0, 0.0, 0.0],
        grade: None,
        columns: Vec::new(),
    }
}

fn col<'a>(res: &'a SimulationResult, name: &str) -> &'a [f64] {
    res.column(name)
        .unwrap_or_else(|| panic!("column {name} in {:?}", res.columns))
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |a, x| a.max(x.abs()))
}

// --- the tests ---------------------------------------------------------------------------------------------

/// The non-minimum-phase linear model: the stable inverse equals the exact bounded solution within 1e-6 at every
/// sample of the extended horizon, from the start of the pre-actuation (t ≈ −39 s) to the end.
#[test]
fn linear_nmp_stable_inverse_matches_the_exact_solution_with_pre_actuation() {
    let model = LinearNmp::new(0.5, 2.0, 0.5);
    let [a, b, k] = model.p;
    let cycle = ramp_cycle();
    let opts = SimulationOptions {
        dt: 0.01,
        lookahead: 2.0,
        include_extension: true,
        ..SimulationOptions::default()
    };
    let res = simulate(&model, &cycle, &opts).expect("stable inversion");
    let s = &res.summary;
    assert_eq!(s.inversion, "stable");
    assert_eq!(s.zero_dynamics_class, ZeroDynamicsClass::NonMinimumPhase);
    assert!(
        (s.zero_dynamics_eigenvalues[0][0] - b).abs() < 1e-6,
        "{:?}",
        s.zero_dynamics_eigenvalues
    );
    // The reference moves from t = −a = −2 s; the unstable part decays backward at b = 0.5/s: ln(1e8)/0.5 s more.
    let expected_pre = 2.0 + (1e8_f64).ln() / b;
    assert!(
        (s.pre_actuation_s - expected_pre).abs() < 0.011,
        "{} vs {expected_pre}",
        s.pre_actuation_s
    );
    assert_eq!(s.post_actuation_s, 0.0);
    let t = res.time();
    assert!(
        (t[0] + s.pre_actuation_s).abs() < 1e-9 && t[0] < -38.0,
        "first sample {}",
        t[0]
    );
    assert_eq!(s.samples, t.len());
    let before = s
        .input_before_start
        .as_ref()
        .expect("input before t = 0 is reported");
    assert!(
        before.max_deviation > 0.1 && before.integral_abs_deviation > 0.1,
        "{before:?}"
    );
    assert!(
        before.departs_at.is_some_and(|d| d < -2.0 && d > t[0]),
        "{before:?}"
    );

    let smoother = Smoother::new(&cycle, opts.lookahead).unwrap();
    let exact = Weighted::new(&smoother, b, t[0] - 1.0, 70.0);
    let (eta, u, yd1) = (col(&res, "eta1"), res.input(), res.yd(1).unwrap());
    let (mut worst_eta, mut worst_u, mut worst_at) = (0.0_f64, 0.0_f64, 0.0);
    for (i, &ti) in t.iter().enumerate() {
        let eta_exact = -k * exact.backward(&smoother, ti);
        let u_exact = yd1[i] + a * res.yd(0).unwrap()[i] - eta_exact;
        let (de, du) = ((eta[i] - eta_exact).abs(), (u[i] - u_exact).abs());
        if de.max(du) > worst_eta.max(worst_u) {
            worst_at = ti;
        }
        worst_eta = worst_eta.max(de);
        worst_u = worst_u.max(du);
    }
    assert!(
        worst_eta < 1e-6 && worst_u < 1e-6,
        "η error {worst_eta:e}, u error {worst_u:e} (worst at t = {worst_at})"
    );
    // The pre-actuation is real: before t = 0 the exact input is far from zero and so is the computed one.
    let i0 = t.iter().position(|&x| x >= -1.0).unwrap();
    assert!(u[i0].abs() > 0.05, "u(−1 s) = {}", u[i0]);
}

/// Causal integration of the same zero dynamics from the causal driver's starting point (the frozen equilibrium
/// at t = 0) grows without bound, while the stable inverse stays bounded; the driver refuses it when forced.
#[test]
fn linear_nmp_causal_integration_grows_without_bound() {
    let model = LinearNmp::new(0.5, 2.0, 0.5);
    let [_, b, k] = model.p;
    let cycle = Cycle {
        tolerance: invsim_runtime::cycle::Tolerance::EPA,
        name: "long".into(),
        time: vec![0.0, 10.0, 20.0, 30.0, 200.0],
        speed: vec![0.0, 5.0, 5.0, 2.0, 2.0],
        grade: None,
        columns: Vec::new(),
    };
    let opts = SimulationOptions {
        dt: 0.01,
        lookahead: 2.0,
        ..SimulationOptions::default()
    };
    let stable = simulate(&model, &cycle, &opts).expect("stable inversion");
    let eta_stable = col(&stable, "eta1");
    let bound = max_abs(eta_stable);
    assert!(
        bound < 2.0 * (-k / b) * 5.0,
        "stable inverse bounded by the reference: {bound}"
    );

    let smoother = Smoother::new(&cycle, opts.lookahead).unwrap();
    let y = |t: f64| smoother.derivative(0, t);
    // RK4 of η' = b η + k y_d from η(0) = −k y_d(0)/b.
    let (h, mut t, mut eta) = (0.01, 0.0, -k * y(0.0) / b);
    let mut first_blowup = None;
    while t < 200.0 {
        let f = |t: f64, e: f64| b * e + k * y(t);
        let k1 = f(t, eta);
        let k2 = f(t + h / 2.0, eta + h / 2.0 * k1);
        let k3 = f(t + h / 2.0, eta + h / 2.0 * k2);
        let k4 = f(t + h, eta + h * k3);
        eta += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        t += h;
        if first_blowup.is_none() && eta.abs() > 1e6 * bound {
            first_blowup = Some(t);
        }
    }
    let at = first_blowup.expect("causal η grows without bound");
    assert!(at < 100.0, "blow-up at {at}");

    let causal = SimulationOptions {
        causal: true,
        ..opts
    };
    match simulate(&model, &cycle, &causal) {
        Err(SimulateError::UnstableZeroDynamics { t, eigenvalues, .. }) => {
            assert_eq!(t, 0.0);
            assert!((eigenvalues[0][0] - b).abs() < 1e-6, "{eigenvalues:?}");
        }
        other => panic!("expected UnstableZeroDynamics, got {other:?}"),
    }
}

/// The forward replay of the stable inverse's input (from the pre-actuated initial state at the start of the
/// extended grid) tracks y_d within 1e-3 of its range; the series covers the cycle only by default.
#[test]
fn linear_nmp_forward_replay_tracks_the_reference() {
    let model = LinearNmp::new(0.5, 2.0, 0.5);
    let cycle = ramp_cycle();
    let opts = SimulationOptions {
        dt: 0.01,
        lookahead: 2.0,
        verify: true,
        ..SimulationOptions::default()
    };
    let res = simulate(&model, &cycle, &opts).expect("stable inversion");
    assert_eq!(res.time()[0], 0.0);
    assert_eq!(*res.time().last().unwrap(), 60.0);
    assert_eq!(res.summary.samples, 6001);
    let err = res.summary.max_abs_tracking_error.expect("verified");
    let range = max_abs(res.yd(0).unwrap());
    assert!(
        err / range < 1e-3,
        "relative tracking error {}",
        err / range
    );
    assert!(res.summary.pre_actuation_s > 38.0);
    // Starting the replay at t = 0 from x(0) instead needs the same state, which only the pre-actuation reaches:
    // x2(0) = η(0) ≠ 0 although the reference is at rest there.
    assert!(
        col(&res, "x2")[0].abs() > 0.01,
        "η(0) = {}",
        col(&res, "x2")[0]
    );
}

/// Mixed zero dynamics (one unstable, one stable eigenvalue): the stable part integrated forward from the
/// start, the unstable part backward from the end; both match their exact solutions within 1e-6, the extended
/// grid covers the post-actuation the stable part needs.
#[test]
fn linear_mixed_stable_inverse_matches_the_exact_solution() {
    let model = LinearMixed::new();
    let [a, b, c, k1, k2] = model.p;
    let cycle = ramp_cycle();
    let opts = SimulationOptions {
        dt: 0.01,
        lookahead: 2.0,
        include_extension: true,
        verify: true,
        ..SimulationOptions::default()
    };
    let res = simulate(&model, &cycle, &opts).expect("stable inversion");
    let s = &res.summary;
    assert_eq!(s.zero_dynamics_class, ZeroDynamicsClass::Mixed);
    assert_eq!(s.stable_inversion.as_ref().unwrap().unstable_dimension, 1);
    // Post-actuation: the stable part decays at c = 2/s after the reference settles at 50 + 2 s.
    let expected_post = 52.0 + (1e8_f64).ln() / c - 60.0;
    assert!(
        (s.post_actuation_s - expected_post).abs() < 0.011,
        "{} vs {expected_post}",
        s.post_actuation_s
    );
    let t = res.time();
    let smoother = Smoother::new(&cycle, opts.lookahead).unwrap();
    let back = Weighted::new(&smoother, b, t[0] - 1.0, t[t.len() - 1] + 1.0);
    let fwd = Weighted::new(&smoother, c, t[0] - 1.0, t[t.len() - 1] + 1.0);
    let (e1, e2, u) = (col(&res, "x2"), col(&res, "x3"), res.input());
    let mut worst = 0.0_f64;
    for (i, &ti) in t.iter().enumerate() {
        let eta1 = -k1 * back.backward(&smoother, ti);
        let eta2 = k2 * fwd.forward(&smoother, ti);
        let u_exact = res.yd(1).unwrap()[i] + a * res.yd(0).unwrap()[i] - eta1 - eta2;
        worst = worst
            .max((e1[i] - eta1).abs())
            .max((e2[i] - eta2).abs())
            .max((u[i] - u_exact).abs());
    }
    assert!(worst < 1e-6, "worst error {worst:e}");
    let err = s.max_abs_tracking_error.unwrap() / max_abs(res.yd(0).unwrap());
    assert!(err < 1e-3, "relative tracking error {err}");
}

/// Zero dynamics too slow for the pre-actuation limit are an error that says so.
#[test]
fn pre_actuation_beyond_the_limit_is_an_error() {
    let model = LinearNmp::new(0.5, 2.0, 0.01);
    let opts = SimulationOptions {
        dt: 0.1,
        lookahead: 2.0,
        max_pre_actuation: 100.0,
        ..SimulationOptions::default()
    };
    match simulate(&model, &ramp_cycle(), &opts) {
        Err(e @ SimulateError::Stable(StableError::PreActuationTooLong { .. })) => {
            let msg = e.to_string();
            assert!(
                msg.contains("pre-actuation") && msg.contains("limit of 100 s"),
                "{msg}"
            );
        }
        other => panic!("expected PreActuationTooLong, got {other:?}"),
    }
}

// --- the built-in models ----------------------------------------------------------------------------------

fn nedc() -> Cycle {
    Cycle::builtin("nedc").expect("built-in NEDC")
}

/// `diesel_gasflow` (boost pressure via the VGT): non-minimum phase; the stable inverse over the NEDC is bounded
/// and its forward replay tracks the boost demand within 1e-3; forward integration of the same zero dynamics
/// from a point of the stable solution, off by 1 Pa, leaves it without bound within seconds.
#[test]
fn diesel_gasflow_stable_inverse_is_bounded_and_tracks_while_causal_blows_up() {
    let model = invsim_models::builtin("diesel_gasflow").expect("built in");
    let model = model.as_ref();
    let opts = SimulationOptions {
        dt: 0.01,
        verify: true,
        ..SimulationOptions::default()
    };
    let res = simulate(model, &nedc(), &opts).expect("stable inversion");
    let s = &res.summary;
    assert_eq!(s.zero_dynamics_class, ZeroDynamicsClass::NonMinimumPhase);
    assert_eq!(s.inversion, "stable");
    assert!(
        s.zero_dynamics_eigenvalues[0][0] > 1.0,
        "{:?}",
        s.zero_dynamics_eigenvalues
    );
    let p_em = col(&res, "eta1");
    assert!(
        p_em.iter().all(|&p| p > 1.0e5 && p < 5.0e5),
        "p_em within [1, 5] bar"
    );
    let u = res.input();
    assert!(
        u.iter().all(|&v| (0.2..=1.0).contains(&v)),
        "VGT position within its bounds"
    );
    let yd = res.yd(0).unwrap();
    let rel = s.max_abs_tracking_error.unwrap() / max_abs(yd);
    assert!(rel < 1e-3, "relative tracking error {rel}");

    // Causal: RK4 of the zero dynamics from the stable solution at t = 100 s, 1 Pa off.
    let smoother = Smoother::new(&nedc(), opts.lookahead)
        .unwrap()
        .with_reference(model.reference());
    let k0 = res.time().iter().position(|&t| t >= 100.0).unwrap();
    let (h, mut t, mut eta) = (0.001, 100.0, p_em[k0] + 1.0);
    let q = |t: f64, e: f64| {
        let mut y = [0.0; 3];
        smoother.eval(t, &mut y);
        let mut d = [0.0];
        model.zero_dynamics(&y[..2], &[e], &[], y[2], &mut d);
        d[0]
    };
    let mut departed = None;
    while t < 110.0 {
        let k1 = q(t, eta);
        let k2 = q(t + h / 2.0, eta + h / 2.0 * k1);
        let k3 = q(t + h / 2.0, eta + h / 2.0 * k2);
        let k4 = q(t + h, eta + h * k3);
        eta += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        t += h;
        let k = ((t - res.time()[0]) / opts.dt).round() as usize;
        if !eta.is_finite() || (eta - p_em[k.min(p_em.len() - 1)]).abs() > 1e4 {
            departed = Some(t);
            break;
        }
    }
    let at = departed.expect("causal η leaves the bounded solution");
    assert!(at < 103.0, "departed at {at}");

    let causal = SimulationOptions {
        causal: true,
        ..opts
    };
    assert!(matches!(
        simulate(model, &nedc(), &causal),
        Err(SimulateError::UnstableZeroDynamics { .. })
    ));
}

/// `driveline` on the NEDC: minimum phase, inverted causally, the forward replay tracks within 1e-3; the body's
/// fore-aft resonance on the tyre/suspension compliance rings in the internal states (body speed η3 against the
/// wheel speed, shaft torsion η1) after every acceleration, at the damped frequency of the zero dynamics'
/// complex pair (2π/T_d ≈ 12.6 rad/s) and with its decay rate ζω_n ≈ c_t/(2m).
#[test]
fn driveline_on_nedc_tracks_and_rings_at_the_zero_dynamics_resonance() {
    let model = invsim_models::builtin("driveline").expect("built in");
    let model = model.as_ref();
    for lookahead in [5.0, 1.0] {
        let opts = SimulationOptions {
            dt: 0.01,
            lookahead,
            verify: true,
            ..SimulationOptions::default()
        };
        let res = simulate(model, &nedc(), &opts).expect("causal inversion");
        let s = &res.summary;
        assert_eq!(s.zero_dynamics_class, ZeroDynamicsClass::MinimumPhase);
        assert_eq!(s.inversion, "causal");
        let rel = s.max_abs_tracking_error.unwrap() / max_abs(res.yd(0).unwrap());
        assert!(
            rel < 1e-3,
            "relative tracking error {rel} at a = {lookahead}"
        );
        // The complex pair at the start (standstill) has the damped frequency of every speed (drag is small).
        let pair = s
            .zero_dynamics_eigenvalues
            .iter()
            .find(|e| e[1] > 0.0)
            .expect("a complex pair");
        let omega_d = pair[1];
        assert!((omega_d - 12.63).abs() < 0.05, "{pair:?}");

        // Segments where the reference is constant (ẏ_d = 0) for at least 3 s: the zero dynamics ring freely.
        let (t, yd, yd1) = (res.time(), res.yd(0).unwrap(), res.yd(1).unwrap());
        let (v, th) = (col(&res, "eta3"), col(&res, "eta1"));
        let mut periods = Vec::new();
        let mut decays = Vec::new();
        let mut i = 0;
        while i < t.len() {
            if yd1[i] != 0.0 || yd[i] < 1.0 {
                i += 1;
                continue;
            }
            let j = (i..t.len()).find(|&j| yd1[j] != 0.0).unwrap_or(t.len());
            if t[j - 1] - t[i] > 3.0 {
                let dev: Vec<f64> = (i..j).map(|k| v[k] - yd[k]).collect();
                let crossings: Vec<f64> = (1..dev.len())
                    .filter(|&k| dev[k - 1] * dev[k] < 0.0)
                    .map(|k| t[i + k - 1] + opts.dt * dev[k - 1] / (dev[k - 1] - dev[k]))
                    .take(12)
                    .collect();
                if crossings.len() >= 8 {
                    periods.push(2.0 * (crossings[7] - crossings[1]) / 6.0);
                    // Decay of the envelope over the first two seconds.
                    let env = |a: f64, b: f64| {
                        (i..j)
                            .filter(|&k| t[k] >= a && t[k] < b)
                            .map(|k| dev[k - i].abs())
                            .fold(0.0_f64, f64::max)
                    };
                    let (e0, e1) = (env(t[i] + 0.2, t[i] + 0.7), env(t[i] + 2.2, t[i] + 2.7));
                    if e0 > 1e-7 && e1 > 0.0 {
                        decays.push((e0 / e1).ln() / 2.0);
                    }
                    // The shaft torsion rings at the same period.
                    let th_end = th[j - 1];
                    let tdev: Vec<f64> = (i..j).map(|k| th[k] - th_end).collect();
                    let n = (1..tdev.len().min(400))
                        .filter(|&k| tdev[k - 1] * tdev[k] < 0.0)
                        .count();
                    assert!(
                        n >= 12,
                        "shaft torsion rings ({n} sign changes in 4 s) at t = {}",
                        t[i]
                    );
                }
            }
            i = j;
        }
        assert!(
            periods.len() >= 10,
            "ringing found after {} accelerations",
            periods.len()
        );
        let t_d = 2.0 * std::f64::consts::PI / omega_d;
        for p in &periods {
            assert!((p - t_d).abs() < 0.01 * t_d, "period {p} vs 2π/ω_d = {t_d}");
        }
        let zeta_omega = 1900.0 / (2.0 * 1500.0);
        let mean_decay = decays.iter().sum::<f64>() / decays.len() as f64;
        assert!(
            (mean_decay - zeta_omega).abs() < 0.15 * zeta_omega,
            "decay rate {mean_decay} vs {zeta_omega}"
        );
    }
}
