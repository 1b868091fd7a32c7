//! One step of the s-stage Gauss–Legendre method (s = 2: order 4; s = 4: order 8; A-stable) for the linear,
//! time-varying system Ṡ = A(t) S + B(t), S of ne rows and P columns: the sensitivity equations of the zero
//! dynamics ([`super::pass`], and a run with modes over DOP853's steps).
//!
//! The collocation method of Hairer & Wanner, *Solving Ordinary Differential Equations II*, §IV.5: nodes c_i
//! the zeros of the shifted Legendre polynomial of degree s, a_ij = ∫₀^(c_i) ℓ_j, b_j = ∫₀¹ ℓ_j (ℓ_j the
//! Lagrange polynomials on the nodes); for s = 2 c = 1/2 ∓ √3/6, a = [[1/4, 1/4 − √3/6], [1/4 + √3/6, 1/4]],
//! b = [1/2, 1/2]. For a linear right-hand side the stages K_i = A_i (S + h Σ_j a_ij K_j) + B_i
//! (A_i = A(t + c_i h), likewise B_i) are the linear system (s = 2 written out)
//!
//! ```text
//! [ I − h a11 A1     −h a12 A1  ] [K1]   [A1 S + B1]
//! [   −h a21 A2    I − h a22 A2 ] [K2] = [A2 S + B2],        S(t + h) = S + h Σ_i b_i K_i
//! ```
//!
//! factorised once per step for all P columns ([`Gauss`]). Its stability function is the (s, s) Padé
//! approximation of e^z (s = 2: R(z) = (1 + z/2 + z²/12)/(1 − z/2 + z²/12)), |R(z)| < 1 on the whole open left
//! half-plane (A-stable; Hairer & Wanner II, §IV.3–IV.4), so no step size is too large for a stable A; it is
//! not L-stable (|R(z)| → 1 as z → −∞): beyond hλ ≈ −3.5 (s = 2), where |R| is smallest (0.07), a stiff
//! component is damped less and less.

const SQRT3_6: f64 = 0.288_675_134_594_812_9; // √3/6

/// The nodes c_1, c_2 in [0, 1] where A and B are evaluated (s = 2).
pub(crate) const NODES: [f64; 2] = [0.5 - SQRT3_6, 0.5 + SQRT3_6];

/// The most stages.
const S_MAX: usize = 4;

/// An s-stage tableau's a and b.
type Coefficients<const S: usize> = ([[f64; S]; S], [f64; S]);

/// The 2-stage tableau's a and b as constants (module docs).
const TWO: Coefficients<2> = ([[0.25, 0.25 - SQRT3_6], [0.25 + SQRT3_6, 0.25]], [0.5, 0.5]);

/// The Butcher tableau of the s-stage method (entries beyond s unused).
#[derive(Debug, Clone, Copy)]
struct Tableau {
    s: usize,
    c: [f64; S_MAX],
    a: [[f64; S_MAX]; S_MAX],
    b: [f64; S_MAX],
}

impl Tableau {
    /// s = 2, with its closed-form entries (module docs).
    fn two() -> Tableau {
        let mut t = Tableau {
            s: 2,
            c: [0.0; S_MAX],
            a: [[0.0; S_MAX]; S_MAX],
            b: [0.0; S_MAX],
        };
        t.c[..2].copy_from_slice(&NODES);
        t.a[0][..2].copy_from_slice(&TWO.0[0]);
        t.a[1][..2].copy_from_slice(&TWO.0[1]);
        t.b[..2].copy_from_slice(&TWO.1);
        t
    }

