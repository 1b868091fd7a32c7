//! The chain rule at one point of a run: how x = ψ⁻¹(ξ, η) and the input u move when η or a parameter moves,
//! and so how the internal states' right-hand sides and the outputs move (implicit function theorem).
//!
//! With ξ, y^(r) and the signals w fixed by the reference, x solves ψ(x; p) = (ξ, η) and u solves
//! φ(x, u; p) = y^(r) (φ = α_x + β_x·u where y^(r) is affine in u). Differentiating both:
//!
//! ```text
//! (∂ψ/∂x) dx = (0, dη) − (∂ψ/∂p) dp          (the η rows of ψ are states, η_j = x_{s_j}: parameter-free)
//! du = −(∂φ/∂x · dx + ∂φ/∂p · dp) / (∂φ/∂u)
//! d row = ∂row/∂x · dx + ∂row/∂u · du + ∂row/∂p · dp   (row: an internal state's rhs, or an output)
//! ```
//!
//! (Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1 for ψ; the implicit function theorem e.g. Rudin,
//! *Principles of Mathematical Analysis*, Thm. 9.28.)
//!
//! The "parameters" p_k are the model's P parameters (k < P) and the grid values asked for (k = P + g, the
//! columns [`GridColumns`] builds at the point): every formula here takes the one as the other.

use std::cell::RefCell;

use invsim_model_api::{InverseModel, ModelError, SensitivityLayout};

use super::grid_columns::GridColumns;

/// The partial derivatives at one point (x, w, u) and the inverse of ∂ψ/∂x (n is small: every direction is
/// then a product with it, without a factorisation or an allocation per direction).
pub(crate) struct Point {
    layout: SensitivityLayout,
    sens: Vec<f64>,
    /// The grid values' columns, `grid[row · n_grid + g]` = ∂row/∂v_g ([`GridColumns::fill`]).
    grid: Vec<f64>,
    n_grid: usize,
    /// (∂ψ/∂x)⁻¹, row-major; NaN where ∂ψ/∂x is singular.
    inverse: Vec<f64>,
    /// A work vector of length n, reused: a direction's right-hand side, a row's (∂ψ/∂x)⁻ᵀ g.
    b: RefCell<Vec<f64>>,
    /// ∂ψ/∂x's buffer, kept for the next point.
    jac: Vec<f64>,
    /// The basis weights' buffer of [`GridColumns::fill`], kept for the next point.
    weights: Vec<(usize, f64)>,
}

/// The buffers of a point, reused from point to point ([`Point::into_buffer`]): nothing is allocated per point
/// once they have their sizes.
#[derive(Default)]
pub(crate) struct Buffers {
    sens: Vec<f64>,
    grid: Vec<f64>,
    weights: Vec<(usize, f64)>,
    jac: Vec<f64>,
    inverse: Vec<f64>,
    work: Vec<f64>,
}

/// The outputs of [`Point::jacobians`]: A, B and (where asked) the reference's columns.
type Jacobians<'o> = (&'o mut [f64], &'o mut [f64], Option<&'o mut [f64]>);

/// A direction of change at a point: dx and du.
pub(crate) struct Direction {
    pub dx: Vec<f64>,
    pub du: f64,
}

impl Point {
    /// The model's partial derivatives at (x, w, u), with the columns of the grid values `grid`; `eta_states`
    /// are the states chosen as η. `buffers`: those of an earlier point ([`Point::into_buffer`]) or new ones.
    pub(crate) fn new<M: InverseModel + ?Sized>(
        model: &M,
        (x, w, u): (&[f64], &[f64], f64),
        (eta_states, columns): (&[usize], &GridColumns),
        buffers: Buffers,
    ) -> Result<Point, ModelError> {
        let info = model.info();
        let layout = SensitivityLayout::of(info);
        let Buffers {
            mut sens,
            mut grid,
            mut weights,
            mut jac,
            mut inverse,
            mut work,
        } = buffers;
        sens.resize(layout.len(), 0.0);
        model.sensitivity(x, w, u, &mut sens)?;
        let maps = (model.maps(), info.map_calls.as_slice());
        columns.fill(maps, (&layout, &sens), &mut weights, &mut grid);
        let n = layout.n;
        inverse.resize(n * n, 0.0);
        let psi = (&layout, &sens[..], eta_states);
        if !invert_psi(psi, (&mut jac, &mut work), &mut inverse) {
            inverse.fill(f64::NAN);
        }
        work.resize(n, 0.0);
        Ok(Point {
            layout,
            sens,
            grid,
            n_grid: columns.len(),
            inverse,
            b: RefCell::new(work),
            jac,
            weights,
        })
    }

