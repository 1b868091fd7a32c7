//! Generated code, compiled, agrees with the interpreter tape: every `InverseModel` method of every loadable
//! model (`models/` via `invsim-models`, `../shared/models` and `tests/models` via this crate's build script)
//! at 1 000 random points, within 1e-12 relative — the per-point methods, and the batch methods
//! (`invert_batch`, `outputs_batch`) on the same points as columns, whole and in a block of odd length; the
//! sensitivities' partial derivatives as terms of each row's differential (`sensitivity_disagreements`), and
//! `sensitivity_batch` against each engine's per-point `sensitivity` the same way.

use invsim_inversion::Interpreter;
use invsim_model_api::{InverseModel, ModelError, SensitivityLayout};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const POINTS: usize = 1000;
const REL: f64 = 1e-12;
/// The sensitivities' bound relative to their rows' scale (`sensitivity_disagreements`): a derivative that is
/// exactly 0 is a sum of terms that cancel, each engine leaving a few ulps of them (1.1e-12 of the row's value
/// in the Fusion's idle mode), and the row's value can be smaller than those terms.
const SENS_REL: f64 = 4e-12;

/// Sampling box of one model: ranges for the states, the input, ξ, η and y^(r).
struct Box_ {
    x: Vec<(f64, f64)>,
    u: (f64, f64),
    xi: Vec<(f64, f64)>,
    eta: Vec<(f64, f64)>,
    yr: (f64, f64),
}

/// Physically sensible ranges per model; [-2, 2] for anything not listed.
fn sampling_box(m: &dyn InverseModel) -> Box_ {
    let info = m.info();
    let (n, r) = (info.n_states(), info.relative_degree);
    let mut b = Box_ {
        x: vec![(-2.0, 2.0); n],
        u: (-2.0, 2.0),
        xi: vec![(-2.0, 2.0); r],
        eta: vec![(-2.0, 2.0); n - r],
        yr: (-3.0, 3.0),
    };
    match info.name.as_str() {
        "si_engine" => {
            // v in m/s, p_i in Pa (manifold pressure between part load and ambient), m_at in kg/s; ξ1 = v,
            // ξ2 = dv/dt in m/s², y^(r) = d²v/dt² in m/s³.
            b.x = vec![(0.0, 40.0), (2.0e4, 1.0e5)];
            b.u = (0.0, 0.08);
            b.xi = vec![(0.0, 40.0), (-3.0, 3.0)];
            b.yr = (-2.0, 2.0);
        }
        // Pressures in Pa above ambient (the turbine and compressor laws need p > p_amb), turbocharger speed in
        // rad/s, VGT position in [0.2, 1]; ξ2 = dp_im/dt in Pa/s, y^(r) in Pa/s² (and the test model with its
        // flows accumulated).
        "diesel_gasflow" | "diesel_gasflow_flows" => {
            b.x = vec![(1.1e5, 3.0e5), (1.2e5, 4.0e5), (3.0e3, 1.5e4)];
            b.u = (0.2, 1.0);
            b.xi = vec![(1.1e5, 3.0e5), (-2.0e5, 2.0e5)];
            b.eta = vec![(1.2e5, 4.0e5)];
            b.yr = (-1.0e6, 1.0e6);
        }
        // Every mode of si_engine_5speed: v and p_i as for si_engine, the free input within its bounds
        // (throttle air flow or brake force), ξ1 = v, ξ2 = dv/dt (drive), η = p_i (brake and idle modes).
        "si_engine_5speed" => {
            b.x = vec![(0.0, 40.0), (2.0e4, 1.0e5)];
            b.u = (info.input_min.unwrap_or(0.0), info.input_max.unwrap_or(1.0));
            b.xi = [(0.0, 40.0), (-3.0, 3.0)][..r].to_vec();
            b.eta = vec![(2.0e4, 1.0e5); n - r];
            b.yr = (-2.0, 2.0);
        }
        // Fractional and negative powers of v need v > 0.
        "function_zoo" => {
            b.x[0] = (0.1, 3.0);
            b.xi[0] = (0.1, 3.0);
        }
        _ => {}
    }
    b
}

