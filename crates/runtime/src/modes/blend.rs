//! The re-entry transition: after a mode switch the reference starts from the ξ that the continuous state
//! gives in the new mode and joins the smoothed cycle within the transition time T.
//!
//! With τ = t − t_s and the initial deviations e_j = ξ_{j+1} − y_c^(j)(t_s) (j < r), the reference is
//! y = y_c + e(τ) with e(τ) = (1 − S(τ/T)) · Σ_j e_j τ^j / j! on [0, T] and e = 0 after, where S is the
//! smoothstep polynomial of order m = r + 1 (S(0) = 0, S(1) = 1, S^(i)(0) = S^(i)(1) = 0 for i = 1 … m;
//! S(s) = s^(m+1) Σ_{k=0}^{m} C(m+k, k) C(2m+1, m−k) (−s)^k). So y^(j)(t_s) = ξ_{j+1} for j < r,
//! y^(r)(t_s) = y_c^(r)(t_s) (the input stays finite), and e has a zero of order r + 2 at τ = T: the
//! reference is C^(r+1) where it joins the cycle. e is a polynomial, so its derivatives are exact.

use std::sync::Arc;

use crate::binomial::binomial;

/// Coefficients (in ascending powers of s) of the smoothstep polynomial of order m.
pub fn smoothstep(m: usize) -> Vec<f64> {
    let mut c = vec![0.0; 2 * m + 2];
    for k in 0..=m {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        c[m + 1 + k] = sign * binomial(m + k, k) * binomial(2 * m + 1, m - k);
    }
    c
}

/// One re-entry transition: the deviation polynomial e(τ) on [0, T].
#[derive(Debug, Clone)]
pub struct Blend {
    pub t_start: f64,
    pub duration: f64,
    /// e(τ) and each of its derivatives e^(j)(τ), in ascending powers of τ (all computed once, at the
    /// switch: the run evaluates the blend at every stage of every step of the transition), one after the
    /// other: e^(j) has n − j coefficients (n those of e), after those of e^(0 … j − 1).
    derivatives: Vec<f64>,
    /// n, the number of coefficients of e.
    terms: usize,
}

impl Blend {
    /// A transition starting at `t_start` with initial deviations `e` (e_j = deviation of the j-th
    /// derivative, j < r) lasting `duration` (> 0).
    pub fn new(t_start: f64, duration: f64, e: &[f64]) -> Blend {
        let r = e.len();
        let s = smoothstep(r + 1);
        // w(τ) = 1 − S(τ/T), in powers of τ.
        let mut w: Vec<f64> = s
            .iter()
            .enumerate()
            .map(|(i, c)| -c / duration.powi(i as i32))
            .collect();
        w[0] += 1.0;
        // p(τ) = Σ e_j τ^j / j!
        let mut fact = 1.0;
        let p: Vec<f64> = e
            .iter()
            .enumerate()
            .map(|(j, ej)| {
                if j > 0 {
                    fact *= j as f64;
                }
                ej / fact
            })
            .collect();
        let mut coeffs = vec![0.0; w.len() + p.len().max(1) - 1];
        for (i, wi) in w.iter().enumerate() {
            for (j, pj) in p.iter().enumerate() {
                coeffs[i + j] += wi * pj;
            }
        }
        Blend {
            t_start,
            duration,
            terms: coeffs.len(),
            derivatives: derivatives(coeffs),
        }
    }

    /// Whether the transition is over at `t`.
    pub fn done(&self, t: f64) -> bool {
        t >= self.t_start + self.duration
    }

    /// Adds e^(j)(t) to `out[j]` for j = 0 … out.len() − 1 (nothing outside [t_s, t_s + T]).
    pub fn add(&self, t: f64, out: &mut [f64]) {
        let tau = t - self.t_start;
        if (0.0..self.duration).contains(&tau) {
            self.add_at(tau, out);
        }
    }

    /// Adds e^(j)(τ) to `out[j]` for j = 0 … out.len() − 1, τ in [0, T] (Horner's scheme on each derivative's
    /// coefficients, which lie one after the other).
    fn add_at(&self, tau: f64, out: &mut [f64]) {
        let mut start = 0;
        for (j, o) in out.iter_mut().enumerate().take(self.terms) {
            let end = start + self.terms - j;
            let c = &self.derivatives[start..end];
            *o += c.iter().rev().fold(0.0, |acc, &ci| acc * tau + ci);
            start = end;
        }
    }
}

/// Transitions started together — the same t_s, T and number of deviations — with deviations e_c per column c
/// (a run's derivatives of one re-entry, `gradient.rs`). e_c(τ) = Σ_j e_c,j b_j(τ) with the basis
/// b_j(τ) = (1 − S(τ/T)) τ^j/j! (the [`Blend`] of the unit deviation j), so each b_j^(k)(t) is evaluated once
/// for every column.
#[derive(Debug, Clone)]
pub struct Blends {
    t_start: f64,
    /// The unit transitions b_j, started at τ = 0 (shared by every family of one length and duration).
    basis: Arc<[Blend]>,
    /// e_c, per column c (each of the basis' length).
    e: Vec<Vec<f64>>,
}

impl Blends {
    /// The transitions of deviations `e` (one vector per column, all of one length) from `t_start` lasting
    /// `duration` (> 0).
    pub fn new(t_start: f64, duration: f64, e: Vec<Vec<f64>>) -> Blends {
        let len = e.first().map_or(0, Vec::len);
        Blends::on(Blends::basis(len, duration), t_start, e)
    }

