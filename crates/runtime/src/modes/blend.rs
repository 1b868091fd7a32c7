//! The re-entry transition: after a mode switch the reference starts from the ξ that the continuous state
//! gives in the new mode and joins the smoothed cycle within the transition time T.
//!
//! With τ = t − t_s and the initial deviations e_j = ξ_{j+1} − y_c^(j)(t_s) (j < r), the reference is
//! y = y_c + e(τ) with e(τ) = (1 − S(τ/T)) · Σ_j e_j τ^j / j! on [0, T] and e = 0 after, where S is the
//! smoothstep polynomial of order m = r + 1 (S(0) = 0, S(1) = 1, S^(i)(0) = S^(i)(1) = 0 for i = 1 … m;
//! S(s) = s^(m+1) Σ_{k=0}^{m} C(m+k, k) C(2m+1, m−k) (−s)^k). So y^(j)(t_s) = ξ_{j+1} for j < r,
//! y^(r)(t_s) = y_c^(r)(t_s) (the input stays finite), and e has a zero of order r + 2 at τ = T: the
//! reference is C^(r+1) where it joins the cycle. e is a polynomial, so its derivatives are exact.

/// Binomial coefficient as a float (small arguments).
fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

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
    /// switch: the run evaluates the blend at every stage of every step of the transition).
    derivatives: Vec<Vec<f64>>,
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
        if !(0.0..self.duration).contains(&tau) {
            return;
        }
        for (o, c) in out.iter_mut().zip(&self.derivatives) {
            *o += c.iter().rev().fold(0.0, |acc, &ci| acc * tau + ci);
        }
    }
}

/// The polynomial with coefficients `c` (ascending powers) and each of its derivatives down to the constant
/// one: d/dτ Σ c_i τ^i = Σ_{i ≥ 1} i c_i τ^(i−1).
fn derivatives(c: Vec<f64>) -> Vec<Vec<f64>> {
    let mut out = vec![c];
    while let Some(last) = out.last().filter(|c| c.len() > 1) {
        let next: Vec<f64> = last
            .iter()
            .enumerate()
            .skip(1)
            .map(|(i, ci)| ci * i as f64)
            .collect();
        out.push(next);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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
