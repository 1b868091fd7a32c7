//! Independent references for the map tests: the (bi)linear interpolant with its continuation, evaluated
//! piece by piece (not through the basis functions), and Gauss–Legendre quadrature of the convolution; and
//! their deterministic random numbers.

use invsim_kernel::map::Extrapolate;
use invsim_kernel::Kernel;

/// Piecewise-linear interpolation of `(x, v)` at `a`, continued by the rule (contract §6).
pub fn linear_1d(x: &[f64], v: &[f64], rule: Extrapolate, a: f64) -> f64 {
    let n = x.len();
    if rule == Extrapolate::Clamp {
        if a <= x[0] {
            return v[0];
        }
        if a >= x[n - 1] {
            return v[n - 1];
        }
    }
    let mut k = 0;
    while k + 2 < n && a > x[k + 1] {
        k += 1;
    }
    v[k] + (v[k + 1] - v[k]) * (a - x[k]) / (x[k + 1] - x[k])
}

/// The tensor-product interpolant: along `y` per grid row, then along `x`.
pub fn linear_2d(x: &[f64], y: &[f64], v: &[f64], rule: Extrapolate, a: f64, b: f64) -> f64 {
    let col: Vec<f64> = (0..x.len())
        .map(|i| linear_1d(y, &v[i * y.len()..(i + 1) * y.len()], rule, b))
        .collect();
    linear_1d(x, &col, rule, a)
}

/// Tanh–sinh nodes and weights on [−1, 1] with step `step` (`x = tanh(π/2 · sinh t)`, |t| ≤ 3.5): exact to
/// rounding for integrands smooth inside the interval, whatever they do at its ends (the kernel's flat ends).
pub fn tanh_sinh(step: f64) -> Vec<(f64, f64)> {
    let half_pi = std::f64::consts::FRAC_PI_2;
    let m = (3.5 / step) as i64;
    (-m..=m)
        .map(|k| {
            let t = k as f64 * step;
            let u = half_pi * t.sinh();
            let x = u.tanh();
            let w = step * half_pi * t.cosh() / (u.cosh() * u.cosh());
            (x, w)
        })
        .filter(|&(x, w)| x.abs() < 1.0 && w > 0.0)
        .collect()
}

/// Quadrature points `(s, weight · k_h^(order)(s))` over (−h, h), split at the kinks `breaks` of the
/// integrand's other factor (given as values of `s`), tanh–sinh with step `step` on each piece.
pub fn kernel_rule(h: f64, order: usize, breaks: &[f64], step: f64) -> Vec<(f64, f64)> {
    let kernel = Kernel::new(h);
    let nodes = tanh_sinh(step);
    let mut cuts: Vec<f64> = breaks.iter().copied().filter(|s| s.abs() < h).collect();
    cuts.push(-h);
    cuts.push(h);
    cuts.sort_by(f64::total_cmp);
    let mut rule = Vec::new();
    for w in cuts.windows(2) {
        let (mid, half) = (0.5 * (w[0] + w[1]), 0.5 * (w[1] - w[0]));
        for &(z, wt) in &nodes {
            let s = mid + half * z;
            rule.push((s, half * wt * kernel_derivative(&kernel, order, s)));
        }
    }
    rule
}

/// `k_h^(order)(s)`; order 0 straight from the definition exp(−h²/(h² − s²))/(C₀ h).
fn kernel_derivative(kernel: &Kernel, order: usize, s: f64) -> f64 {
    let h = kernel.half_width();
    if order > 0 {
        return kernel.derivative(order, s);
    }
    if s.abs() >= h {
        return 0.0;
    }
    (-h * h / (h * h - s * s)).exp() / kernel.normalisation()
}

/// `∫ k_h^(p)(s) L(a − s) ds` by quadrature.
pub fn convolve_1d(x: &[f64], v: &[f64], rule: Extrapolate, h: f64, p: usize, a: f64) -> f64 {
    let breaks: Vec<f64> = x.iter().map(|xc| a - xc).collect();
    kernel_rule(h, p, &breaks, 1.0 / 64.0)
        .iter()
        .map(|&(s, w)| w * linear_1d(x, v, rule, a - s))
        .sum()
}

/// `∫∫ k_hx^(p)(s) k_hy^(q)(σ) L(a − s, b − σ) ds dσ` by quadrature, for every `p, q ≤ 4` with
/// `p + q ≤ 4` at once (`out[p][q]`): the nodes do not depend on the orders, so `L` is sampled once.
pub fn convolve_2d(
    x: &[f64],
    y: &[f64],
    v: &[f64],
    rule: Extrapolate,
    h: [f64; 2],
    ab: [f64; 2],
) -> [[f64; 5]; 5] {
    let step = 1.0 / 48.0;
    let bx: Vec<f64> = x.iter().map(|c| ab[0] - c).collect();
    let by: Vec<f64> = y.iter().map(|c| ab[1] - c).collect();
    let rx: Vec<Vec<(f64, f64)>> = (0..5).map(|p| kernel_rule(h[0], p, &bx, step)).collect();
    let ry: Vec<Vec<(f64, f64)>> = (0..5).map(|q| kernel_rule(h[1], q, &by, step)).collect();
    let samples: Vec<Vec<f64>> = rx[0]
        .iter()
        .map(|&(s, _)| {
            ry[0]
                .iter()
                .map(|&(t, _)| linear_2d(x, y, v, rule, ab[0] - s, ab[1] - t))
                .collect()
        })
        .collect();
    let mut out = [[0.0; 5]; 5];
    for p in 0..5 {
        for q in 0..(5 - p) {
            out[p][q] = rx[p]
                .iter()
                .zip(&samples)
                .map(|(&(_, ws), row)| {
                    ws * row
                        .iter()
                        .zip(&ry[q])
                        .map(|(l, &(_, wt))| l * wt)
                        .sum::<f64>()
                })
                .sum();
        }
    }
    out
}

/// A deterministic generator of uniform numbers in [0, 1) (64-bit LCG, top 53 bits).
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}
