//! The pieces of a run with modes' gradient (`gradient.rs`, `gradient_zd.rs`) evaluated at a point: a
//! mode's partial derivatives at (x, w, u) ([`crate::gradient::Point`]), the derivative of the re-entry's
//! transition, de^(j)(t) (`blend.rs`: the transition is linear in its initial deviations, so its derivative is
//! the transition of theirs), and the accumulated outputs' derivatives there ([`OutputChanges`]).

use invsim_model_api::InverseModel;

use super::blend::Blends;
use super::record::Ctx;
use super::ModalError;
use crate::gradient::{Buffers, ClosedJacobian, ClosedRows, GridColumns, ModalWrt, Point};

/// The model's partial derivatives of mode m at (x, w, u) at time t, with the mode's columns of the grid values
/// differentiated by (`grid`).
pub(super) fn point_at(
    ctx: &Ctx<'_, '_>,
    (m, grid): (usize, &GridColumns),
    at: (f64, &[f64], &[f64], f64),
) -> Result<Point, ModalError> {
    point_into(ctx, (m, grid), at, Default::default())
}

/// [`point_at`] into the buffer `buf` of an earlier point ([`Point::into_buffer`]).
pub(super) fn point_into(
    ctx: &Ctx<'_, '_>,
    (m, grid): (usize, &GridColumns),
    (t, x, w, u): (f64, &[f64], &[f64], f64),
    buf: Buffers,
) -> Result<Point, ModalError> {
    let model: &dyn InverseModel = ctx.model(m);
    Point::new(model, (x, w, u), (&model.info().eta_states, grid), buf)
        .map_err(|e| ctx.err(m, t, e.to_string()))
}

/// The transition's derivative de_c^(0 … orders−1)(t) of every derivative c < np into `out` (entry c·orders + k;
/// zeros without one or outside it), its basis evaluated once into `basis`.
pub(super) fn moved_references(
    dblend: Option<&Blends>,
    (np, t, orders): (usize, f64, usize),
    basis: &mut Vec<f64>,
    out: &mut Vec<f64>,
) {
    out.clear();
    out.resize(np * orders, 0.0);
    let Some(b) = dblend else {
        return;
    };
    if b.basis_at(t, orders, basis) {
        for (c, de) in out
            .chunks_exact_mut(orders.max(1))
            .take(b.columns())
            .enumerate()
        {
            b.add_from(c, basis, de);
        }
    }
}

/// The accumulated outputs' derivatives at a point of a mode, with the buffers reused from point to point:
/// by one adjoint product per output ([`Point::moved_row_jacobians`]) the rows' A = ∂o/∂η, B = ∂o/∂p and
/// R = ∂o/∂(ξ, y^(r)), then per derivative c
///
/// ```text
/// do_a/dp_c = B_ac + Σ_j A_aj S_jc + Σ_(l≤r) R_al de_c,l(t)
/// ```
///
/// (S = ∂η/∂p of the mode, de_c the transition's derivative).
#[derive(Default)]
pub(super) struct OutputChanges {
    buf: Buffers,
    w: Vec<f64>,
    rows: Vec<usize>,
    a: Vec<f64>,
    b: Vec<f64>,
    reference: Vec<f64>,
    basis: Vec<f64>,
    moved: Vec<f64>,
    /// The mode's closed-form partial derivatives at the point.
    closed: ClosedJacobian,
}

/// Where the outputs' derivatives are taken: mode m at time t, (x, u), with η's sensitivities per derivative
/// and the transition's derivative per derivative.
pub(super) type OutputsAt<'b> = (
    (usize, f64),
    (&'b [f64], f64),
    (&'b [Vec<f64>], Option<&'b Blends>),
);