    /// The buffers, to reuse for the next point.
    pub(crate) fn into_buffer(self) -> Buffers {
        Buffers {
            sens: self.sens,
            grid: self.grid,
            weights: self.weights,
            jac: self.jac,
            inverse: self.inverse,
            work: self.b.into_inner(),
        }
    }

    fn d(&self, row: usize, column: usize) -> f64 {
        self.sens[self.layout.at(row, column)]
    }

    /// ∂row/∂p_k: a model parameter's column (k < P), grid value k − P's (k < P + G), or else the value of
    /// signal k − P − G (a decided input, moved like a parameter).
    fn dp(&self, row: usize, k: usize) -> f64 {
        let np = self.layout.n_params;
        if k < np {
            self.d(row, self.layout.param(k))
        } else if k < np + self.n_grid {
            self.grid[row * self.n_grid + k - np]
        } else {
            self.d(row, self.layout.signal(k - np - self.n_grid))
        }
    }

    /// dx and du for a change dη of the internal coordinates and (`param`) a unit change of parameter k.
    /// NaN where ∂ψ/∂x is singular.
    pub(crate) fn direction(&self, deta: &[f64], param: Option<usize>) -> Direction {
        let mut dir = Direction {
            dx: vec![0.0; self.layout.n],
            du: 0.0,
        };
        self.direction_into(deta, param, &mut dir);
        dir
    }

    /// [`Point::direction`] into `dir` (its `dx` of length n), without allocating.
    pub(crate) fn direction_into(&self, deta: &[f64], param: Option<usize>, dir: &mut Direction) {
        self.moved_into(&[], 0.0, deta, param, dir);
    }

    /// dx and du where the reference moves too: dξ (`dxi`, the first r of ξ; missing entries 0) and dy^(r)
    /// (`dyr`), as a re-entry's transition moves it with the state it started from (`crate::modes`):
    /// (∂ψ/∂x) dx = (dξ − ∂ψ_ξ/∂p dp, dη), du = (dy^(r) − ∂φ/∂x · dx − ∂φ/∂p dp)/(∂φ/∂u).
    pub(crate) fn moved_into(
        &self,
        dxi: &[f64],
        dyr: f64,
        deta: &[f64],
        param: Option<usize>,
        dir: &mut Direction,
    ) {
        let l = &self.layout;
        let (n, r) = (l.n, l.r);
        let mut b = self.b.borrow_mut();
        for (i, bi) in b.iter_mut().enumerate() {
            *bi = if i < r {
                dxi.get(i).copied().unwrap_or(0.0) - param.map_or(0.0, |k| self.dp(l.psi(i), k))
            } else {
                deta[i - r]
            };
        }
        for (dx, row) in dir.dx.iter_mut().zip(self.inverse.chunks_exact(n)) {
            *dx = row.iter().zip(b.iter()).map(|(a, v)| a * v).sum();
        }
        let phi = l.phi();
        let mut num = param.map_or(0.0, |k| self.dp(phi, k)) - dyr;
        for (j, v) in dir.dx.iter().enumerate() {
            num += self.d(phi, l.x(j)) * v;
        }
        dir.du = -num / self.d(phi, l.u());
    }

    /// The change of `row` along `dir` (with the unit change of parameter `param`, if any).
    pub(crate) fn row_change(&self, row: usize, dir: &Direction, param: Option<usize>) -> f64 {
        let l = &self.layout;
        let mut v = param.map_or(0.0, |k| self.dp(row, k)) + self.d(row, l.u()) * dir.du;
        for (j, dx) in dir.dx.iter().enumerate() {
            v += self.d(row, l.x(j)) * dx;
        }
        v
    }

    /// A = ∂q/∂η (ne × ne) and B = ∂q/∂p (ne × P, the parameters `params`) of the internal states' right-hand
    /// sides q_i = F_(η_i)(x, w, u; p), through x and u, into `a` and `b` ([`Point::row_jacobians`] of the η
    /// rows).
    pub(crate) fn eta_jacobians(&self, params: &[usize], a: &mut [f64], b: &mut [f64]) {
        let l = &self.layout;
        let rows: Vec<usize> = (0..l.n_eta).map(|i| l.eta(i)).collect();
        self.row_jacobians(&rows, params, a, b);
    }

