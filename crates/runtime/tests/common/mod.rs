//! Hand-written [`InverseModel`]s with known answers for the driver's tests and benchmark.
//!
//! - [`SiEngine`]: the paper's SI engine + vehicle (Fröberg & Nielsen 2004, eq. 8–32) in the reduced form
//!   dv/dt = c1 v² + c2 v^1.8 + c3 p_i + c4, dp_i/dt = c5 v + c6 v p_i + c7 ṁ_at, with c1 … c7 derived from the
//!   physical parameters of `shared/reference/si_engine.md`.
//! - [`LinearR2`]: a linear system with r = 2, n = 3 and one internal coordinate, minimum phase or not.
//! - [`NanOutput`]: the SI engine with an extra output that becomes NaN above a speed.
//! - [`integrals_deviation`]: how far two runs' integrals are apart.
#![allow(dead_code)]

use std::f64::consts::PI;

use invsim_model_api::{set_param_checked, InverseModel, ModelError, ModelInfo, OutputInfo};

/// Fuel density for the volume output, kg/m³.
pub const FUEL_DENSITY: f64 = 745.0;

/// Parameter names and values of `si_engine.md` (in this order).
pub const SI_PARAMS: &[(&str, f64)] = &[
    ("m", 1300.0),
    ("C_d", 0.32),
    ("A", 2.0),
    ("c_r", 0.013),
    ("rho", 1.2),
    ("g", 9.81),
    ("r_w", 0.30),
    ("i", 5.0),
    ("eta_trm", 0.92),
    ("J_e", 0.2),
    ("V_d", 2.0e-3),
    ("B", 0.086),
    ("S", 0.086),
    ("xi_aux", 1.44),
    ("Pi_bl", 1.0),
    ("eta_th", 0.38),
    ("Q_hv", 44e6),
    ("lambda", 1.0),
    ("AFs", 14.7),
    ("R", 287.0),
    ("T_i", 300.0),
    ("V_i", 2.5e-3),
    ("p_e", 1.05e5),
    ("s_i", 0.96),
    ("y_i", 8000.0),
];

/// c1 … c7 of the reduced model from the physical parameters (in [`SI_PARAMS`] order).
///
/// Vehicle (eq. 8–13): m_eff dv/dt = (η_trm i / r_w) T_e − ½ρC_dA v² − m g c_r, m_eff = m + η_trm i² J_e / r_w².
/// Engine (eq. 14–21): T_e = BMEP V_d/(4π); FMEP contains 0.0215·BMEP, so
/// BMEP = (IMEP_g − PMEP − ξ_aux k (0.464 + 0.0072 S̄p^1.8) Π_bl 1e5) / (1 + 0.0215 ξ_aux k), k = √(0.075/B),
/// with IMEP_g = (s_i p_i − y_i) Q_hv η_th / (λ AFs R T_i) (air charge × fuel per air × heat), PMEP = p_e − p_i,
/// S̄p = S i v / (π r_w). Everything is linear in p_i, and v enters as v² and v^1.8 only.
/// Manifold: dp_i/dt = (R T_i / V_i)(ṁ_at − m_ac ω_e/(4π)), m_ac = (s_i p_i − y_i) V_d/(R T_i), ω_e = i v / r_w.
pub fn si_coefficients(p: &[f64]) -> [f64; 7] {
    let p: [f64; 25] = p.try_into().expect("25 parameters");
    let [m, c_d, a, c_r, rho, g, r_w, i, eta_trm, j_e, v_d, b, s, xi_aux, pi_bl, eta_th, q_hv, lambda, afs, r, t_i, v_i, p_e, s_i, y_i] =
        p;
    let m_eff = m + eta_trm * i * i * j_e / (r_w * r_w);
    let k = (0.075 / b).sqrt();
    let den = 1.0 + 0.0215 * xi_aux * k;
    // dv/dt contribution per Pa of BMEP.
    let k_t = (eta_trm * i / r_w) * v_d / (4.0 * PI) / m_eff / den;
    // IMEP_g per Pa of (s_i p_i − y_i).
    let imep = q_hv * eta_th / (lambda * afs * r * t_i);
    let c1 = -0.5 * rho * c_d * a / m_eff;
    let c2 = -k_t * xi_aux * k * 0.0072 * pi_bl * 1e5 * (s * i / (PI * r_w)).powf(1.8);
    let c3 = k_t * (s_i * imep + 1.0);
    let c4 = k_t * (-y_i * imep - p_e - xi_aux * k * 0.464 * pi_bl * 1e5) - g * c_r * m / m_eff;
    let pump = v_d * i / (v_i * r_w * 4.0 * PI);
    let c5 = y_i * pump;
    let c6 = -s_i * pump;
    let c7 = r * t_i / v_i;
    [c1, c2, c3, c4, c5, c6, c7]
}

