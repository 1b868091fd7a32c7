//! Exogenous signals (contract §5) against independent references: the total derivatives of the derivation
//! against finite differences along random trajectories x(t), w(t); the smoothed signal and its derivatives
//! against quadrature of the convolution; `si_engine_grade` satisfying the original equations at every sample
//! (dx/dt by the chain rule through ψ⁻¹ with the signals' derivatives) and its replay; a constant signal
//! against the same model with the signal as a parameter; and the extra fuel on a constant grade against the
//! work against gravity divided by the model's own marginal efficiency.

use invsim_expr::{Id, Symbol, Tape};
use invsim_inversion::{derive_file, Derivation, Interpreter, Model, Solution};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, Kernel, SignalInput, SignalValue, SimulationOptions};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn grade_model() -> Derivation {
    derive_file(&root().join("models/si_engine_grade.toml")).unwrap()
}

/// A model whose output itself depends on a signal (h = x1 + S²) and whose right-hand side depends on S
/// nonlinearly, so that every derivative order of S appears in the Lie derivatives.
const SIGNAL_IN_H: &str = r#"
[parameters]
c = 0.7
[signals]
S = 0.1
[states]
x1 = { rhs = "x2 + sin(S)*x1" }
x2 = { rhs = "-c*x1*S^2 + exp(S)*u" }
[input]
name = "u"
[output]
name = "y"
h = "x1 + S^2"
"#;

/// D e along the straight trajectory (x + t·v, w + t·ẇ) by central differences of e, where v = f + g·u and ẇ
/// shifts each signal's chain (S_dk)' = S_d(k+1): the definition of the total derivative.
fn fd_total_derivative(d: &Derivation, e: Id, at: &HashMap<Symbol, f64>, u: f64) -> f64 {
    let pool = d.pool();
    let m = &d.model;
    let mut tangent: HashMap<Symbol, f64> = HashMap::new();
    let mut values = at.clone();
    values.insert(m.input.symbol, u);
    for s in &m.states {
        tangent.insert(s.symbol, pool.eval(s.rhs, &values).unwrap());
    }
    for s in &m.signals {
        for k in 0..=d.n() {
            let name = |k: usize| {
                if k == 0 {
                    s.name.clone()
                } else {
                    format!("{}_d{k}", s.name)
                }
            };
            let (Some(a), Some(b)) = (pool.find_symbol(&name(k)), pool.find_symbol(&name(k + 1)))
            else {
                continue;
            };
            tangent.insert(a, at[&b]);
        }
    }
    let h = 1e-6;
    let shifted = |sign: f64| {
        let mut p = at.clone();
        for (s, v) in &tangent {
            *p.get_mut(s).unwrap() += sign * h * v;
        }
        pool.eval(e, &p).unwrap()
    };
    (shifted(1.0) - shifted(-1.0)) / (2.0 * h)
}