    /// ∂q/∂η (m × ne) and ∂q/∂p (m × P, the parameters `params`) of the rows q_i (`rows`: η right-hand sides or
    /// outputs, m of them) through x and u (the directions of the module doc, all at once, the adjoint way: one
    /// product with (∂ψ/∂x)⁻ᵀ per row, then r + 2 terms per parameter): with
    /// g_i = ∂q_i/∂x − (∂q_i/∂u / ∂φ/∂u) ∂φ/∂x and m_i = (∂ψ/∂x)⁻ᵀ g_i,
    ///
    /// ```text
    /// A_ij = m_i[r + j],   B_ic = ∂q_i/∂p_c − (∂q_i/∂u / ∂φ/∂u) ∂φ/∂p_c − Σ_(l<r) m_i[l] ∂ψ_l/∂p_c
    /// ```
    ///
    /// into `a` and `b`, column-major (entry (i, j) at j·m + i).
    pub(crate) fn row_jacobians(
        &self,
        rows: &[usize],
        params: &[usize],
        a: &mut [f64],
        b: &mut [f64],
    ) {
        self.jacobians(rows, params.iter().map(|&k| Some(k)), (a, b, None));
    }

    /// [`Point::row_jacobians`] for parameters that may be missing from the model (`None`: a zero column of
    /// B), and the rows' derivatives with respect to the reference, `reference` (m × (r + 1), column-major):
    /// ∂q_i/∂ξ_l = m_i[l] for l < r and ∂q_i/∂y^(r) = ∂q_i/∂u / ∂φ/∂u, so that a move of the reference
    /// (dξ, dy^(r)) and of p changes q_i by Σ_l m_i[l] dξ_l + (∂q_i/∂u / ∂φ/∂u) dy^(r) + B_i dp (the
    /// directions of [`Point::moved_into`]).
    pub(crate) fn moved_row_jacobians(
        &self,
        rows: &[usize],
        params: &[Option<usize>],
        (a, b): (&mut [f64], &mut [f64]),
        reference: &mut [f64],
    ) {
        self.jacobians(rows, params.iter().copied(), (a, b, Some(reference)));
    }