    /// s = 4: the Gauss points ±√(3/7 ∓ (2/7)√(6/5)) of [−1, 1] mapped to [0, 1], weights (18 ± √30)/72, and
    /// a_ij = ∫₀^(c_i) ℓ_j = c_i Σ_q b_q ℓ_j(c_i c_q) (the rule is exact for ℓ_j, of degree 3).
    fn four() -> Tableau {
        let inner = (3.0 / 7.0 - 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
        let outer = (3.0 / 7.0 + 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
        let c = [
            0.5 * (1.0 - outer),
            0.5 * (1.0 - inner),
            0.5 * (1.0 + inner),
            0.5 * (1.0 + outer),
        ];
        let (wo, wi) = ((18.0 - 30f64.sqrt()) / 72.0, (18.0 + 30f64.sqrt()) / 72.0);
        let b = [wo, wi, wi, wo];
        let lagrange = |j: usize, x: f64| -> f64 {
            (0..4)
                .filter(|&m| m != j)
                .map(|m| (x - c[m]) / (c[j] - c[m]))
                .product()
        };
        let mut a = [[0.0; S_MAX]; S_MAX];
        for (i, row) in a.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = c[i] * (0..4).map(|q| b[q] * lagrange(j, c[i] * c[q])).sum::<f64>();
            }
        }
        Tableau { s: 4, c, a, b }
    }
}

/// The stage system is singular or not finite: h·A has an eigenvalue at a pole of the stability function
/// (only possible for an A with eigenvalues in the right half-plane), or A is not finite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Singular;

/// The stage system's matrix and the step's transition matrices, reused from step to step. Every matrix is
/// column-major: entry (i, j) of a matrix of m rows at j·m + i.
///
/// With W = h [b_1 I … b_s I] M⁻¹ = [W1 … Ws] (M the stage matrix of the module doc) the step is
/// S(t + h) = S + W [A1 S + B1; …; As S + Bs] = Φ S + Σ_i W_i B_i with Φ = I + Σ_i W_i A_i: M is factorised once
/// and W found by ne solves with Mᵀ (one per row), and each of the P columns then costs s + 1 ne × ne products.
/// (Plain loops rather than nalgebra's generic LU and products: the matrices are small and the generic code's
/// overhead dominated in unoptimised builds.)
pub(crate) struct Gauss {
    ne: usize,
    np: usize,
    tableau: Tableau,
    m: Vec<f64>,
    piv: Vec<usize>,
    /// 1/U_jj (a product where the backward substitution would divide).
    dinv: Vec<f64>,
    /// W (ne × s·ne), Φ (ne × ne) and a column of length s·ne.
    w: Vec<f64>,
    phi: Vec<f64>,
    x: Vec<f64>,
}

impl Gauss {
    /// The 2-stage method for S of `ne` rows and `np` columns.
    pub(crate) fn new(ne: usize, np: usize) -> Gauss {
        Gauss::with_stages(ne, np, 2)
    }

    /// The `stages`-stage method (2 or 4; any other number is taken as 4) for S of `ne` rows and `np`
    /// columns.
    pub(crate) fn with_stages(ne: usize, np: usize, stages: usize) -> Gauss {
        let tableau = if stages == 2 {
            Tableau::two()
        } else {
            Tableau::four()
        };
        let ns = tableau.s * ne;
        Gauss {
            ne,
            np,
            tableau,
            m: vec![0.0; ns * ns],
            piv: vec![0; ns],
            dinv: vec![0.0; ns],
            w: vec![0.0; ne * ns],
            phi: vec![0.0; ne * ne],
            x: vec![0.0; ns],
        }
    }

    /// The nodes c_1 … c_s in [0, 1] where A and B are wanted.
    pub(crate) fn nodes(&self) -> &[f64] {
        &self.tableau.c[..self.tableau.s]
    }

    /// S ← S(t + h) by one Gauss–Legendre step, `a[i]` = A(t + c_i h) (ne × ne), `b[i]` = B(t + c_i h)
    /// (ne × P), i < s. The common sizes are compiled each with ne a constant (the small loops unrolled); the
    /// 2-stage method (the single-mode pass's, at every step of a stiff run) with its coefficients as
    /// constants.
    pub(crate) fn step(
        &mut self,
        h: f64,
        a: &[&[f64]],
        b: &[&[f64]],
        s: &mut [f64],
    ) -> Result<(), Singular> {
        if self.tableau.s == 2 {
            let (a, b) = ([a[0], a[1]], [b[0], b[1]]);
            return match self.ne {
                1 => self.step_two(1, h, (a, b), s),
                2 => self.step_two(2, h, (a, b), s),
                3 => self.step_two(3, h, (a, b), s),
                4 => self.step_two(4, h, (a, b), s),
                ne => self.step_two(ne, h, (a, b), s),
            };
        }
        self.step_four(h, (a, b), s)
    }