#[test]
fn total_derivatives_match_finite_differences_along_random_trajectories() {
    let models = [
        grade_model(),
        Derivation::new(Model::from_str(Path::new("signal_in_h.toml"), SIGNAL_IN_H).unwrap())
            .unwrap(),
    ];
    let mut rng = StdRng::seed_from_u64(0x51_6A);
    for d in &models {
        let m = &d.model;
        let r = d.relative_degree;
        let mut checked = 0;
        for _ in 0..200 {
            let mut at: HashMap<Symbol, f64> =
                m.parameters.iter().map(|p| (p.symbol, p.value)).collect();
            // States in a physical range (si_engine_grade: speed 1–40 m/s, pressure 0.3–1 bar).
            for (j, s) in m.states.iter().enumerate() {
                let v = if m.name == "si_engine_grade" && j == 1 {
                    rng.gen_range(3e4..1e5)
                } else {
                    rng.gen_range(1.0..40.0)
                        / if m.name == "si_engine_grade" {
                            1.0
                        } else {
                            20.0
                        }
                };
                at.insert(s.symbol, v);
            }
            for s in &m.signals {
                let scale = if s.name == "P_aux" { 1000.0 } else { 0.1 };
                for k in 0..=d.n() + 1 {
                    let name = if k == 0 {
                        s.name.clone()
                    } else {
                        format!("{}_d{k}", s.name)
                    };
                    if let Some(sym) = d.pool().find_symbol(&name) {
                        at.insert(sym, scale * rng.gen_range(-1.0..1.0));
                    }
                }
            }
            let u = rng.gen_range(-1.0..1.0)
                * if m.name == "si_engine_grade" {
                    0.03
                } else {
                    1.0
                };
            // d/dt D^(k−1) h = D^k h (u = 0 part) + L_g D^(k−1) h · u, k = 1 … r.
            for k in 1..=r {
                let mut values = at.clone();
                values.insert(m.input.symbol, u);
                let symbolic = d.pool().eval(d.lie[k], &values).unwrap()
                    + d.pool().eval(d.lg_lie[k - 1], &values).unwrap() * u;
                let fd = fd_total_derivative(d, d.lie[k - 1], &at, u);
                let scale = symbolic.abs().max(fd.abs()).max(1e-3);
                assert!(
                    (symbolic - fd).abs() / scale < 1e-5,
                    "{}: k = {k}: symbolic {symbolic} vs finite difference {fd}",
                    m.name
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 200 * r);
    }
    // Every derivative order of the signal reaches the output's derivatives when h depends on S.
    let lie1 = models[1].pool().display(models[1].lie[2]);
    assert!(lie1.contains("S_d2") && lie1.contains("S_d1"), "{lie1}");
}

/// NEDC with a grade column: a hilly profile between −4 % and +5 %, piecewise linear at 1 Hz.
fn hilly_nedc() -> Cycle {
    let mut c = Cycle::builtin("nedc").unwrap();
    let grade: Vec<f64> = c
        .time
        .iter()
        .map(|&t| 0.045 * (t / 97.0).sin() + 0.005 * (t / 13.0).cos())
        .collect();
    c.grade = Some(grade);
    c
}

fn run(
    model: &dyn InverseModel,
    cycle: &Cycle,
    dt: f64,
    signals: Vec<SignalInput>,
) -> invsim_runtime::SimulationResult {
    let opts = SimulationOptions {
        dt,
        verify: true,
        signals,
        engine: "interpreted".into(),
        ..SimulationOptions::default()
    };
    simulate(model, cycle, &opts).unwrap()
}

#[test]
fn smoothed_signal_and_derivatives_match_quadrature_of_the_convolution() {
    let d = grade_model();
    let interp = Interpreter::new(&d).unwrap();
    let cycle = hilly_nedc();
    let res = run(&interp, &cycle, 0.5, Vec::new());
    let kernel = Kernel::new(5.0);
    let raw = |t: f64| {
        let g = cycle.grade.as_ref().unwrap();
        let i = cycle
            .time
            .partition_point(|&x| x <= t)
            .clamp(1, cycle.time.len() - 1);
        let (t0, t1) = (cycle.time[i - 1], cycle.time[i]);
        let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        g[i - 1] + s * (g[i] - g[i - 1])
    };
    let time = res.time();
    let cols: Vec<&[f64]> = ["grade", "grade_d1", "grade_d2"]
        .iter()
        .map(|c| res.column(c).unwrap())
        .collect();
    let peak: Vec<f64> = cols
        .iter()
        .map(|c| c.iter().fold(0.0f64, |m, v| m.max(v.abs())))
        .collect();
    // S^(k)(t) = ∫ k^(k)(σ) S_c(t − σ) dσ over σ ∈ [−a, a], Simpson's rule on 4000 intervals.
    for idx in (0..time.len()).step_by(97) {
        let t = time[idx];
        for (k, col) in cols.iter().enumerate() {
            let n = 4000;
            let h = 10.0 / n as f64;
            let mut sum = 0.0;
            for i in 0..=n {
                let s = -5.0 + i as f64 * h;
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                sum += w * kernel.derivative(k, s) * raw(t - s);
            }
            let q = sum * h / 3.0;
            let tol = 1e-7 * peak[k];
            assert!(
                (col[idx] - q).abs() < tol,
                "t = {t}, order {k}: {} vs quadrature {q}",
                col[idx]
            );
        }
    }
}

/// ∂ψ⁻¹/∂(ξ, w) compiled over (ξ, η, w, params); ψ⁻¹ must be closed-form.
fn psi_inv_jacobian(d: &Derivation) -> Tape {
    let mut pool = d.pool().clone();
    let coords: Vec<Symbol> = d.xi.iter().chain(&d.w).copied().collect();
    let mut exprs = Vec::new();
    for sol in &d.psi_inv {
        let Solution::Closed(e) = sol else {
            panic!("closed-form ψ⁻¹ expected")
        };
        for &c in &coords {
            exprs.push(pool.diff(*e, c));
        }
    }
    let inputs: Vec<Symbol> =
        d.xi.iter()
            .chain(&d.eta)
            .chain(&d.w)
            .copied()
            .chain(d.model.parameters.iter().map(|p| p.symbol))
            .collect();
    let values: Vec<f64> = d.model.parameters.iter().map(|p| p.value).collect();
    Tape::compile(&pool, &exprs, &inputs)
        .unwrap()
        .specialize(&values)
}

#[test]
fn si_engine_grade_inverse_satisfies_the_original_equations_and_replays() {
    let d = grade_model();
    let interp = Interpreter::new(&d).unwrap();
    let cycle = hilly_nedc();
    let res = run(&interp, &cycle, 0.01, Vec::new());
    let (r, n, nw) = (d.relative_degree, d.n(), d.w.len());
    assert_eq!((r, n, nw), (2, 2, 6));
    let jac = psi_inv_jacobian(&d);
    let ncoord = r + nw;
    let yd: Vec<&[f64]> = (0..=r).map(|k| res.yd(k).unwrap()).collect();
    let names = [
        "grade", "grade_d1", "grade_d2", "P_aux", "P_aux_d1", "P_aux_d2",
    ];
    let w: Vec<&[f64]> = names.iter().map(|c| res.column(c).unwrap()).collect();
    let u = res.input();
    let xs: Vec<&[f64]> = d
        .model
        .states
        .iter()
        .map(|s| res.column(&s.name).unwrap())
        .collect();
    let mut j = vec![0.0; n * ncoord];
    let (mut dx, mut f) = (vec![0.0; n], vec![0.0; n]);
    let mut rows = Vec::new();
    let mut peak = vec![0.0f64; n];
    for k in 0..res.len() {
        let xi: Vec<f64> = (0..r).map(|i| yd[i][k]).collect();
        let wk: Vec<f64> = w.iter().map(|c| c[k]).collect();
        let x: Vec<f64> = xs.iter().map(|c| c[k]).collect();
        jac.eval_parts(&[&xi, &wk], &mut j);
        interp.rhs(&x, &wk, u[k], &mut dx);
        interp.rhs(&x, &wk, 0.0, &mut f);
        let row: Vec<(f64, f64, f64)> = (0..n)
            .map(|s| {
                // dx_s/dt = Σ_i ∂ψ⁻¹_s/∂ξ_i · y_d^(i+1) + Σ_(S,k) ∂ψ⁻¹_s/∂S_dk · S_d(k+1).
                let mut chain: f64 = (0..r).map(|i| j[s * ncoord + i] * yd[i + 1][k]).sum();
                for sig in 0..2 {
                    for kk in 0..=r {
                        let dpsi = j[s * ncoord + r + sig * (r + 1) + kk];
                        if kk == r {
                            assert_eq!(dpsi, 0.0, "ψ⁻¹ depends on the highest signal derivative");
                        } else {
                            chain += dpsi * w[sig * (r + 1) + kk + 1][k];
                        }
                    }
                }
                let magnitude = f[s].abs() + (dx[s] - f[s]).abs();
                peak[s] = peak[s].max(magnitude);
                (chain, dx[s], magnitude)
            })
            .collect();
        rows.push(row);
    }
    let mut worst = 0.0f64;
    for row in &rows {
        for (s, &(chain, rhs, magnitude)) in row.iter().enumerate() {
            worst = worst.max((chain - rhs).abs() / magnitude.max(1e-6 * peak[s]));
        }
    }
    assert!(worst < 1e-8, "worst relative residual {worst:e}");
    // The open-loop replay with the smoothed signal tracks y_d within the bound without grade (README: below
    // 1e-4 m/s for si_engine at dt = 0.01 s).
    let replay = res.summary.max_abs_tracking_error.unwrap();
    assert!(replay < 1e-4, "replay error {replay:e}");
}

/// si_engine_grade with `grade` as a parameter of value `g` instead of a signal.
fn grade_as_parameter(g: f64) -> Derivation {
    let text = std::fs::read_to_string(root().join("models/si_engine_grade.toml")).unwrap();
    let text = text
        .replace(
            "grade = { default = 0.0, column = \"grade\", unit = \"-\", doc = \"road grade, rise over run\" }\n",
            "",
        )
        .replace("[parameters]\n", &format!("[parameters]\ngrade = {g}\n"));
    assert!(!text.contains("column = \"grade\""));
    Derivation::new(Model::from_str(Path::new("grade_parameter.toml"), &text).unwrap()).unwrap()
}

#[test]
fn a_constant_signal_equals_the_parameter_version() {
    let cycle = Cycle::builtin("nedc").unwrap();
    let signal = Interpreter::new(&grade_model()).unwrap();
    let param = Interpreter::new(&grade_as_parameter(0.02)).unwrap();
    let constant = vec![SignalInput {
        name: "grade".into(),
        value: SignalValue::Constant(0.02),
    }];
    let a = run(&signal, &cycle, 0.1, constant);
    let b = run(&param, &cycle, 0.1, Vec::new());
    for col in ["m_at", "v", "p_i", "fuel"] {
        let (x, y) = (a.column(col).unwrap(), b.column(col).unwrap());
        for (p, q) in x.iter().zip(y) {
            assert!(
                (p - q).abs() <= 1e-12 * (1.0 + q.abs()),
                "{col}: {p} vs {q}"
            );
        }
    }
    let (fa, fb) = (
        a.summary.totals.integrals["fuel"],
        b.summary.totals.integrals["fuel"],
    );
    assert!((fa - fb).abs() <= 1e-12 * fb, "{fa} vs {fb}");
}

/// The extra fuel on a constant grade, against the work against gravity m·g·Δh divided by the model's own
/// marginal efficiency.
///
/// How the marginal efficiency follows from the model's equations: at a given speed (fixed by the reference,
/// so w_e is fixed) the fuel flow is ṁ_f = m_fc·w_e/(4π) with m_fc = (s_i p_i − y_i) V_d/(R_a T_i λ AFs), and
/// the power at the wheels is P_w = η_trm·T_e·w_e with T_e = BMEP·V_d/(4π) affine in p_i
/// (∂BMEP/∂p_i = (s_i Q_hv η_th/(R_a T_i λ AFs) + 1)/(1 + 0.0215 ξ_aux √(0.075/B)): IMEP_g and −PMEP). Both are
/// affine in p_i, so dṁ_f/dP_w = (∂m_fc/∂p_i)/(4π η_trm ∂T_e/∂p_i) is one constant: the inverse of the
/// marginal efficiency times Q_hv. The extra wheel work on the grade is ΔE = m g (sin θ·D + c_r (cos θ − 1)·D)
/// with tan θ = grade and D the reference's distance ∫ y_d dt (the climbing force m g sin θ and the change of
/// the rolling resistance m g c_r cos θ). The fuel compared is ∫ m_at/(λ AFs) dt, the unclipped flow (the
/// `fuel` output cuts the flow off where the inverse brakes); the clipped `fuel` is checked to rise and fall.
#[test]
fn fuel_on_a_grade_matches_the_work_against_gravity() {
    let d = grade_model();
    let p: HashMap<&str, f64> = d
        .model
        .parameters
        .iter()
        .map(|p| (p.name.as_str(), p.value))
        .collect();
    let interp = Interpreter::new(&d).unwrap();
    let cycle = Cycle::builtin("nedc").unwrap();
    let dm_fc = p["s_i"] * p["V_d"] / (p["R_a"] * p["T_i"] * p["lambda"] * p["AFs"]);
    let k_b = (0.075 / p["B"]).sqrt();
    let dbmep =
        (dm_fc * p["Q_hv"] * p["eta_th"] / p["V_d"] + 1.0) / (1.0 + 0.0215 * p["xi_aux"] * k_b);
    let dte = dbmep * p["V_d"] / (4.0 * std::f64::consts::PI);
    let dfuel_dwork = dm_fc / (4.0 * std::f64::consts::PI * p["eta_trm"] * dte);
    let marginal_efficiency = 1.0 / (dfuel_dwork * p["Q_hv"]);
    assert!(
        (0.2..0.5).contains(&marginal_efficiency),
        "{marginal_efficiency}"
    );
    let flow = |grade: f64| {
        let given = vec![SignalInput {
            name: "grade".into(),
            value: SignalValue::Constant(grade),
        }];
        let res = run(&interp, &cycle, 0.1, given);
        let u = res.input();
        let dt = 0.1;
        let air: f64 = u.windows(2).map(|w| 0.5 * dt * (w[0] + w[1])).sum();
        let distance: f64 = res
            .yd(0)
            .unwrap()
            .windows(2)
            .map(|w| 0.5 * dt * (w[0] + w[1]))
            .sum();
        (
            air / (p["lambda"] * p["AFs"]),
            res.summary.totals.integrals["fuel"],
            distance,
        )
    };
    let (flat, flat_clipped, distance) = flow(0.0);
    for grade in [0.02, -0.02] {
        let (fuel, clipped, _) = flow(grade);
        let theta = f64::atan(grade);
        let work = p["m"] * p["g_0"] * distance * (theta.sin() + p["c_r"] * (theta.cos() - 1.0));
        let expected = work * dfuel_dwork;
        let got = fuel - flat;
        eprintln!(
            "grade {grade}: extra fuel {got:.6} kg, m g Δh/(η_m Q_hv) = {expected:.6} kg (η_m = {marginal_efficiency:.4})"
        );
        assert!(
            (got - expected).abs() < 1e-3 * expected.abs(),
            "grade {grade}: extra fuel {got} kg vs m g Δh / (η Q_hv) = {expected} kg"
        );
        assert_eq!(
            clipped > flat_clipped,
            grade > 0.0,
            "clipped fuel {clipped} vs {flat_clipped}"
        );
    }
}