/// v^e extended oddly to v < 0 (the smoother may return −1e-17 for a vehicle at rest).
fn spow(v: f64, e: f64) -> f64 {
    v.signum() * v.abs().powf(e)
}

/// The paper's SI engine + vehicle in reduced form; states (v, p_i), input ṁ_at, output v.
#[derive(Debug, Clone)]
pub struct SiEngine {
    info: ModelInfo,
    params: Vec<f64>,
    pub c: [f64; 7],
    /// 1/(λ AFs): fuel per air mass.
    fuel_per_air: f64,
    /// Evaluate v^1.8 in [`InverseModel::rhs`] as `powf`, NaN for v < 0, as generated code does.
    pub strict_domain: bool,
}

impl SiEngine {
    pub fn new() -> Self {
        let info = ModelInfo {
            name: "si_engine".into(),
            source_hash: None,
            description: String::new(),
            state_units: Vec::new(),
            input_unit: None,
            output_unit: None,
            states: vec!["v".into(), "p_i".into()],
            input: "m_at".into(),
            output: "v".into(),
            relative_degree: 2,
            n_eta: 0,
            input_min: Some(0.0),
            input_max: Some(0.08),
            outputs: vec![
                OutputInfo {
                    name: "fuel".into(),
                    unit: Some("kg/s".into()),
                    accumulate: true,
                    per_distance: true,
                },
                OutputInfo {
                    name: "fuel_l".into(),
                    unit: Some("l/s".into()),
                    accumulate: true,
                    per_distance: true,
                },
            ],
            parameters: SI_PARAMS.iter().map(|(n, _)| n.to_string()).collect(),
            ..Default::default()
        };
        let params: Vec<f64> = SI_PARAMS.iter().map(|(_, v)| *v).collect();
        let mut model = SiEngine {
            info,
            params,
            c: [0.0; 7],
            fuel_per_air: 0.0,
            strict_domain: false,
        };
        model.update();
        model
    }

    fn update(&mut self) {
        self.c = si_coefficients(&self.params);
        let param = |name: &str| {
            self.params[self
                .info
                .parameters
                .iter()
                .position(|p| p == name)
                .expect("known")]
        };
        self.fuel_per_air = 1.0 / (param("lambda") * param("AFs"));
    }

    /// x2 = p_i = (ξ2 − c1 ξ1² − c2 ξ1^1.8 − c4)/c3 (ψ⁻¹, paper eq. 30).
    pub fn p_i(&self, xi: &[f64]) -> f64 {
        let [c1, c2, c3, c4, ..] = self.c;
        (xi[1] - c1 * xi[0] * xi[0] - c2 * spow(xi[0], 1.8) - c4) / c3
    }
}

impl Default for SiEngine {
    fn default() -> Self {
        Self::new()
    }
}

