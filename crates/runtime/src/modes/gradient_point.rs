//! The two pieces of a run with modes' gradient (`gradient.rs`, `gradient_zd.rs`) evaluated at a point: a
//! mode's partial derivatives at (x, w, u) ([`crate::gradient::Point`]) and the derivative of the re-entry's
//! transition, de^(j)(t) (`blend.rs`: the transition is linear in its initial deviations, so its derivative is
//! the transition of theirs).

use invsim_model_api::InverseModel;

use super::blend::Blend;
use super::record::Ctx;
use super::ModalError;
use crate::gradient::{Buffers, GridColumns, Point};

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

/// The transition's derivative de^(0 … orders−1)(t) (zeros without one or outside it).
pub(super) fn moved_reference(dblend: Option<&Blend>, t: f64, orders: usize) -> Vec<f64> {
    let mut de = vec![0.0; orders];
    moved_reference_into(dblend, t, &mut de);
    de
}

/// [`moved_reference`] into `de` (its length the orders).
pub(super) fn moved_reference_into(dblend: Option<&Blend>, t: f64, de: &mut [f64]) {
    de.fill(0.0);
    if let Some(b) = dblend {
        b.add(t, de);
    }
}