fn sample(rng: &mut StdRng, ranges: &[(f64, f64)]) -> Vec<f64> {
    ranges
        .iter()
        .map(|&(lo, hi)| rng.gen_range(lo..=hi))
        .collect()
}

/// What a comparison found.
struct Stats {
    /// Largest |a − b| / max(|a|, |b|, S).
    worst: f64,
    compared: usize,
    /// Pairs where both sides are NaN (outside a function's domain).
    nan: usize,
    /// Pairs that are bitwise equal.
    equal: usize,
}

/// Values of each quantity (interpreter, compiled) over all points.
#[derive(Default)]
struct Compare {
    pairs: BTreeMap<String, Vec<(f64, f64)>>,
    /// Points where exactly one side reported an error.
    mismatched_errors: Vec<String>,
}

impl Compare {
    fn add(&mut self, what: &str, a: &[f64], b: &[f64]) {
        assert_eq!(a.len(), b.len(), "{what}: lengths differ");
        for (i, (&x, &y)) in a.iter().zip(b).enumerate() {
            self.pairs
                .entry(format!("{what}[{i}]"))
                .or_default()
                .push((x, y));
        }
    }

    /// Check every pair: |a − b| ≤ 1e-12 · max(|a|, |b|, S), S the largest |a| of that quantity over the
    /// sample. The floor S: near a zero of a quantity its value comes from cancellation of terms about as
    /// large as the quantity gets elsewhere in the box, so both implementations carry rounding errors of
    /// order ε·S there, not ε·|value| (the generated code hoists parameter-only subexpressions and groups
    /// parameter-only factors first, which reorders roundings at that level). Away from zeros the bound is
    /// the plain 1e-12 relative one. Both NaN (a point outside a function's domain) counts as agreement.
    fn check(&self, model: &str) -> Result<Stats, String> {
        let mut worst = 0.0_f64;
        let (mut compared, mut nan, mut equal) = (0, 0, 0);
        let mut failures = Vec::new();
        for (what, pairs) in &self.pairs {
            let scale = pairs
                .iter()
                .map(|p| p.0.abs())
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
            for (k, &(a, b)) in pairs.iter().enumerate() {
                compared += 1;
                if a.is_nan() && b.is_nan() {
                    nan += 1;
                    continue;
                }
                if a == b {
                    equal += 1;
                    continue;
                }
                let bound = REL * a.abs().max(b.abs()).max(scale);
                let diff = (a - b).abs();
                // NaN on one side only fails too.
                if diff.is_nan() || diff > bound {
                    failures.push(format!(
                        "{what} at point {k}: interpreter {a:e}, compiled {b:e}"
                    ));
                }
                if bound > 0.0 && diff.is_finite() {
                    worst = worst.max(diff / bound * REL);
                }
            }
        }
        failures.extend(self.mismatched_errors.iter().cloned());
        if failures.is_empty() {
            Ok(Stats {
                worst,
                compared,
                nan,
                equal,
            })
        } else {
            let n = failures.len();
            failures.truncate(10);
            Err(format!(
                "{model}: {n} disagreements, e.g.\n  {}",
                failures.join("\n  ")
            ))
        }
    }
}

/// The sampled points as columns, for the batch methods.
#[derive(Default)]
struct Columns {
    x: Vec<Vec<f64>>,
    u: Vec<f64>,
    xi: Vec<Vec<f64>>,
    eta: Vec<Vec<f64>>,
    yr: Vec<f64>,
}

impl Columns {
    fn new(n: usize, r: usize, ne: usize) -> Columns {
        Columns {
            x: vec![Vec::new(); n],
            xi: vec![Vec::new(); r],
            eta: vec![Vec::new(); ne],
            ..Columns::default()
        }
    }

    fn push(&mut self, x: &[f64], u: f64, xi: &[f64], eta: &[f64], yr: f64) {
        let add = |cols: &mut Vec<Vec<f64>>, v: &[f64]| {
            cols.iter_mut().zip(v).for_each(|(c, &v)| c.push(v));
        };
        add(&mut self.x, x);
        add(&mut self.xi, xi);
        add(&mut self.eta, eta);
        self.u.push(u);
        self.yr.push(yr);
    }
}