    /// [`Gauss::step`] of the 4-stage method, out of line (the 2-stage arms above stay as small as they were).
    #[inline(never)]
    fn step_four(
        &mut self,
        h: f64,
        (a, b): (&[&[f64]], &[&[f64]]),
        s: &mut [f64],
    ) -> Result<(), Singular> {
        let (a, b): ([&[f64]; S_MAX], [&[f64]; S_MAX]) =
            (std::array::from_fn(|i| a[i]), std::array::from_fn(|i| b[i]));
        match self.ne {
            1 => self.step_sized::<S_MAX>(1, h, (&a, &b), s),
            2 => self.step_sized::<S_MAX>(2, h, (&a, &b), s),
            ne => self.step_sized::<S_MAX>(ne, h, (&a, &b), s),
        }
    }

    /// [`Gauss::step`] of the 2-stage method for ne = `self.ne`, inlined into each of its arms: b = (1/2, 1/2)
    /// and a as constants ([`TWO`]), the columns walked in chunks (no index checks in the loops).
    #[inline(always)]
    fn step_two(
        &mut self,
        ne: usize,
        h: f64,
        (a, b): ([&[f64]; 2], [&[f64]; 2]),
        s: &mut [f64],
    ) -> Result<(), Singular> {
        self.transition::<2>(ne, h, (a, TWO))?;
        let (w, phi, x) = (
            &self.w[..2 * ne * ne],
            &self.phi[..ne * ne],
            &mut self.x[..ne],
        );
        let (b0, b1) = (&b[0][..self.np * ne], &b[1][..self.np * ne]);
        for ((sc, b0), b1) in s[..self.np * ne]
            .chunks_exact_mut(ne)
            .zip(b0.chunks_exact(ne))
            .zip(b1.chunks_exact(ne))
        {
            for (row, v) in x.iter_mut().enumerate() {
                let mut sum = 0.0;
                for j in 0..ne {
                    sum += phi[j * ne + row] * sc[j]
                        + w[j * ne + row] * b0[j]
                        + w[(ne + j) * ne + row] * b1[j];
                }
                *v = sum;
            }
            sc.copy_from_slice(x);
        }
        Ok(())
    }

    /// [`Gauss::step`] for ne = `self.ne` and s = `S` stages with the tableau's coefficients.
    #[inline(always)]
    fn step_sized<const S: usize>(
        &mut self,
        ne: usize,
        h: f64,
        (a, b): (&[&[f64]; S], &[&[f64]; S]),
        s: &mut [f64],
    ) -> Result<(), Singular> {
        let tab = self.tableau;
        let coefficients: Coefficients<S> = (
            std::array::from_fn(|i| std::array::from_fn(|j| tab.a[i][j])),
            std::array::from_fn(|i| tab.b[i]),
        );
        self.transition::<S>(ne, h, (*a, coefficients))?;
        let (w, phi, x) = (
            &self.w[..S * ne * ne],
            &self.phi[..ne * ne],
            &mut self.x[..ne],
        );
        let np = self.np;
        for (c, sc) in s[..np * ne].chunks_exact_mut(ne).enumerate() {
            for (row, v) in x.iter_mut().enumerate() {
                let mut sum = 0.0;
                for j in 0..ne {
                    let mut term = phi[j * ne + row] * sc[j];
                    for (i, bi) in b.iter().enumerate() {
                        term += w[(i * ne + j) * ne + row] * bi[c * ne + j];
                    }
                    sum += term;
                }
                *v = sum;
            }
            sc.copy_from_slice(x);
        }
        Ok(())
    }

