//! Test models that carry their exact answers (diffsol's habit): every model file in `tests/models/known/`
//! is listed in [`CASES`] with its exact solution — the states and the input along any reference y_d — and the
//! tolerances the engines must meet. The build script compiles the same files into [`compiled`]; the harness
//! `tests/tests/known_answers.rs` runs every engine on every case.
//!
//! Exact means: from the smoother's exact derivatives y_d, y_d', … (no numerical differentiation) by closed
//! formulas, and where the zero dynamics are integrated, by the variation-of-constants integral evaluated with
//! 16-point Gauss–Legendre quadrature on panels of 0.5 s (error ~1e-13: y_d is C-infinity and smooth on the
//! kernel's scale).

use std::collections::BTreeMap;

/// The compiled known-answer models (registry like `invsim-models`': `builtin`, `by_hash`, `MODELS`).
pub mod compiled {
    include!(concat!(env!("OUT_DIR"), "/known/registry.rs"));
}

/// The reference: `yd(k, t)` is y_d^(k)(t).
pub type Yd<'a> = &'a dyn Fn(usize, f64) -> f64;

/// The exact solution at one time: the states (in the model file's order) and the input.
#[derive(Debug, Clone, PartialEq)]
pub struct Exact {
    pub states: Vec<f64>,
    pub input: f64,
}

/// A model's parameter values by name.
#[derive(Debug, Clone, Default)]
pub struct Params(pub BTreeMap<String, f64>);

impl Params {
    /// The parameters `names` with `values` (as an `InverseModel` reports them).
    pub fn new(names: &[String], values: &[f64]) -> Params {
        Params(names.iter().cloned().zip(values.iter().copied()).collect())
    }
    /// The value of `name`; a known-answer model without it is a mistake in this file.
    pub fn get(&self, name: &str) -> f64 {
        match self.0.get(name) {
            Some(&v) => v,
            None => panic!("known-answer model has no parameter `{name}`: {:?}", self.0),
        }
    }
}

/// The exact solution along a reference, for times in `span` (the quadrature's range).
pub type Solution<'a> = Box<dyn Fn(f64) -> Exact + 'a>;

/// A known-answer model and what the engines must achieve on it.
pub struct Case {
    /// The model file in `tests/models/known/`.
    pub file: &'static str,
    /// The model's name (its compiled module).
    pub name: &'static str,
    /// The summary's `inversion`: `none` (r = n), `causal` or `stable`.
    pub inversion: &'static str,
    /// The inverse simulation's states and input equal the exact ones within this, relative to each
    /// signal's peak over the run.
    pub tol_inverse: f64,
    /// The replay of the exact input through the original model tracks y_d within this, relative to the
    /// peak of y_d.
    pub tol_replay: f64,
    /// The exact solution for parameters, reference and time span.
    pub solution: for<'a> fn(&Params, Yd<'a>, (f64, f64)) -> Solution<'a>,
}

/// Every known-answer model.
pub const CASES: &[Case] = &[
    Case {
        file: "first_order.toml",
        name: "first_order",
        inversion: "none",
        tol_inverse: 1e-12,
        tol_replay: 1e-9,
        solution: first_order,
    },
    Case {
        file: "linear_fuel.toml",
        name: "linear_fuel",
        inversion: "none",
        tol_inverse: 1e-12,
        tol_replay: 1e-9,
        solution: linear_fuel,
    },
    Case {
        file: "chain3.toml",
        name: "chain3",
        inversion: "none",
        tol_inverse: 1e-12,
        tol_replay: 1e-9,
        solution: chain3,
    },
    Case {
        file: "pendulum.toml",
        name: "pendulum",
        inversion: "none",
        tol_inverse: 1e-12,
        tol_replay: 1e-9,
        solution: pendulum,
    },
    Case {
        file: "linear_mp.toml",
        name: "linear_mp",
        inversion: "causal",
        tol_inverse: 1e-10,
        tol_replay: 1e-9,
        solution: linear_mp,
    },
    Case {
        file: "linear_nmp.toml",
        name: "linear_nmp",
        inversion: "stable",
        // The stable inverse starts and ends where the unstable part has decayed to 1e-8 (the runtime's
        // tolerance), so the truncation error is of that order.
        tol_inverse: 1e-7,
        tol_replay: 1e-9,
        solution: linear_nmp,
    },
];

/// x' = −a x + b u, y = x: x = y_d, u = (y_d' + a y_d)/b.
fn first_order<'a>(p: &Params, yd: Yd<'a>, _span: (f64, f64)) -> Solution<'a> {
    let (a, b) = (p.get("a"), p.get("b"));
    Box::new(move |t| Exact {
        states: vec![yd(0, t)],
        input: (yd(1, t) + a * yd(0, t)) / b,
    })
}