/// `invert_batch` (states then u, or the first failing point) and `outputs_batch` over the first `len` points
/// of `c`, Newton's method (where ψ⁻¹ needs it) starting from x = 1 at the first point.
#[allow(clippy::type_complexity)]
fn batch(
    m: &dyn InverseModel,
    c: &Columns,
    len: usize,
    n_out: usize,
) -> (Result<Vec<Vec<f64>>, usize>, Vec<Vec<f64>>) {
    let cut =
        |cols: &[Vec<f64>]| -> Vec<Vec<f64>> { cols.iter().map(|v| v[..len].to_vec()).collect() };
    let (xi, eta) = (cut(&c.xi), cut(&c.eta));
    let xi: Vec<&[f64]> = xi.iter().map(|v| &v[..]).collect();
    let eta: Vec<&[f64]> = eta.iter().map(|v| &v[..]).collect();
    let mut states = vec![vec![1.0; len]; c.x.len()];
    let mut u = vec![0.0; len];
    // The signals at their nominal values at every point.
    let w_cols: Vec<Vec<f64>> = m.info().nominal_w().iter().map(|&v| vec![v; len]).collect();
    let w: Vec<&[f64]> = w_cols.iter().map(|v| &v[..]).collect();
    let inverse = {
        let mut x: Vec<&mut [f64]> = states.iter_mut().map(|v| &mut v[..]).collect();
        m.invert_batch(&xi, &eta, &w, &c.yr[..len], &mut x, &mut u)
    };
    let inverse = inverse.map(|()| {
        states.push(u);
        states
    });
    let x = cut(&c.x);
    let x: Vec<&[f64]> = x.iter().map(|v| &v[..]).collect();
    let mut out = vec![vec![0.0; len]; n_out];
    {
        let mut o: Vec<&mut [f64]> = out.iter_mut().map(|v| &mut v[..]).collect();
        m.outputs_batch(&x, &w, &c.u[..len], &mut o);
    }
    (inverse.map_err(|(k, _)| k), out)
}

/// `sensitivity_batch` over the first `len` points of `c` (the signals at their nominal values), entry e of
/// point k at `[e][k]`.
fn sensitivity_batch(m: &dyn InverseModel, c: &Columns, len: usize) -> Vec<Vec<f64>> {
    sensitivity_batch_of(m, c, len, &|_| true)
}

/// [`sensitivity_batch`] asking for the entries `want` marks alone (the others empty columns).
fn sensitivity_batch_of(
    m: &dyn InverseModel,
    c: &Columns,
    len: usize,
    want: &dyn Fn(usize) -> bool,
) -> Vec<Vec<f64>> {
    let x: Vec<&[f64]> = c.x.iter().map(|v| &v[..len]).collect();
    let w_cols: Vec<Vec<f64>> = m.info().nominal_w().iter().map(|&v| vec![v; len]).collect();
    let w: Vec<&[f64]> = w_cols.iter().map(|v| &v[..]).collect();
    let entries = SensitivityLayout::of(m.info()).len();
    let mut out: Vec<Vec<f64>> = (0..entries)
        .map(|e| vec![f64::NAN; if want(e) { len } else { 0 }])
        .collect();
    let mut o: Vec<&mut [f64]> = out.iter_mut().map(|v| &mut v[..]).collect();
    m.sensitivity_batch(&x, &w, &c.u[..len], (&mut o, true))
        .expect("both engines provide sensitivities");
    out
}

/// The magnitude of each column of the sensitivities' layout: the sampling box's largest |x_j| and |u|, each
/// parameter's |value| (1 where 0), each map call's |value| at the arguments the interpreter's sensitivities
/// `sens` give (1 where 0), each signal's nominal |value| (1 where 0).
fn variable_scales(b: &Box_, m: &dyn InverseModel, sens: &[f64]) -> Vec<f64> {
    let big = |(lo, hi): (f64, f64)| f64::max(lo.abs(), hi.abs()).max(f64::MIN_POSITIVE);
    let one_if_zero = |v: f64| if v == 0.0 { 1.0 } else { v.abs() };
    let mut s: Vec<f64> = b.x.iter().map(|&r| big(r)).collect();
    s.push(big(b.u));
    s.extend(m.params().iter().map(|&p| one_if_zero(p)));
    let l = SensitivityLayout::of(m.info());
    s.extend(m.info().map_calls.iter().enumerate().map(|(c, call)| {
        let at = l.arguments(c);
        one_if_zero(m.maps()[call.map].partial(&sens[at..at + 2], call.orders))
    }));
    let (w, per) = (m.info().nominal_w(), m.info().relative_degree + 1);
    s.extend((0..l.n_signals).map(|j| one_if_zero(w.get(j * per).copied().unwrap_or(0.0))));
    s
}