    /// W = h [b_1 I … b_s I] M⁻¹ row by row (Mᵀ solves by the LU factors) and Φ = I + Σ_i W_i A_i.
    #[inline(always)]
    fn transition<const S: usize>(
        &mut self,
        ne: usize,
        h: f64,
        (a, (ca, cb)): ([&[f64]; S], Coefficients<S>),
    ) -> Result<(), Singular> {
        let ns = S * ne;
        // Block (i, j) of M is δ_ij I − h a_ij A_i: entry (i·ne + k, j·ne + l) at (j·ne + l)·ns + i·ne + k.
        for (j, block_column) in self.m[..ns * ns].chunks_exact_mut(ne * ns).enumerate() {
            for (l, column) in block_column.chunks_exact_mut(ns).enumerate() {
                for (i, (block, ai)) in column.chunks_exact_mut(ne).zip(a).enumerate() {
                    let f = h * ca[i][j];
                    for ((v, &ak), k) in block.iter_mut().zip(&ai[l * ne..(l + 1) * ne]).zip(0..) {
                        let unit = if i == j && k == l { 1.0 } else { 0.0 };
                        *v = unit - f * ak;
                    }
                }
            }
        }
        factor(&mut self.m[..ns * ns], ns, &mut self.piv[..ns])?;
        for (j, d) in self.dinv[..ns].iter_mut().enumerate() {
            *d = 1.0 / self.m[j * ns + j];
        }
        // Row r of W is h Σ_i b_i e_(i·ne+r)ᵀ M⁻¹: Mᵀ y = h Σ_i b_i e_(i·ne+r), ne solves with Mᵀ.
        let (m, piv, dinv) = (&self.m[..ns * ns], &self.piv[..ns], &self.dinv[..ns]);
        let (x, w) = (&mut self.x[..ns], &mut self.w[..ns * ne]);
        for row in 0..ne {
            x.fill(0.0);
            for (i, bi) in cb.iter().enumerate() {
                x[i * ne + row] = bi * h;
            }
            solve_transposed(m, ns, (piv, dinv), x);
            for (k, &y) in x.iter().enumerate() {
                w[k * ne + row] = y;
            }
        }
        for (col, phi_column) in self.phi[..ne * ne].chunks_exact_mut(ne).enumerate() {
            for (row, v) in phi_column.iter_mut().enumerate() {
                let mut sum = if row == col { 1.0 } else { 0.0 };
                for (i, ai) in a.iter().enumerate() {
                    for l in 0..ne {
                        sum += w[(i * ne + l) * ne + row] * ai[col * ne + l];
                    }
                }
                *v = sum;
            }
        }
        Ok(())
    }
}

/// LU factorisation with partial pivoting of the n × n column-major `m` in place, PM = LU (L unit lower
/// triangular below the diagonal, U on and above it; Golub & Van Loan, *Matrix Computations*, Alg. 3.4.1):
/// `piv[j]` the row swapped with row j at step j.
#[inline(always)]
fn factor(m: &mut [f64], n: usize, piv: &mut [usize]) -> Result<(), Singular> {
    for j in 0..n {
        let column = &m[j * n..(j + 1) * n];
        let mut p = j;
        for i in j + 1..n {
            if column[i].abs() > column[p].abs() {
                p = i;
            }
        }
        let pivot = column[p];
        if pivot == 0.0 || !pivot.is_finite() {
            return Err(Singular);
        }
        piv[j] = p;
        if p != j {
            for c in 0..n {
                m.swap(c * n + j, c * n + p);
            }
        }
        let inverse = 1.0 / pivot;
        for v in &mut m[j * n + j + 1..(j + 1) * n] {
            *v *= inverse;
        }
        let (left, right) = m.split_at_mut((j + 1) * n);
        let l = &left[j * n + j + 1..(j + 1) * n];
        for c in right.chunks_exact_mut(n) {
            let u = c[j];
            if u != 0.0 {
                for (v, li) in c[j + 1..].iter_mut().zip(l) {
                    *v -= li * u;
                }
            }
        }
    }
    Ok(())
}