/// v' = −a v + b u, y = v (fuel = c u + d): v = y_d, u = (y_d' + a y_d)/b.
fn linear_fuel<'a>(p: &Params, yd: Yd<'a>, _span: (f64, f64)) -> Solution<'a> {
    let (a, b) = (p.get("a"), p.get("b"));
    Box::new(move |t| Exact {
        states: vec![yd(0, t)],
        input: (yd(1, t) + a * yd(0, t)) / b,
    })
}

/// x1' = −c1 x1 + x2, x2' = −c2 x2 + x3, x3' = −c3 x3 + b u, y = x1: each state from the one before,
/// x_{i+1} = x_i' + c_i x_i, and u = (x3' + c3 x3)/b, expanded in y_d … y_d'''.
fn chain3<'a>(p: &Params, yd: Yd<'a>, _span: (f64, f64)) -> Solution<'a> {
    let (c1, c2, c3, b) = (p.get("c1"), p.get("c2"), p.get("c3"), p.get("b"));
    Box::new(move |t| {
        let [y, y1, y2, y3] = [0, 1, 2, 3].map(|k| yd(k, t));
        let x2 = y1 + c1 * y;
        let x3 = y2 + (c1 + c2) * y1 + c1 * c2 * y;
        let s2 = c1 * c2 + c1 * c3 + c2 * c3;
        Exact {
            states: vec![y, x2, x3],
            input: (y3 + (c1 + c2 + c3) * y2 + s2 * y1 + c1 * c2 * c3 * y) / b,
        }
    })
}

/// th'' = −(g/l) sin th − d th' + u/(m l²), y = th: (th, om) = (y_d, y_d'), u = m l² (y_d'' + d y_d' + (g/l) sin y_d).
fn pendulum<'a>(p: &Params, yd: Yd<'a>, _span: (f64, f64)) -> Solution<'a> {
    let (m, l, g, d) = (p.get("m"), p.get("l"), p.get("g"), p.get("d"));
    Box::new(move |t| {
        let [y, y1, y2] = [0, 1, 2].map(|k| yd(k, t));
        Exact {
            states: vec![y, y1],
            input: m * l * l * (y2 + d * y1 + (g / l) * y.sin()),
        }
    })
}

/// x1' = −a x1 + x2 + u, x2' = −c x2 + k x1, y = x1, from rest: x2 = k ∫_{−∞}^t e^{−c(t−τ)} y_d dτ,
/// u = y_d' + a y_d − x2.
fn linear_mp<'a>(p: &Params, yd: Yd<'a>, span: (f64, f64)) -> Solution<'a> {
    let (a, c, k) = (p.get("a"), p.get("c"), p.get("k"));
    let w = Weighted::new(yd, c, span);
    Box::new(move |t| {
        let x2 = k * w.forward(t);
        Exact {
            states: vec![yd(0, t), x2],
            input: yd(1, t) + a * yd(0, t) - x2,
        }
    })
}

/// x1' = −a x1 + x2 + u, x2' = b x2 + k x1 (b > 0), y = x1, bounded: x2 = −k ∫_t^∞ e^{−b(τ−t)} y_d dτ,
/// u = y_d' + a y_d − x2.
fn linear_nmp<'a>(p: &Params, yd: Yd<'a>, span: (f64, f64)) -> Solution<'a> {
    let (a, b, k) = (p.get("a"), p.get("b"), p.get("k"));
    let w = Weighted::new(yd, b, span);
    Box::new(move |t| {
        let x2 = -k * w.backward(t);
        Exact {
            states: vec![yd(0, t), x2],
            input: yd(1, t) + a * yd(0, t) - x2,
        }
    })
}

// --- quadrature ----------------------------------------------------------------------------------------------

/// (P_n(z), P_{n−1}(z)) by the three-term recurrence k P_k = (2k − 1) z P_{k−1} − (k − 1) P_{k−2}.
fn legendre(n: usize, z: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, z);
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    (p1, p0)
}

/// Gauss–Legendre nodes and weights on [−1, 1]: the roots of P_n by Newton's method from
/// cos(π (i + 3/4)/(n + 1/2)), weights 2/((1 − z²) P_n'(z)²) with P_n' = n (z P_n − P_{n−1})/(z² − 1).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let dp = |z: f64| {
        let (p, q) = legendre(n, z);
        n as f64 * (z * p - q) / (z * z - 1.0)
    };
    (0..n)
        .map(|i| {
            let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            for _ in 0..100 {
                let dz = legendre(n, z).0 / dp(z);
                z -= dz;
                if dz.abs() < 1e-16 {
                    break;
                }
            }
            (z, 2.0 / ((1.0 - z * z) * dp(z) * dp(z)))
        })
        .unzip()
}