impl InverseModel for SiEngine {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        &self.params
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        set_param_checked(&self.info, &mut self.params, name, value)?;
        self.update();
        Ok(())
    }
    fn h(&self, x: &[f64], _w: &[f64]) -> f64 {
        x[0]
    }
    fn psi(&self, x: &[f64], _w: &[f64], xi: &mut [f64], _eta: &mut [f64]) {
        let [c1, c2, c3, c4, ..] = self.c;
        xi[0] = x[0];
        xi[1] = c1 * x[0] * x[0] + c2 * spow(x[0], 1.8) + c3 * x[1] + c4;
    }
    fn psi_inv(
        &self,
        xi: &[f64],
        _eta: &[f64],
        _w: &[f64],
        x: &mut [f64],
    ) -> Result<(), ModelError> {
        x[0] = xi[0];
        x[1] = self.p_i(xi);
        Ok(())
    }
    /// α(ξ) = (1.8 c2 ξ1^0.8 + 2 c1 ξ1) ξ2 + c3 (c5 ξ1 + c6 ξ1 x2) (paper eq. 28).
    fn alpha(&self, xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        let [c1, c2, c3, _, c5, c6, _] = self.c;
        let x2 = self.p_i(xi);
        (1.8 * c2 * xi[0].abs().powf(0.8) + 2.0 * c1 * xi[0]) * xi[1]
            + c3 * (c5 * xi[0] + c6 * xi[0] * x2)
    }
    /// β = c3 c7 (paper eq. 28).
    fn beta(&self, _xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        self.c[2] * self.c[6]
    }
    fn zero_dynamics(&self, _xi: &[f64], _eta: &[f64], _w: &[f64], _yr: f64, _deta: &mut [f64]) {}
    /// ψ⁻¹ and u = (y^(r) − α)/β with the common subexpressions shared (one `powf`), as generated code does.
    fn invert(
        &self,
        xi: &[f64],
        _eta: &[f64],
        _w: &[f64],
        yr: f64,
        x: &mut [f64],
    ) -> Result<f64, ModelError> {
        let [c1, c2, c3, c4, c5, c6, c7] = self.c;
        let (v, dv) = (xi[0], xi[1]);
        // |v|^0.8 is d(v^1.8)/dv / 1.8 for the odd extension v^1.8 := v |v|^0.8.
        let v08 = v.abs().powf(0.8);
        let p_i = (dv - c1 * v * v - c2 * v * v08 - c4) / c3;
        x[0] = v;
        x[1] = p_i;
        let alpha = (1.8 * c2 * v08 + 2.0 * c1 * v) * dv + c3 * (c5 * v + c6 * v * p_i);
        Ok((yr - alpha) / (c3 * c7))
    }
    fn rhs(&self, x: &[f64], _w: &[f64], u: f64, dx: &mut [f64]) {
        let [c1, c2, c3, c4, c5, c6, c7] = self.c;
        let v18 = if self.strict_domain {
            x[0].powf(1.8)
        } else {
            spow(x[0], 1.8)
        };
        dx[0] = c1 * x[0] * x[0] + c2 * v18 + c3 * x[1] + c4;
        dx[1] = c5 * x[0] + c6 * x[0] * x[1] + c7 * u;
    }
    /// fuel = ṁ_at / (λ AFs) in kg/s, and its volume in l/s.
    fn outputs(&self, _x: &[f64], _w: &[f64], u: f64, out: &mut [f64]) {
        let fuel = u * self.fuel_per_air;
        out[0] = fuel;
        out[1] = fuel / FUEL_DENSITY * 1000.0;
    }
}

/// x1' = x2, x2' = −a0 x1 − a1 x2 + x3 + u, x3' = −k x3 + b x1 + c u, y = x1.
///
/// r = 2 (L_g h = 0, L_g L_f h = 1), ξ = (x1, x2), η = x3; α = −a0 ξ1 − a1 ξ2 + η, β = 1 and the zero dynamics
/// (Isidori §4.3) q = −k η + b ξ1 + c (y^(r) − α) = −(k + c) η + (b + c a0) ξ1 + c a1 ξ2 + c y^(r).
/// Transfer function (s + k + c)/((s² + a1 s + a0)(s + k) − b): minimum phase iff k + c > 0.
#[derive(Debug, Clone)]
pub struct LinearR2 {
    info: ModelInfo,
    params: [f64; 5],
}