    /// The basis b_0 … b_(len−1) of transitions lasting `duration`, started at τ = 0.
    pub fn basis(len: usize, duration: f64) -> Arc<[Blend]> {
        (0..len)
            .map(|j| {
                let unit: Vec<f64> = (0..len).map(|i| if i == j { 1.0 } else { 0.0 }).collect();
                Blend::new(0.0, duration, &unit)
            })
            .collect()
    }

    /// [`Blends::new`] on a basis of [`Blends::basis`] (of the deviations' length).
    pub fn on(basis: Arc<[Blend]>, t_start: f64, e: Vec<Vec<f64>>) -> Blends {
        debug_assert!(e.iter().all(|e| e.len() == basis.len()));
        Blends { t_start, basis, e }
    }

    /// The number of columns c.
    pub fn columns(&self) -> usize {
        self.e.len()
    }

    /// b_j^(k)(t) into `values` (entry j·orders + k, k < `orders`); false outside the transitions (or
    /// without deviations), where every e_c^(k)(t) is 0.
    pub fn basis_at(&self, t: f64, orders: usize, values: &mut Vec<f64>) -> bool {
        let Some(first) = self.basis.first() else {
            return false;
        };
        let tau = t - self.t_start;
        if !(0.0..first.duration).contains(&tau) {
            return false;
        }
        values.clear();
        values.resize(self.basis.len() * orders, 0.0);
        for (b, v) in self.basis.iter().zip(values.chunks_exact_mut(orders)) {
            b.add_at(tau, v);
        }
        true
    }

    /// e_c^(k)(t) = Σ_j e_c,j b_j^(k)(t) added to `out[k]` for k < out.len(), from [`Blends::basis_at`]'s
    /// `values` (with orders = out.len()).
    pub fn add_from(&self, c: usize, values: &[f64], out: &mut [f64]) {
        let orders = out.len();
        for (k, o) in out.iter_mut().enumerate() {
            let mut sum = 0.0;
            for (j, &ej) in self.e[c].iter().enumerate() {
                sum += ej * values[j * orders + k];
            }
            *o += sum;
        }
    }

    /// Column c's deviations e_c,j (the coefficients of its transition in the basis).
    pub fn deviations(&self, c: usize) -> &[f64] {
        &self.e[c]
    }
}

/// The polynomial with coefficients `c` (ascending powers) and each of its derivatives down to the constant
/// one, one after the other: d/dτ Σ c_i τ^i = Σ_{i ≥ 1} i c_i τ^(i−1).
fn derivatives(c: Vec<f64>) -> Vec<f64> {
    let n = c.len();
    let mut out = c;
    out.reserve(n * n.saturating_sub(1) / 2);
    let mut start = 0;
    for len in (1..n).rev() {
        // The last polynomial's n − j + 1 coefficients at start … start + len + 1.
        for i in 1..=len {
            out.push(out[start + i] * i as f64);
        }
        start += len + 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A family's e_c^(k)(t) through the shared basis equals each column's own [`Blend`] (the same polynomial,
    /// summed in another order: within 10⁻¹⁰ absolute, where the coefficients of the derivatives reach 10⁴
    /// and the values cancel towards 0 at the end), inside the transition and 0 outside it.
    #[test]
    fn blends_equal_their_columns_own_blends() {
        let e = vec![
            vec![0.5, -0.2, 0.03],
            vec![-1.5, 0.0, 2.0],
            vec![0.0, 0.0, 0.0],
        ];
        let family = Blends::new(2.0, 3.0, e.clone());
        assert_eq!(family.columns(), 3);
        for t in [1.9, 2.0, 2.7, 4.1, 4.999, 5.0, 6.0] {
            for (c, ec) in e.iter().enumerate() {
                let (mut own, mut shared, mut basis) = ([0.0; 4], [0.0; 4], Vec::new());
                Blend::new(2.0, 3.0, ec).add(t, &mut own);
                if family.basis_at(t, 4, &mut basis) {
                    family.add_from(c, &basis, &mut shared);
                }
                for (a, b) in own.iter().zip(&shared) {
                    assert!(
                        (a - b).abs() <= 1e-10 * (1.0 + a.abs()),
                        "t {t} c {c}: {own:?} {shared:?}"
                    );
                }
                if !(2.0..5.0).contains(&t) {
                    assert_eq!(shared, [0.0; 4], "t {t}");
                }
            }
        }
    }

    #[test]
    fn smoothstep_ends() {
        for m in 1..5 {
            let c = smoothstep(m);
            let v: f64 = c.iter().sum();
            assert!((v - 1.0).abs() < 1e-12, "S(1) = {v}");
        }
    }

    #[test]
    fn blend_starts_at_deviation_and_ends_flat() {
        let b = Blend::new(2.0, 3.0, &[0.5, -0.2]);
        let mut out = [0.0; 4];
        b.add(2.0, &mut out);
        assert!((out[0] - 0.5).abs() < 1e-14 && (out[1] + 0.2).abs() < 1e-14);
        assert!(out[2].abs() < 1e-12);
        let mut out = [0.0; 4];
        b.add(5.0 - 1e-9, &mut out);
        assert!(out.iter().all(|x| x.abs() < 1e-6), "{out:?}");
    }
}
