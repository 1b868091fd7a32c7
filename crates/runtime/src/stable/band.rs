//! A band matrix factorised by Gaussian elimination with partial pivoting: the Newton matrix of the
//! collocation equations of stable inversion is block bidiagonal plus boundary rows.

/// A band matrix with kl sub- and ku super-diagonals in LAPACK's layout (room for the ku + kl super-diagonals
/// that partial pivoting fills in), factorised in place (Golub & Van Loan, *Matrix Computations*, §4.3;
/// LAPACK dgbtf2/dgbtrs).
pub(crate) struct Band {
    n: usize,
    kl: usize,
    ku: usize,
    ld: usize,
    ab: Vec<f64>,
    piv: Vec<usize>,
}

impl Band {
    pub(crate) fn new(n: usize, kl: usize, ku: usize) -> Band {
        let ld = 2 * kl + ku + 1;
        Band {
            n,
            kl,
            ku,
            ld,
            ab: vec![0.0; ld * n],
            piv: vec![0; n],
        }
    }
    pub(crate) fn clear(&mut self) {
        self.ab.fill(0.0);
    }
    #[inline]
    fn at(&self, i: usize, j: usize) -> usize {
        debug_assert!(i + self.kl + self.ku >= j && i <= j + self.kl);
        (self.kl + self.ku + i - j) + j * self.ld
    }
    #[inline]
    pub(crate) fn set(&mut self, i: usize, j: usize, v: f64) {
        let k = self.at(i, j);
        self.ab[k] = v;
    }
    /// LU with partial pivoting; `Err(column)` if singular.
    pub(crate) fn factor(&mut self) -> Result<(), usize> {
        let (n, kl) = (self.n, self.kl);
        let kv = self.kl + self.ku;
        let mut ju = 0;
        for j in 0..n {
            let km = kl.min(n - 1 - j);
            let mut p = 0;
            let mut best = self.ab[self.at(j, j)].abs();
            for i in 1..=km {
                let v = self.ab[self.at(j + i, j)].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            self.piv[j] = j + p;
            if best == 0.0 || !best.is_finite() {
                return Err(j);
            }
            ju = ju.max((j + self.ku + p).min(n - 1));
            if p != 0 {
                for c in j..=ju {
                    let (a, b) = (self.at(j, c), self.at(j + p, c));
                    self.ab.swap(a, b);
                }
            }
            if km > 0 {
                let pivot = self.ab[self.at(j, j)];
                for i in 1..=km {
                    let k = self.at(j + i, j);
                    self.ab[k] /= pivot;
                }
                for c in j + 1..=ju {
                    let u = self.ab[self.at(j, c)];
                    if u != 0.0 {
                        for i in 1..=km {
                            // Row j+i, column c: within the stored band since c − (j+i) ≤ kv.
                            debug_assert!(c <= j + i + kv);
                            let l = self.ab[self.at(j + i, j)];
                            let k = self.at(j + i, c);
                            self.ab[k] -= l * u;
                        }
                    }
                }
            }
        }
        Ok(())
    }
    /// Solve A x = b in place with the factors.
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let (n, kl) = (self.n, self.kl);
        let kv = self.kl + self.ku;
        for j in 0..n {
            let p = self.piv[j];
            if p != j {
                b.swap(j, p);
            }
            let bj = b[j];
            if bj != 0.0 {
                for i in 1..=kl.min(n - 1 - j) {
                    b[j + i] -= self.ab[self.at(j + i, j)] * bj;
                }
            }
        }
        for j in (0..n).rev() {
            b[j] /= self.ab[self.at(j, j)];
            let bj = b[j];
            if bj != 0.0 {
                let first = j.saturating_sub(kv);
                for (i, bi) in b[first..j].iter_mut().enumerate() {
                    *bi -= self.ab[self.at(first + i, j)] * bj;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    #[test]
    fn band_solver_matches_dense() {
        // A random-ish band matrix with kl = 2, ku = 1 and a small diagonal (pivoting needed).
        let (n, kl, ku) = (9, 2, 1);
        let mut band = Band::new(n, kl, ku);
        let mut dense = DMatrix::<f64>::zeros(n, n);
        for i in 0..n {
            for j in i.saturating_sub(kl)..=(i + ku).min(n - 1) {
                let v = ((i * 7 + j * 13) % 11) as f64 - 5.0 + if i == j { 0.01 } else { 0.0 };
                band.set(i, j, v);
                dense[(i, j)] = v;
            }
        }
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = b.clone();
        band.factor().unwrap();
        band.solve(&mut x);
        let expect = dense.lu().solve(&DVector::from_vec(b)).unwrap();
        for i in 0..n {
            assert!(
                (x[i] - expect[i]).abs() < 1e-10,
                "{i}: {} vs {}",
                x[i],
                expect[i]
            );
        }
    }
}