/// The value of each row's function of the sensitivities' layout at (x, u): ψ_1 … ψ_r, y^(r) (the box's
/// largest |y^(r)|: φ is not a method of its own), the internal states' right-hand sides, the outputs.
fn row_values(m: &dyn InverseModel, (x, u): (&[f64], f64), yr: (f64, f64)) -> Vec<f64> {
    let info = m.info();
    let w = info.nominal_w();
    let (mut xi, mut eta) = (vec![0.0; info.relative_degree], vec![0.0; info.n_eta]);
    m.psi(x, &w, &mut xi, &mut eta);
    let mut dx = vec![0.0; info.n_states()];
    m.rhs(x, &w, u, &mut dx);
    let mut out = vec![0.0; info.outputs.len()];
    m.outputs(x, &w, u, &mut out);
    let mut v = xi;
    v.push(yr.0.abs().max(yr.1.abs()));
    v.extend(info.eta_states.iter().map(|&s| dx[s]));
    v.extend(out);
    v.iter().map(|f| f.abs()).collect()
}

/// The sensitivities' entries (interpreter `a`, compiled `g`) that disagree. An entry ∂f/∂z is compared as the
/// term ∂f/∂z·|z| of the row's differential df = Σ ∂f/∂z dz (z at its scale), against the row's largest such
/// term T and the row's value |f|: |Δ|·|z| ≤ 4e-12·max(|∂f/∂z|·|z|, T, |f|) ([`SENS_REL`]). A partial derivative is a sum of
/// products whose terms cancel (the product rule), so each engine's rounding is of order ε·T or ε·|f|, not
/// ε·|∂f/∂z| (a derivative that is exactly 0 comes out 1e-24 in one engine and 0 in the other); both NaN
/// agree.
fn sensitivity_disagreements(
    l: &SensitivityLayout,
    (scales, values): (&[f64], &[f64]),
    (a, g): (&[f64], &[f64]),
) -> Vec<String> {
    let mut bad = Vec::new();
    for row in 0..l.rows() {
        let term = |v: &[f64], c: usize| v[l.at(row, c)].abs() * scales[c];
        let t = (0..l.width())
            .map(|c| term(a, c))
            .filter(|v| v.is_finite())
            .fold(values[row], f64::max);
        for c in 0..l.width() {
            let (x, y) = (a[l.at(row, c)], g[l.at(row, c)]);
            if (x.is_nan() && y.is_nan()) || x == y {
                continue;
            }
            let diff = (x - y).abs() * scales[c];
            if diff.is_nan() || diff > SENS_REL * term(a, c).max(term(g, c)).max(t) {
                bad.push(format!(
                    "row {row} column {c}: interpreter {x:e}, compiled {y:e} (row scale {t:e}, column \
                     scale {:e})",
                    scales[c]
                ));
            }
        }
    }
    bad
}

fn compare(name: &str, file: &Path, compiled: &mut dyn InverseModel) -> Stats {
    let d = invsim_inversion::derive_file(file).unwrap_or_else(|e| panic!("{name}: {e}"));
    compare_derived(name, &d, compiled)
}