impl OutputChanges {
    /// do_a/dp_c of the accumulated outputs `accumulated` into `out` (entry (a, c) at c·na + a).
    pub(super) fn at(
        &mut self,
        ctx: &Ctx<'_, '_>,
        (wrt, accumulated): (&ModalWrt, &[usize]),
        ((m, t), (x, u), (deta, dblend)): OutputsAt<'_>,
        out: &mut Vec<f64>,
    ) -> Result<(), ModalError> {
        let model = ctx.model(m);
        let info = model.info();
        ctx.w_into(m, t, info.n_w(), &mut self.w);
        let (na, ne, r, np) = (
            accumulated.len(),
            info.n_eta,
            info.relative_degree,
            deta.len(),
        );
        self.a.resize(na * ne, 0.0);
        self.b.resize(na * np, 0.0);
        self.reference.resize(na * (r + 1), 0.0);
        // The closed form where the mode has it, else the implicit function theorem at (x, u).
        let rows = (
            ClosedRows::Outputs(x, &self.w, u, accumulated),
            &wrt.columns[m][..],
        );
        let matrices = (
            &mut self.a[..],
            &mut self.b[..],
            Some(&mut self.reference[..]),
        );
        if !self.closed.eval(model, rows, matrices) {
            let buf = std::mem::take(&mut self.buf);
            let point = point_into(ctx, (m, &wrt.grids[m]), (t, x, &self.w, u), buf)?;
            let l = *point.layout();
            self.rows.clear();
            self.rows.extend(accumulated.iter().map(|&o| l.output(o)));
            let (a, b) = (&mut self.a[..], &mut self.b[..]);
            point.moved_row_jacobians(&self.rows, &wrt.columns[m], (a, b), &mut self.reference);
            self.buf = point.into_buffer();
        }
        out.clear();
        out.extend_from_slice(&self.b);
        for (c, col) in out.chunks_exact_mut(na.max(1)).take(np).enumerate() {
            for (j, &s) in deta[c].iter().enumerate() {
                add_scaled(col, &self.a[j * na..(j + 1) * na], s);
            }
        }
        let moves = (&self.reference[..], dblend, t);
        let buffers = (r + 1, &mut self.basis, &mut self.moved);
        add_transition_moves((&mut out[..], na), moves, buffers);
        Ok(())
    }
}

/// Each derivative c's column of `cols` (`rows` entries each, column-major) += Σ_l R_l de_c,l(t): the rows'
/// columns R = ∂/∂(ξ, y^(r)) (`reference`, rows × (r + 1), [`Point::moved_row_jacobians`]) along the re-entry
/// transition's derivative de_c(t) (`dblend`'s column c, nothing without one). With de_c,l = Σ_j e_c,j b_j^(l)
/// ([`Blends`]) the sum is Σ_j e_c,j v_j, v_j = Σ_l R_l b_j^(l)(t): the basis and the v_j are formed once
/// for every column c. `orders` = r + 1; `basis` and `moved` are buffers.
pub(super) fn add_transition_moves(
    (cols, rows): (&mut [f64], usize),
    (reference, dblend, t): (&[f64], Option<&Blends>, f64),
    (orders, basis, moved): (usize, &mut Vec<f64>, &mut Vec<f64>),
) {
    let Some(blends) = dblend else {
        return;
    };
    let moving = |c: &usize| blends.deviations(*c).iter().any(|&e| e != 0.0);
    let Some(first) = (0..blends.columns()).find(moving) else {
        return;
    };
    if rows == 0 || !blends.basis_at(t, orders, basis) {
        return;
    }
    // v_j = Σ_l R_l b_j^(l), j over the basis (rows entries each).
    let len = basis.len() / orders;
    moved.clear();
    moved.resize(len * rows, 0.0);
    for j in 0..len {
        let v = &mut moved[j * rows..(j + 1) * rows];
        for l in 0..orders {
            add_scaled(
                v,
                &reference[l * rows..(l + 1) * rows],
                basis[j * orders + l],
            );
        }
    }
    for c in (first..blends.columns().min(cols.len() / rows)).filter(moving) {
        let col = &mut cols[c * rows..(c + 1) * rows];
        for (j, &e) in blends.deviations(c).iter().enumerate() {
            add_scaled(col, &moved[j * rows..(j + 1) * rows], e);
        }
    }
}

/// col += v·s (nothing for s = 0).
fn add_scaled(col: &mut [f64], v: &[f64], s: f64) {
    if s != 0.0 {
        for (o, &g) in col.iter_mut().zip(v) {
            *o += g * s;
        }
    }
}