/// The exponentially weighted integrals of the reference (the variation-of-constants solutions of
/// η' = ∓λ η + y_d): B(t) = ∫_t^∞ e^{−λ(τ−t)} y_d(τ) dτ (backward) and F(t) = ∫_{−∞}^t e^{−λ(t−τ)} y_d(τ) dτ
/// (forward), by Gauss–Legendre quadrature on panels of 0.5 s, with exact tails y_d/λ beyond the span where
/// the reference is constant.
pub struct Weighted<'a> {
    yd: Yd<'a>,
    lambda: f64,
    lo: f64,
    w: f64,
    /// B and F at the panel boundaries lo + p w.
    b: Vec<f64>,
    f: Vec<f64>,
    gl: (Vec<f64>, Vec<f64>),
}

impl<'a> Weighted<'a> {
    /// Tabulate B and F over `span` = (lo, hi) for the rate `lambda` > 0.
    pub fn new(yd: Yd<'a>, lambda: f64, (lo, hi): (f64, f64)) -> Weighted<'a> {
        let w = 0.5;
        let panels = ((hi - lo) / w).ceil().max(1.0) as usize;
        let mut me = Weighted {
            yd,
            lambda,
            lo,
            w,
            b: vec![0.0; panels + 1],
            f: vec![0.0; panels + 1],
            gl: gauss_legendre(16),
        };
        me.b[panels] = yd(0, lo + panels as f64 * w + 1e3) / lambda;
        me.f[0] = yd(0, lo - 1e3) / lambda;
        let decay = (-lambda * w).exp();
        for p in (0..panels).rev() {
            let a = lo + p as f64 * w;
            me.b[p] = me.quad(a, a + w, |s| (-lambda * (s - a)).exp()) + decay * me.b[p + 1];
        }
        for p in 1..=panels {
            let c = lo + p as f64 * w;
            me.f[p] = me.quad(c - w, c, |s| (-lambda * (c - s)).exp()) + decay * me.f[p - 1];
        }
        me
    }

    /// ∫_a^c weight(s) y_d(s) ds.
    fn quad(&self, a: f64, c: f64, weight: impl Fn(f64) -> f64) -> f64 {
        let (m, r) = (0.5 * (a + c), 0.5 * (c - a));
        let (x, wt) = &self.gl;
        x.iter()
            .zip(wt)
            .map(|(x, wt)| wt * r * weight(m + r * x) * (self.yd)(0, m + r * x))
            .sum()
    }

    fn panel(&self, t: f64) -> usize {
        (((t - self.lo) / self.w).floor().max(0.0) as usize).min(self.b.len() - 2)
    }

    /// B(t) = ∫_t^∞ e^{−λ(τ−t)} y_d(τ) dτ.
    pub fn backward(&self, t: f64) -> f64 {
        let p = self.panel(t);
        let c = self.lo + (p + 1) as f64 * self.w;
        let l = self.lambda;
        self.quad(t, c, |s| (-l * (s - t)).exp()) + (-l * (c - t)).exp() * self.b[p + 1]
    }

    /// F(t) = ∫_{−∞}^t e^{−λ(t−τ)} y_d(τ) dτ.
    pub fn forward(&self, t: f64) -> f64 {
        let p = self.panel(t);
        let a = self.lo + p as f64 * self.w;
        let l = self.lambda;
        self.quad(a, t, |s| (-l * (t - s)).exp()) + (-l * (t - a)).exp() * self.f[p]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_of_degree_2n_minus_1_exactly() {
        let (x, w) = gauss_legendre(16);
        let integral = |k: i32| -> f64 { x.iter().zip(&w).map(|(x, w)| w * x.powi(k)).sum() };
        for k in 0..32 {
            let exact = if k % 2 == 0 {
                2.0 / (k + 1) as f64
            } else {
                0.0
            };
            assert!(
                (integral(k) - exact).abs() < 1e-14,
                "x^{k}: {}",
                integral(k)
            );
        }
    }

    #[test]
    fn weighted_integrals_of_a_known_reference() {
        // y_d = e^{−t²}: B(0) = F(0) by symmetry, and B and F solve B' = λB − y_d and F' = −λF + y_d
        // (checked by central differences).
        let yd = |k: usize, t: f64| if k == 0 { (-t * t).exp() } else { f64::NAN };
        let w = Weighted::new(&yd, 0.7, (-12.0, 12.0));
        let (b, f) = (w.backward(0.0), w.forward(0.0));
        assert!((b - f).abs() < 1e-13, "symmetric reference: {b} vs {f}");
        let h = 1e-4;
        for t in [-1.3, 0.2, 2.1] {
            let db = (w.backward(t + h) - w.backward(t - h)) / (2.0 * h);
            let df = (w.forward(t + h) - w.forward(t - h)) / (2.0 * h);
            assert!(
                (db - (0.7 * w.backward(t) - yd(0, t))).abs() < 1e-7,
                "B' at {t}"
            );
            assert!(
                (df - (-0.7 * w.forward(t) + yd(0, t))).abs() < 1e-7,
                "F' at {t}"
            );
        }
    }
}