/// [`compare`] against the interpreter of the derivation `d`.
fn compare_derived(
    name: &str,
    d: &invsim_inversion::Derivation,
    compiled: &mut dyn InverseModel,
) -> Stats {
    let mut interp = Interpreter::new(d).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(compiled.info(), interp.info(), "{name}: ModelInfo");
    assert_eq!(
        compiled.params(),
        interp.params(),
        "{name}: parameter values"
    );
    assert_eq!(
        compiled.reference(),
        interp.reference(),
        "{name}: reference map"
    );
    let info = interp.info().clone();
    let (n, r, ne, no) = (
        info.n_states(),
        info.relative_degree,
        info.n_eta,
        info.outputs.len(),
    );
    let b = sampling_box(&interp);
    let mut rng = StdRng::seed_from_u64(0x1CE_C0DE);
    let mut c = Compare::default();
    let run = |c: &mut Compare,
               rng: &mut StdRng,
               compiled: &dyn InverseModel,
               interp: &dyn InverseModel,
               tag: &str| {
        let mut columns = Columns::new(n, r, ne);
        for k in 0..POINTS {
            let x = sample(rng, &b.x);
            let u = rng.gen_range(b.u.0..=b.u.1);
            let xi = sample(rng, &b.xi);
            let eta = sample(rng, &b.eta);
            let yr = rng.gen_range(b.yr.0..=b.yr.1);
            columns.push(&x, u, &xi, &eta, yr);
            let both = |f: &dyn Fn(&dyn InverseModel) -> Vec<f64>| (f(interp), f(compiled));

            let (a, g) = both(&|m| vec![m.h(&x, &m.info().nominal_w())]);
            c.add(&format!("{tag}h"), &a, &g);
            let (a, g) = both(&|m| {
                let (mut s, mut e) = (vec![0.0; r], vec![0.0; ne]);
                m.psi(&x, &m.info().nominal_w(), &mut s, &mut e);
                s.extend(e);
                s
            });
            c.add(&format!("{tag}psi"), &a, &g);
            let (a, g) = both(&|m| {
                let mut dx = vec![0.0; n];
                m.rhs(&x, &m.info().nominal_w(), u, &mut dx);
                dx
            });
            c.add(&format!("{tag}rhs"), &a, &g);
            let (a, g) = both(&|m| {
                let mut out = vec![0.0; no];
                m.outputs(&x, &m.info().nominal_w(), u, &mut out);
                out
            });
            c.add(&format!("{tag}outputs"), &a, &g);
            let (a, g) = both(&|m| {
                let mut s = vec![0.0; SensitivityLayout::of(m.info()).len()];
                m.sensitivity(&x, &m.info().nominal_w(), u, &mut s)
                    .expect("both engines provide sensitivities");
                s
            });
            let scales = variable_scales(&b, interp, &a);
            let layout = SensitivityLayout::of(&info);
            let rows_end = layout.rows() * layout.width();
            c.add(
                &format!("{tag}map_call_arguments"),
                &a[rows_end..],
                &g[rows_end..],
            );
            let values = row_values(interp, (&x, u), b.yr);
            let bad = sensitivity_disagreements(&layout, (&scales, &values), (&a, &g));
            c.mismatched_errors.extend(
                bad.into_iter()
                    .map(|e| format!("{tag}sensitivity at point {k}: {e}")),
            );
            let (a, g) = both(&|m| {
                vec![
                    m.alpha(&xi, &eta, &m.info().nominal_w()),
                    m.beta(&xi, &eta, &m.info().nominal_w()),
                ]
            });
            c.add(&format!("{tag}alpha_beta"), &a, &g);
            let (a, g) = both(&|m| {
                let mut q = vec![0.0; ne];
                m.zero_dynamics(&xi, &eta, &m.info().nominal_w(), yr, &mut q);
                q
            });
            c.add(&format!("{tag}zero_dynamics"), &a, &g);
            // ψ⁻¹ and the fused inverse, from the same guess (used only by Newton's method).
            let solve = |m: &dyn InverseModel| {
                let mut xs = vec![1.0; n];
                let p = m
                    .psi_inv(&xi, &eta, &m.info().nominal_w(), &mut xs)
                    .map(|()| xs);
                let mut xs2 = vec![1.0; n];
                let q = m
                    .invert(&xi, &eta, &m.info().nominal_w(), yr, &mut xs2)
                    .map(|u| {
                        xs2.push(u);
                        xs2
                    });
                (p, q)
            };
            let ((pa, qa), (pg, qg)) = (solve(interp), solve(compiled));
            for (what, a, g) in [("psi_inv", pa, pg), ("invert", qa, qg)] {
                match (a, g) {
                    (Ok(a), Ok(g)) => c.add(&format!("{tag}{what}"), &a, &g),
                    (Err(_), Err(_)) => {}
                    (a, g) => c.mismatched_errors.push(format!(
                        "{tag}{what} at point {k}: interpreter {a:?}, compiled {g:?}"
                    )),
                }
            }
        }
        // The batch methods on the same points: all of them (several blocks of the generated code), and an
        // odd-length prefix (a partial last block).
        for len in [POINTS, 300] {
            let ((ia, oa), (ig, og)) = (
                batch(interp, &columns, len, no),
                batch(compiled, &columns, len, no),
            );
            // One row per point (quantity i of a method is `what[i]`, as for the per-point methods).
            let row =
                |cols: &[Vec<f64>], k: usize| -> Vec<f64> { cols.iter().map(|c| c[k]).collect() };
            for k in 0..len {
                c.add(
                    &format!("{tag}outputs_batch/{len}"),
                    &row(&oa, k),
                    &row(&og, k),
                );
            }
            // `sensitivity_batch` against the same engine's per-point `sensitivity` (the generated kernel takes
            // its fractional powers a block at once, within 1 ulp of `powf`): each point's row differentials
            // within the sensitivities' bound, the map calls' arguments within 1e-12.
            let layout = SensitivityLayout::of(&info);
            let rows_end = layout.rows() * layout.width();
            for m in [interp, compiled] {
                let sb = sensitivity_batch(m, &columns, len);
                // Asked for every third entry alone (the others empty columns, which stay empty): those the
                // same bits as asked for all.
                let third = sensitivity_batch_of(m, &columns, len, &|e| e % 3 == 0);
                for (e, (all, some)) in sb.iter().zip(&third).enumerate() {
                    let same = |(a, b): (&f64, &f64)| a.to_bits() == b.to_bits();
                    let agrees = if e % 3 == 0 {
                        all.iter().zip(some).all(same)
                    } else {
                        some.is_empty()
                    };
                    if !agrees {
                        c.mismatched_errors.push(format!(
                            "{tag}sensitivity_batch/{len} asked for every third: entry {e}"
                        ));
                    }
                }
                for k in 0..len {
                    let (x, u) = (row(&columns.x, k), columns.u[k]);
                    let mut s = vec![0.0; layout.len()];
                    m.sensitivity(&x, &m.info().nominal_w(), u, &mut s)
                        .expect("both engines provide sensitivities");
                    let g = row(&sb, k);
                    let scales = variable_scales(&b, interp, &s);
                    let values = row_values(interp, (&x, u), b.yr);
                    let bad = sensitivity_disagreements(&layout, (&scales, &values), (&s, &g));
                    c.mismatched_errors.extend(
                        bad.into_iter()
                            .map(|e| format!("{tag}sensitivity_batch/{len} at point {k}: {e}")),
                    );
                    c.add(
                        &format!("{tag}sensitivity_batch_arguments/{len}"),
                        &s[rows_end..],
                        &g[rows_end..],
                    );
                }
            }
            match (ia, ig) {
                (Ok(a), Ok(g)) => {
                    for k in 0..len {
                        c.add(
                            &format!("{tag}invert_batch/{len}"),
                            &row(&a, k),
                            &row(&g, k),
                        );
                    }
                }
                (Err(a), Err(g)) if a == g => {}
                (a, g) => c.mismatched_errors.push(format!(
                    "{tag}invert_batch/{len}: interpreter {:?}, compiled {:?}",
                    a.map(|_| ()),
                    g.map(|_| ())
                )),
            }
        }
    };
    run(&mut c, &mut rng, compiled, &interp, "");
    // A changed parameter reaches both (the compiled model recomputes its parameter-only subexpressions).
    if let Some(p) = info.parameters.first() {
        let v = interp.params()[0] * 1.1 + 0.01;
        interp
            .set_param(p, v)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        compiled
            .set_param(p, v)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            compiled.params(),
            interp.params(),
            "{name}: parameter values after set_param"
        );
        run(&mut c, &mut rng, compiled, &interp, "set_param: ");
    }
    assert_eq!(
        compiled.set_param("no_such_parameter", 1.0),
        interp.set_param("no_such_parameter", 1.0)
    );
    // A non-finite value is refused by both (compared by variant: the error holds the NaN).
    let first = info.parameters.first().cloned().unwrap_or_default();
    for m in [&mut *compiled as &mut dyn InverseModel, &mut interp] {
        let e = m.set_param(&first, f64::NAN);
        assert!(
            matches!(e, Err(ModelError::NonFiniteParameter { .. })),
            "{name}: {e:?}"
        );
    }
    match c.check(name) {
        Ok(stats) => stats,
        Err(e) => panic!("{e}"),
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn check_registry(
    dir: &Path,
    models: &[(&str, &str, &str)],
    builtin: fn(&str) -> Option<Box<dyn InverseModel>>,
    by_hash: fn(&str) -> Option<Box<dyn InverseModel>>,
) {
    assert!(
        !models.is_empty(),
        "no compiled models from {}",
        dir.display()
    );
    for &(name, hash, file) in models {
        let mut compiled = builtin(name).unwrap_or_else(|| panic!("{name} is not in the registry"));
        assert_eq!(
            by_hash(hash).map(|m| m.info().name.clone()).as_deref(),
            Some(name),
            "{name}: by_hash"
        );
        let s = compare(name, &dir.join(file), compiled.as_mut());
        eprintln!(
            "{name}: {} values compared ({} identical, {} NaN on both sides); largest difference {:.1e} relative",
            s.compared, s.equal, s.nan, s.worst
        );
        assert!(
            s.nan * 10 < s.compared,
            "{name}: too many points outside the model's domain"
        );
    }
}

#[test]
fn builtin_models_agree_with_the_interpreter() {
    check_registry(
        &root().join("models"),
        invsim_models::MODELS,
        invsim_models::builtin,
        invsim_models::by_hash,
    );
    assert_eq!(invsim_models::names().len(), invsim_models::MODELS.len());
    assert!(invsim_models::builtin("no such model").is_none());
    assert!(invsim_models::by_hash("0000").is_none());
    // by_source (what the command line uses) finds by the bytes what by_hash finds by their SHA-256, and a
    // file that differs in one byte is none of them.
    for &(name, _, file) in invsim_models::MODELS {
        let mut bytes = std::fs::read(root().join("models").join(file)).expect("model file");
        let found = invsim_models::by_source(&bytes).map(|m| m.info().name.clone());
        assert_eq!(found.as_deref(), Some(name), "{name}: by_source");
        bytes.push(b'\n');
        assert!(
            invsim_models::by_source(&bytes).is_none(),
            "{name}: one byte more"
        );
    }
}

/// Every mode of every compiled model with operating modes against the interpreter of that mode's
/// derivation (the modes read from the same file, in its order).
#[test]
fn builtin_modes_agree_with_the_interpreter() {
    assert!(!invsim_models::MODAL_MODELS.is_empty());
    for &(name, hash, file) in invsim_models::MODAL_MODELS {
        let path = root().join("models").join(file);
        let m = match invsim_inversion::ModelFile::from_path(&path) {
            Ok(invsim_inversion::ModelFile::Modal(m)) => m,
            other => panic!("{name}: not a model with modes: {other:?}"),
        };
        let mut compiled =
            invsim_models::modal_by_hash(hash).unwrap_or_else(|| panic!("{name}: modal_by_hash"));
        assert_eq!(compiled.len(), m.modes.len(), "{name}: number of modes");
        for (mode, c) in m.modes.into_iter().zip(compiled.iter_mut()) {
            let label = format!("{name}, mode {}", mode.name);
            let d = invsim_inversion::Derivation::new(mode.model)
                .unwrap_or_else(|e| panic!("{label}: {e}"));
            let s = compare_derived(&label, &d, c.as_mut());
            eprintln!(
                "{label}: {} values compared ({} identical, {} NaN on both sides); largest difference {:.1e} relative",
                s.compared, s.equal, s.nan, s.worst
            );
            assert!(s.nan * 10 < s.compared, "{label}: too many NaN");
        }
    }
    assert!(invsim_models::modal_by_hash("0000").is_none());
}

/// What a run of a compiled model with modes reads (the headers, without each mode's model) equals what the
/// full reader gives, mode by mode; a hash that compiled code does not claim reads nothing.
#[test]
fn mode_headers_equal_the_full_read() {
    for &(name, hash, file) in invsim_models::MODAL_MODELS {
        let path = root().join("models").join(file);
        let full = match invsim_inversion::ModelFile::from_path(&path) {
            Ok(invsim_inversion::ModelFile::Modal(m)) => m,
            other => panic!("{name}: not a model with modes: {other:?}"),
        };
        let claims = |h: &str| h == hash;
        let (light, headers) = invsim_inversion::ModelFile::modal_headers(&path, &claims)
            .unwrap_or_else(|e| panic!("{name}: {e}"))
            .unwrap_or_else(|| panic!("{name}: no headers for its own hash"));
        assert_eq!(light.name, full.name, "{name}");
        assert_eq!(light.description, full.description, "{name}");
        assert_eq!(light.source_hash, full.source_hash, "{name}");
        assert_eq!(light.source_hash, hash, "{name}");
        assert_eq!(light.inputs, full.inputs, "{name}");
        assert_eq!(light.gearbox, full.gearbox, "{name}");
        assert_eq!(light.sequence, full.sequence, "{name}");
        assert!(
            light.modes.is_empty(),
            "{name}: the light read builds no mode"
        );
        let expected: Vec<_> = full.modes.into_iter().map(|m| m.into_header()).collect();
        assert_eq!(headers, expected, "{name}: headers");
        // With what the compiled code knows of the file, no mode is built at all, and the read is the same.
        let compiled = invsim_models::modal_by_hash(hash).expect("compiled modes");
        let facts = invsim_inversion::ModalFacts::from_info(compiled[0].info());
        let bytes = std::fs::read(&path).expect("model file");
        let knows = |h: &str| (h == hash).then(|| Some(facts.clone()));
        let (bare, bare_headers) =
            invsim_inversion::ModelFile::modal_headers_of(&path, &bytes, &knows)
                .unwrap_or_else(|e| panic!("{name}: {e}"))
                .unwrap_or_else(|| panic!("{name}: no headers for its own hash"));
        assert_eq!(
            bare_headers, expected,
            "{name}: headers from the compiled facts"
        );
        assert_eq!(
            (
                &bare.name,
                &bare.description,
                &bare.inputs,
                &bare.gearbox,
                &bare.sequence
            ),
            (
                &light.name,
                &light.description,
                &light.inputs,
                &light.gearbox,
                &light.sequence
            ),
            "{name}: the model from the compiled facts"
        );
        // The compiled code finds the file by its bytes, with the file's SHA-256; one byte more is not it.
        assert_eq!(
            invsim_models::modal_hash_of_source(&bytes),
            Some(hash),
            "{name}"
        );
        let mut edited = bytes.clone();
        edited.push(b'\n');
        assert_eq!(invsim_models::modal_hash_of_source(&edited), None, "{name}");
        let refuse = |_: &str| false;
        let none = invsim_inversion::ModelFile::modal_headers(&path, &refuse)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            none.is_none(),
            "{name}: read although no compiled code claims it"
        );
    }
    // A file without modes has no headers even when its hash is claimed.
    let single = root().join("models/si_engine.toml");
    let any = |_: &str| true;
    let got = invsim_inversion::ModelFile::modal_headers(&single, &any).expect("si_engine reads");
    assert!(got.is_none());
    let bytes = std::fs::read(&single).expect("si_engine.toml");
    assert_eq!(invsim_models::modal_hash_of_source(&bytes), None);
}

#[test]
fn test_models_agree_with_the_interpreter() {
    let dir = root().join("tests/models");
    check_registry(
        &dir,
        invsim_tests::extra::MODELS,
        invsim_tests::extra::builtin,
        invsim_tests::extra::by_hash,
    );
    assert!(
        invsim_tests::extra::SKIPPED.is_empty(),
        "{:?}",
        invsim_tests::extra::SKIPPED
    );
}

#[cfg(has_shared)]
#[test]
fn shared_models_agree_with_the_interpreter() {
    let dir = root().join("../shared/models");
    check_registry(
        &dir,
        invsim_tests::shared::MODELS,
        invsim_tests::shared::builtin,
        invsim_tests::shared::by_hash,
    );
    // Only the deliberately broken models are skipped.
    for (file, error) in invsim_tests::shared::SKIPPED {
        assert!(file.starts_with("bad_"), "{file} did not derive: {error}");
    }
}

#[cfg(not(has_shared))]
#[test]
fn shared_models_agree_with_the_interpreter() {
    eprintln!("skipping: ../shared not found");
}