impl LinearR2 {
    /// Parameters a0, a1, k, b, c.
    pub fn new(name: &str, [a0, a1, k, b, c]: [f64; 5]) -> Self {
        let info = ModelInfo {
            name: name.into(),
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
            outputs: vec![OutputInfo {
                name: "u2".into(),
                unit: None,
                accumulate: true,
                per_distance: true,
            }],
            parameters: ["a0", "a1", "k", "b", "c"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            ..Default::default()
        };
        LinearR2 {
            info,
            params: [a0, a1, k, b, c],
        }
    }
    /// Minimum phase: zero at −(k + c) = −1.5.
    pub fn minimum_phase() -> Self {
        Self::new("linear_mp", [2.0, 3.0, 1.0, 0.5, 0.5])
    }
    /// Non-minimum phase: zero at −(k + c) = +0.5.
    pub fn non_minimum_phase() -> Self {
        Self::new("linear_nmp", [2.0, 3.0, -1.0, 0.5, 0.5])
    }
    /// a0, a1, k, b, c.
    pub fn p(&self) -> [f64; 5] {
        self.params
    }
}

impl InverseModel for LinearR2 {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        &self.params
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        set_param_checked(&self.info, &mut self.params, name, value)
    }
    fn h(&self, x: &[f64], _w: &[f64]) -> f64 {
        x[0]
    }
    fn psi(&self, x: &[f64], _w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        xi[0] = x[0];
        xi[1] = x[1];
        eta[0] = x[2];
    }
    fn psi_inv(
        &self,
        xi: &[f64],
        eta: &[f64],
        _w: &[f64],
        x: &mut [f64],
    ) -> Result<(), ModelError> {
        x[0] = xi[0];
        x[1] = xi[1];
        x[2] = eta[0];
        Ok(())
    }
    fn alpha(&self, xi: &[f64], eta: &[f64], _w: &[f64]) -> f64 {
        let [a0, a1, ..] = self.p();
        -a0 * xi[0] - a1 * xi[1] + eta[0]
    }
    fn beta(&self, _xi: &[f64], _eta: &[f64], _w: &[f64]) -> f64 {
        1.0
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], _w: &[f64], yr: f64, deta: &mut [f64]) {
        let [_, _, k, b, c] = self.p();
        let u = (yr - self.alpha(xi, eta, &[])) / self.beta(xi, eta, &[]);
        deta[0] = -k * eta[0] + b * xi[0] + c * u;
    }
    fn rhs(&self, x: &[f64], _w: &[f64], u: f64, dx: &mut [f64]) {
        let [a0, a1, k, b, c] = self.p();
        dx[0] = x[1];
        dx[1] = -a0 * x[0] - a1 * x[1] + x[2] + u;
        dx[2] = -k * x[2] + b * x[0] + c * u;
    }
    fn outputs(&self, _x: &[f64], _w: &[f64], u: f64, out: &mut [f64]) {
        out[0] = u * u;
    }
}

/// [`SiEngine`] plus an output `bad` = √(v_max − v), NaN once the speed exceeds v_max.
#[derive(Debug, Clone)]
pub struct NanOutput {
    inner: SiEngine,
    info: ModelInfo,
    pub v_max: f64,
}

impl NanOutput {
    pub fn new(v_max: f64) -> Self {
        let inner = SiEngine::new();
        let mut info = inner.info().clone();
        info.name = "si_engine_nan".into();
        info.outputs.push(OutputInfo {
            name: "bad".into(),
            unit: None,
            accumulate: false,
            per_distance: false,
        });
        NanOutput { inner, info, v_max }
    }
}

impl InverseModel for NanOutput {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        self.inner.params()
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        self.inner.set_param(name, value)
    }
    fn h(&self, x: &[f64], w: &[f64]) -> f64 {
        self.inner.h(x, w)
    }
    fn psi(&self, x: &[f64], w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        self.inner.psi(x, w, xi, eta)
    }
    fn psi_inv(&self, xi: &[f64], eta: &[f64], w: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
        self.inner.psi_inv(xi, eta, w, x)
    }
    fn alpha(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64 {
        self.inner.alpha(xi, eta, w)
    }
    fn beta(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64 {
        self.inner.beta(xi, eta, w)
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], w: &[f64], yr: f64, deta: &mut [f64]) {
        self.inner.zero_dynamics(xi, eta, w, yr, deta)
    }
    fn rhs(&self, x: &[f64], w: &[f64], u: f64, dx: &mut [f64]) {
        self.inner.rhs(x, w, u, dx)
    }
    fn outputs(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) {
        self.inner.outputs(x, w, u, &mut out[..2]);
        out[2] = (self.v_max - x[0]).sqrt();
    }
}

/// The largest relative difference between two runs' integrals of the same names.
pub fn integrals_deviation(
    a: &std::collections::BTreeMap<String, f64>,
    b: &std::collections::BTreeMap<String, f64>,
) -> f64 {
    a.iter().fold(0.0f64, |worst, (name, x)| {
        let y = b[name];
        worst.max((x - y).abs() / x.abs().max(y.abs()).max(f64::MIN_POSITIVE))
    })
}