/// x ← M⁻ᵀ x from [`factor`]'s LU of M (PM = LU, so Mᵀ = Uᵀ Lᵀ P) and the reciprocals `dinv` of U's diagonal:
/// Uᵀ w = x forward, Lᵀ v = w backward, x = Pᵀ v (the row swaps undone in reverse order). Each step is a dot
/// product of a column of the factors, contiguous in the column-major `m`.
#[inline(always)]
fn solve_transposed(m: &[f64], n: usize, (piv, dinv): (&[usize], &[f64]), x: &mut [f64]) {
    for i in 0..n {
        let column = &m[i * n..i * n + i];
        let dot: f64 = column.iter().zip(&x[..i]).map(|(u, w)| u * w).sum();
        x[i] = (x[i] - dot) * dinv[i];
    }
    for i in (0..n).rev() {
        let column = &m[i * n + i + 1..(i + 1) * n];
        let dot: f64 = column.iter().zip(&x[i + 1..]).map(|(l, v)| l * v).sum();
        x[i] -= dot;
    }
    for (j, &p) in piv.iter().enumerate().rev() {
        x.swap(j, p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// Mᵀ y = x by the LU factors of M, for a matrix whose factorisation swaps rows (a zero leading entry).
    #[test]
    fn the_transposed_solve_inverts_m_transposed() {
        let m0 = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 2.0, 1.0, -1.0, 3.0, 1.0, 0.5, 2.0, -1.0, 4.0, 2.0, 0.0, 2.0, -3.0, 1.0, 5.0,
            ],
        );
        let (mut m, mut piv) = (m0.as_slice().to_vec(), vec![0; 4]);
        factor(&mut m, 4, &mut piv).expect("regular");
        assert_ne!(piv[0], 0, "a row swap at the first step");
        let dinv: Vec<f64> = (0..4).map(|j| 1.0 / m[j * 4 + j]).collect();
        let x = [1.0, -2.0, 0.5, 3.0];
        let mut y = x.to_vec();
        solve_transposed(&m, 4, (&piv, &dinv), &mut y);
        let back = m0.transpose() * DMatrix::from_column_slice(4, 1, &y);
        for (b, v) in back.iter().zip(x) {
            assert!((b - v).abs() < 1e-13, "{back} against {x:?}");
        }
    }

    /// n steps of h from S(0) = s0 for Ṡ = A(t) S + B(t) by the 2-stage method.
    fn integrate(
        a: impl Fn(f64) -> DMatrix<f64>,
        b: impl Fn(f64) -> DMatrix<f64>,
        s0: DMatrix<f64>,
        (h, n): (f64, usize),
    ) -> DMatrix<f64> {
        integrate_with(2, a, b, s0, (h, n))
    }

    /// n steps of h from S(0) = s0 for Ṡ = A(t) S + B(t) by the `stages`-stage method.
    fn integrate_with(
        stages: usize,
        a: impl Fn(f64) -> DMatrix<f64>,
        b: impl Fn(f64) -> DMatrix<f64>,
        s0: DMatrix<f64>,
        (h, n): (f64, usize),
    ) -> DMatrix<f64> {
        let mut s = s0;
        let mut gauss = Gauss::with_stages(s.nrows(), s.ncols(), stages);
        let nodes = gauss.nodes().to_vec();
        for k in 0..n {
            let t = k as f64 * h;
            let am: Vec<DMatrix<f64>> = nodes.iter().map(|c| a(t + c * h)).collect();
            let bm: Vec<DMatrix<f64>> = nodes.iter().map(|c| b(t + c * h)).collect();
            let a: Vec<&[f64]> = am.iter().map(|m| m.as_slice()).collect();
            let b: Vec<&[f64]> = bm.iter().map(|m| m.as_slice()).collect();
            gauss.step(h, &a, &b, s.as_mut_slice()).expect("regular");
        }
        s
    }

    /// The 4-stage tableau satisfies the collocation conditions it is built from, checked independently:
    /// Σ_j a_ij c_j^(q−1) = c_i^q/q and Σ_j b_j c_j^(q−1) = 1/q for q = 1 … 4 (Hairer & Wanner II, §IV.5,
    /// C(4) and B(8): the weights integrate degree 7 exactly, here q up to 8).
    #[test]
    fn the_four_stage_tableau_is_the_collocation_method() {
        let t = Tableau::four();
        for q in 1..=4 {
            for i in 0..4 {
                let lhs: f64 = (0..4).map(|j| t.a[i][j] * t.c[j].powi(q - 1)).sum();
                let rhs = t.c[i].powi(q) / q as f64;
                assert!((lhs - rhs).abs() < 1e-15, "C({q}) row {i}: {lhs} vs {rhs}");
            }
        }
        for q in 1..=8 {
            let lhs: f64 = (0..4).map(|j| t.b[j] * t.c[j].powi(q - 1)).sum();
            assert!((lhs - 1.0 / q as f64).abs() < 1e-15, "B({q}): {lhs}");
        }
    }

    /// Order 8: on Ṡ = λS + cos t (λ = −3, t ∈ [0, 1]) halving h divides the 4-stage method's error by
    /// 2⁸ = 256 (the second halving reaches rounding and is not checked); and the stiff case at hλ = −30 is
    /// stable and accurate.
    #[test]
    fn the_four_stage_method_converges_with_order_eight() {
        let run = |lambda: f64, hn: (f64, usize)| {
            let (s, exact) = scalar_with(4, lambda, hn);
            (s - exact).abs()
        };
        let (e1, e2) = (run(-3.0, (0.5, 2)), run(-3.0, (0.25, 4)));
        let order = (e1 / e2).log2();
        assert!(
            (7.5..8.7).contains(&order),
            "order {order} ({e1:e}, {e2:e})"
        );
        assert!(run(-300.0, (0.1, 100)) < 1e-9);
    }

    /// Ṡ = λS + cos t, S(0) = 1: S(t) = (1 − S_p(0)) e^{λt} + S_p(t) with the particular solution
    /// S_p(t) = (sin t − λ cos t)/(λ² + 1) (substitute: Ṡ_p − λ S_p = cos t).
    fn scalar(lambda: f64, hn: (f64, usize)) -> (f64, f64) {
        scalar_with(2, lambda, hn)
    }

    /// [`scalar`] by the `stages`-stage method.
    fn scalar_with(stages: usize, lambda: f64, (h, n): (f64, usize)) -> (f64, f64) {
        let sp = |t: f64| (t.sin() - lambda * t.cos()) / (lambda * lambda + 1.0);
        let t = h * n as f64;
        let exact = (1.0 - sp(0.0)) * (lambda * t).exp() + sp(t);
        let s = integrate_with(
            stages,
            |_| DMatrix::from_element(1, 1, lambda),
            |t| DMatrix::from_element(1, 1, t.cos()),
            DMatrix::from_element(1, 1, 1.0),
            (h, n),
        );
        (s[(0, 0)], exact)
    }

    /// Order 4: on Ṡ = λS + cos t (λ = −3, over t ∈ [0, 1]) halving h divides the error by 2⁴ = 16.
    #[test]
    fn scalar_forced_decay_converges_with_order_four() {
        let errors: Vec<f64> = [10, 20, 40, 80]
            .iter()
            .map(|&n| {
                let (s, exact) = scalar(-3.0, (1.0 / n as f64, n));
                (s - exact).abs()
            })
            .collect();
        for w in errors.windows(2) {
            let ratio = w[0] / w[1];
            assert!((14.0..18.0).contains(&ratio), "{errors:?}");
        }
        assert!(errors[3] < 1e-9, "{errors:?}");
    }

    /// λ = −300, the driveline shaft's eigenvalue: at h = 0.011 (hλ = −3.3, DOPRI5's stability border, where
    /// the pass's steps sit) 100 steps follow the exact solution to 3.0e-11 (of S ≈ 1.5e-3), and halving h
    /// twice divides the error by 16 each time (1.9e-12, 1.2e-13): order 4 already there. At h = 0.1
    /// (hλ = −30, ten times beyond the border) it stays stable: R(−30) = 0.67, the transient's
    /// 0.67¹⁰⁰ ≈ 4e-18 is gone and the error of following the forced solution is 7.2e-8.
    #[test]
    fn scalar_stiff_decay_is_accurate_at_the_border_and_stable_beyond() {
        let errors: Vec<f64> = [(0.011, 100), (0.0055, 200), (0.00275, 400)]
            .iter()
            .map(|&(h, n)| {
                let (s, exact) = scalar(-300.0, (h, n));
                (s - exact).abs()
            })
            .collect();
        assert!(errors[0] < 4e-11, "{errors:?}");
        for w in errors.windows(2) {
            let ratio = w[0] / w[1];
            assert!((14.0..18.0).contains(&ratio), "{errors:?}");
        }
        let (s, exact) = scalar(-300.0, (0.1, 100));
        assert!((s - exact).abs() < 1e-7, "{s:e} vs {exact:e}");
    }

    /// Ṡ = A S + B with A = [[−d, ω], [−ω, −d]] (a lightly damped rotation: eigenvalues −d ± iω, the 2 Hz
    /// body mode's kind) and constant B (two columns): S(t) = e^{At}(S0 + A⁻¹B) − A⁻¹B with
    /// e^{At} = e^{−dt} [[cos ωt, sin ωt], [−sin ωt, cos ωt]]. Order 4 by halving h over t ∈ [0, 1], and
    /// stable over 100 periods at ω h = 1.
    #[test]
    fn damped_rotation_converges_with_order_four_and_stays_stable() {
        let (d, w) = (1.27, 4.0 * std::f64::consts::PI);
        let a = DMatrix::from_row_slice(2, 2, &[-d, w, -w, -d]);
        let b = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.5, -2.0]);
        let s0 = DMatrix::from_row_slice(2, 2, &[0.3, 1.0, -0.7, 0.0]);
        let shift = a.clone().try_inverse().expect("regular") * &b;
        let exact = |t: f64| {
            let (c, s) = ((w * t).cos(), (w * t).sin());
            let e = (-d * t).exp() * DMatrix::from_row_slice(2, 2, &[c, s, -s, c]);
            e * (&s0 + &shift) - &shift
        };
        let error = |h: f64, n: usize| {
            let s = integrate(|_| a.clone(), |_| b.clone(), s0.clone(), (h, n));
            (s - exact(h * n as f64)).amax()
        };
        let errors: Vec<f64> = [50, 100, 200, 400]
            .iter()
            .map(|&n| error(1.0 / n as f64, n))
            .collect();
        for e in errors.windows(2) {
            let ratio = e[0] / e[1];
            assert!((14.0..18.0).contains(&ratio), "{errors:?}");
        }
        // 100 periods (t = 50 s) at h = 1/ω: the exact solution is −A⁻¹B to 3e-28; the method's damping
        // |R(h(−d ± iω))|ⁿ is not quite e^{−dt} but below 1, so it converges there too.
        let h = 1.0 / w;
        let n = (50.0 / h) as usize;
        let s = integrate(|_| a.clone(), |_| b.clone(), s0.clone(), (h, n));
        assert!((&s + &shift).amax() < 1e-12, "{s}");
    }

    /// A time-varying A: Ṡ = λ(t) S with λ(t) = −k (1 + sin t / 2), S(0) = 1, so
    /// S(t) = exp(−k (t + (1 − cos t)/2)), over t ∈ [0, 1]. k = 3: halving h from 1/10 divides the error by 16
    /// (2.5e-6, 1.6e-7, 9.8e-9, 6.1e-10). k = 300 at h = 1/91 (hλ from −3.3 to −4.6): the exact S(1) is
    /// 6e-161, the method's 1e-100 (each step damps by |R(hλ)| ≤ 0.1; Gauss–Legendre is A- but not L-stable,
    /// R(−∞) = 1, so at far larger steps it would damp less).
    #[test]
    fn time_varying_coefficient_converges_with_order_four_and_stays_stable() {
        let run = |k: f64, n: usize| {
            let lambda = |t: f64| DMatrix::from_element(1, 1, -k * (1.0 + 0.5 * t.sin()));
            let zero = |_| DMatrix::zeros(1, 1);
            let s0 = DMatrix::from_element(1, 1, 1.0);
            integrate(lambda, zero, s0, (1.0 / n as f64, n))[(0, 0)]
        };
        let exact = (-3.0 * (1.0 + 0.5 * (1.0 - 1.0_f64.cos()))).exp();
        let errors: Vec<f64> = [10, 20, 40, 80]
            .iter()
            .map(|&n| (run(3.0, n) - exact).abs())
            .collect();
        for w in errors.windows(2) {
            let ratio = w[0] / w[1];
            assert!((14.0..18.0).contains(&ratio), "{errors:?}");
        }
        let stiff = run(300.0, 91);
        assert!((0.0..1e-90).contains(&stiff), "{stiff:e}");
    }
}