    /// The formulas of [`Point::row_jacobians`] and [`Point::moved_row_jacobians`]; the common numbers of
    /// states are compiled each with n a constant (the loops over the states unrolled).
    fn jacobians<I>(&self, rows: &[usize], params: I, out: Jacobians<'_>)
    where
        I: Iterator<Item = Option<usize>> + Clone,
    {
        match self.layout.n {
            1 => self.jacobians_sized(1, rows, params, out),
            2 => self.jacobians_sized(2, rows, params, out),
            3 => self.jacobians_sized(3, rows, params, out),
            4 => self.jacobians_sized(4, rows, params, out),
            5 => self.jacobians_sized(5, rows, params, out),
            6 => self.jacobians_sized(6, rows, params, out),
            n => self.jacobians_sized(n, rows, params, out),
        }
    }

    /// [`Point::jacobians`] for n = `self.layout.n`, inlined into each of its arms.
    #[inline(always)]
    fn jacobians_sized<I>(
        &self,
        n: usize,
        rows: &[usize],
        params: I,
        (a, b, mut reference): Jacobians<'_>,
    ) where
        I: Iterator<Item = Option<usize>> + Clone,
    {
        let l = &self.layout;
        let (r, ne, w) = (l.r, l.n_eta, l.width());
        let nr = rows.len();
        // The ψ rows are the slice's first r (`SensitivityLayout::psi`), φ's the next.
        let (psi, rest) = self.sens.split_at(r * w);
        let phi = &rest[..w];
        let mut m = self.b.borrow_mut();
        let m = &mut m[..n];
        for (i, &row) in rows.iter().enumerate() {
            let q = &self.sens[row * w..(row + 1) * w];
            let ratio = q[l.u()] / phi[l.u()];
            // m = (∂ψ/∂x)⁻ᵀ g, g_j = ∂q/∂x_j − ratio·∂φ/∂x_j (∂/∂x_j is column j).
            m.fill(0.0);
            for (j, inverse_row) in self.inverse[..n * n].chunks_exact(n).enumerate() {
                let g = q[j] - ratio * phi[j];
                for (mk, v) in m.iter_mut().zip(inverse_row) {
                    *mk += g * v;
                }
            }
            for (j, &mj) in m[r..r + ne].iter().enumerate() {
                a[j * nr + i] = mj;
            }
            if let Some(reference) = reference.as_deref_mut() {
                for (li, &ml) in m[..r].iter().enumerate() {
                    reference[li * nr + i] = ml;
                }
                reference[r * nr + i] = ratio;
            }
            for (c, k) in params.clone().enumerate() {
                b[c * nr + i] = match k {
                    None => 0.0,
                    Some(k) if k < l.n_params => {
                        let col = l.param(k);
                        let mut v = q[col] - ratio * phi[col];
                        for (li, ml) in m[..r].iter().enumerate() {
                            v -= ml * psi[li * w + col];
                        }
                        v
                    }
                    Some(k) if k < l.n_params + self.n_grid => {
                        self.grid_b(row, k - l.n_params, (&m[..r], ratio))
                    }
                    Some(k) => {
                        let mut v = self.dp(row, k) - ratio * self.dp(l.phi(), k);
                        for (li, ml) in m[..r].iter().enumerate() {
                            v -= ml * self.dp(l.psi(li), k);
                        }
                        v
                    }
                };
            }
        }
    }

    /// [`Point::row_jacobians`]' B entry of `row` for grid value g: ∂q/∂v_g − ratio·∂φ/∂v_g − Σ_l m_l ∂ψ_l/∂v_g.
    fn grid_b(&self, row: usize, g: usize, (m, ratio): (&[f64], f64)) -> f64 {
        let l = &self.layout;
        let col = |row: usize| self.grid[row * self.n_grid + g];
        let mut v = col(row) - ratio * col(l.phi());
        for (psi, ml) in m.iter().enumerate() {
            v -= ml * col(l.psi(psi));
        }
        v
    }

    pub(crate) fn layout(&self) -> &SensitivityLayout {
        &self.layout
    }
}

/// (∂ψ/∂x)⁻¹ into `inverse` (n × n, row-major: row s is state x_s's), from the block structure of ∂ψ/∂x: its
/// η rows are the unit rows e_(s_j) (η_j = x_(s_j)), so with C the other r states (in order) and J_C, J_E the
/// ξ rows' partial derivatives by them and by the η states, (∂ψ/∂x) dx = (b_ξ, b_η) is solved by
///
/// ```text
/// dx_C = J_C⁻¹ (b_ξ − J_E b_η),   dx_(s_j) = b_η,j
/// ```
///
/// and only the r × r matrix J_C is inverted ([`invert`]; for r = n it is ∂ψ/∂x itself). `jac` and `block`
/// are buffers; false where J_C is singular or not finite.
fn invert_psi(
    (l, sens, eta_states): (&SensitivityLayout, &[f64], &[usize]),
    (jac, block): (&mut Vec<f64>, &mut Vec<f64>),
    inverse: &mut [f64],
) -> bool {
    let (n, r) = (l.n, l.r);
    // The ξ-block's states C, in order (r of them: n = r + n_η).
    let xi_states = || (0..n).filter(|s| !eta_states.contains(s)).take(r);
    jac.clear();
    jac.resize(r * r, 0.0);
    for (a, column) in xi_states().enumerate() {
        for i in 0..r {
            jac[i * r + a] = sens[l.at(l.psi(i), l.x(column))];
        }
    }
    block.clear();
    block.resize(r * r, 0.0);
    if !invert(r, jac, block) {
        return false;
    }
    inverse.fill(0.0);
    for (a, state) in xi_states().enumerate() {
        let row = &mut inverse[state * n..(state + 1) * n];
        row[..r].copy_from_slice(&block[a * r..(a + 1) * r]);
        for (j, &e) in eta_states.iter().enumerate() {
            let mut v = 0.0;
            for (i, &b) in block[a * r..(a + 1) * r].iter().enumerate() {
                v -= b * sens[l.at(l.psi(i), l.x(e))];
            }
            row[r + j] = v;
        }
    }
    for (j, &e) in eta_states.iter().enumerate() {
        inverse[e * n + r + j] = 1.0;
    }
    inverse.iter().all(|v| v.is_finite())
}

/// The inverse of the n × n matrix `a` (row-major, overwritten) into `inv` by Gauss–Jordan elimination with
/// partial pivoting; false where a pivot is zero or not finite (n is the number of states: small, and no
/// allocation per point), or for n ≤ 2 in closed form. The other common sizes are compiled each with its n a
/// constant (the loops unrolled).
pub(super) fn invert(n: usize, a: &mut [f64], inv: &mut [f64]) -> bool {
    match n {
        1 => {
            inv[0] = 1.0 / a[0];
            a[0] != 0.0 && inv[0].is_finite()
        }
        2 => match inverse_two([a[0], a[1], a[2], a[3]]) {
            Some(v) => {
                inv[..4].copy_from_slice(&v);
                true
            }
            None => false,
        },
        3 => invert_sized(3, a, inv),
        4 => invert_sized(4, a, inv),
        5 => invert_sized(5, a, inv),
        6 => invert_sized(6, a, inv),
        _ => invert_sized(n, a, inv),
    }
}

/// [[a, b], [c, d]]⁻¹ = [[d, −b], [−c, a]]/(ad − bc) (Cramer's rule), row-major; None where the matrix is
/// singular or the inverse not finite.
#[inline(always)]
pub(super) fn inverse_two([a, b, c, d]: [f64; 4]) -> Option<[f64; 4]> {
    let det = a * d - b * c;
    let i = 1.0 / det;
    let v = [d * i, -b * i, -c * i, a * i];
    (det != 0.0 && v.iter().all(|v| v.is_finite())).then_some(v)
}

/// [`invert`]'s elimination, inlined into each of its arms.
#[inline(always)]
fn invert_sized(n: usize, a: &mut [f64], inv: &mut [f64]) -> bool {
    let (a, inv) = (&mut a[..n * n], &mut inv[..n * n]);
    inv.fill(0.0);
    for i in 0..n {
        inv[i * n + i] = 1.0;
    }
    for col in 0..n {
        let mut pivot = col;
        for i in col + 1..n {
            if a[i * n + col].abs() > a[pivot * n + col].abs() {
                pivot = i;
            }
        }
        let d = a[pivot * n + col];
        if !(d.is_finite() && d != 0.0) {
            return false;
        }
        if pivot != col {
            for j in 0..n {
                a.swap(col * n + j, pivot * n + j);
                inv.swap(col * n + j, pivot * n + j);
            }
        }
        let d = 1.0 / d;
        for j in 0..n {
            a[col * n + j] *= d;
            inv[col * n + j] *= d;
        }
        for i in (0..n).filter(|&i| i != col) {
            let f = a[i * n + col];
            if f != 0.0 {
                for j in 0..n {
                    a[i * n + j] -= f * a[col * n + j];
                    inv[i * n + j] -= f * inv[col * n + j];
                }
            }
        }
    }
    inv.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::invert;

    /// The inverse times the matrix is the identity (a pivot swap needed: a zero leading entry), and a
    /// singular matrix is refused.
    #[test]
    fn gauss_jordan_inverts_and_refuses_a_singular_matrix() {
        let a0 = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 4.0];
        let (mut a, mut inv) = (a0, [0.0; 9]);
        assert!(invert(3, &mut a, &mut inv));
        for i in 0..3 {
            for j in 0..3 {
                let p: f64 = (0..3).map(|k| a0[i * 3 + k] * inv[k * 3 + j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((p - want).abs() < 1e-15, "({i}, {j}): {p}");
            }
        }
        let mut singular = [1.0, 2.0, 2.0, 4.0];
        assert!(!invert(2, &mut singular, &mut [0.0; 4]));
    }

    /// Every size, the ones compiled apart (1 … 6) and the general arm (7, 8): A·A⁻¹ = I for a matrix with a
    /// zero diagonal (every column needs a pivot swap), and a matrix with a zero column is refused.
    #[test]
    fn every_size_inverts() {
        for n in 1..=8 {
            // a_ij = 1/(1 + |i − j − 1|) off the diagonal pattern, 0 on the diagonal for n > 1.
            let a0: Vec<f64> = (0..n * n)
                .map(|e| {
                    let (i, j) = (e / n, e % n);
                    if n > 1 && i == j {
                        0.0
                    } else {
                        1.0 / (1.0 + (i as f64 - j as f64 - 1.0).abs()) + 0.1 * i as f64
                    }
                })
                .collect();
            let (mut a, mut inv) = (a0.clone(), vec![0.0; n * n]);
            assert!(invert(n, &mut a, &mut inv), "n = {n}");
            for i in 0..n {
                for j in 0..n {
                    let p: f64 = (0..n).map(|k| a0[i * n + k] * inv[k * n + j]).sum();
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((p - want).abs() < 1e-12, "n = {n} ({i}, {j}): {p}");
                }
            }
            let mut singular = a0.clone();
            for row in singular.chunks_exact_mut(n) {
                row[n - 1] = 0.0;
            }
            assert!(!invert(n, &mut singular, &mut vec![0.0; n * n]), "n = {n}");
        }
    }
}
