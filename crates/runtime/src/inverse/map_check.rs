//! `extrapolate = "error"` during an inverse run (contract §6): a map evaluated with an argument outside its
//! grid anywhere in a block (inner integration steps and Newton iterations included) stops the run with the
//! time, the map and the argument. The evaluation records the first violation of the thread
//! ([`invsim_model_api::map::take_violation`]); after each block the driver takes it and finds the first
//! sample whose own evaluation (rhs and outputs at that sample's states and input) repeats it, or, when the
//! violation happened only between samples, names the block's time span.

use invsim_model_api::map::take_violation;
use invsim_model_api::InverseModel;

use super::error::SimulateError;
use super::inverter::Block;

/// Forgets violations recorded before the run (by a derivation or an earlier run on this thread).
pub(super) fn clear() {
    let _ = take_violation();
}

/// `Err` when a map under `extrapolate = "error"` left its grid while the block was computed.
pub(super) fn check<M: InverseModel + ?Sized>(
    model: &M,
    b: &Block<'_, '_>,
) -> Result<(), SimulateError> {
    let Some(first) = take_violation() else {
        return Ok(());
    };
    let n = b.x.len();
    let mut x = vec![0.0; n];
    let mut dx = vec![0.0; n];
    let mut w = vec![0.0; b.w.len()];
    let mut out = vec![0.0; b.out.len()];
    for (i, &t) in b.time.iter().enumerate() {
        for (xs, c) in x.iter_mut().zip(b.x.iter()) {
            *xs = c[i];
        }
        for (ws, c) in w.iter_mut().zip(b.w.iter()) {
            *ws = c[i];
        }
        model.rhs(&x, &w, b.u[i], &mut dx);
        model.outputs(&x, &w, b.u[i], &mut out);
        if let Some(v) = take_violation() {
            return Err(SimulateError::MapOutsideGrid {
                at: format!("t = {} s", crate::error::num(t)),
                violation: v,
            });
        }
    }
    let (t0, t1) = (b.time[0], b.time[b.time.len() - 1]);
    Err(SimulateError::MapOutsideGrid {
        at: format!(
            "a time between t = {} s and t = {} s (inside an integration step or Newton iteration)",
            crate::error::num(t0),
            crate::error::num(t1)
        ),
        violation: first,
    })
}
