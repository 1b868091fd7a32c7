//! `--verify` for a run with modes: the computed input (linear between grid points within each interval)
//! replayed through the original equations of the mode active on each interval (with the smoothed signals), with the same switches
//! (the states a new mode couples set to their couplings, and, for the quasi-static option, the same
//! impulses as state jumps Δx = U g(x)); the tracking error is
//! |h(x_replay) − y_d| over the samples, y_d the reference the inverse tracked (transitions included). A
//! strategy's run (`hybrid.rs`) is replayed the same way with each decided input held at the strategy's value
//! over its interval, as the strategy priced it; the replay's final state (the battery's charge among it)
//! is kept beside the tracking error.

use super::record::{set_decided, Ctx, Record};
use super::ModalError;
use crate::ode::{Dopri5, StepFailure};

/// The replay's tracking error.
pub(super) struct Tracking {
    pub(super) max_abs: f64,
    pub(super) rms: f64,
    /// The replay's state at the last sample.
    pub(super) x_end: Vec<f64>,
}

/// Mode m's signal values at time t within sample k's interval: the smoothed exogenous signals, and the
/// decided inputs at the values the record holds for sample k (none without a strategy).
fn signals_at(ctx: &Ctx<'_, '_>, rec: &Record, (m, k): (usize, usize), t: f64) -> Vec<f64> {
    let mut w = ctx.w(m, t);
    set_decided(ctx, rec, (m, k), &mut w);
    w
}

pub(super) fn replay(ctx: &Ctx<'_, '_>, rec: &Record) -> Result<Tracking, ModalError> {
    let ns = rec.t.len();
    let mut x = rec.states[0].to_vec();
    let (mut max_abs, mut sum2) = (0.0f64, 0.0f64);
    let mut ode = Dopri5::new(x.len(), 1e-11, 1e-12, 1e-3);
    for k in 0..ns {
        let m = rec.mode[k];
        let model = ctx.spec.modes[m].model;
        if k > 0 && rec.mode[k - 1] != m {
            // The same entry as the inverse's: the states the new mode couples at their couplings.
            let _ = super::coupling::enter(ctx, m, rec.t[k], &mut x, rec.free[k]);
        }
        if rec.impulse[k] != 0.0 {
            for (xi, gi) in x.iter_mut().zip(rec.impulse_dir_at(k)) {
                *xi += rec.impulse[k] * gi;
            }
        }
        let e = model.h(&x, &signals_at(ctx, rec, (m, k), rec.t[k])) - rec.yref[k][0];
        max_abs = max_abs.max(e.abs());
        sum2 += e * e;
        if k + 1 == ns {
            break;
        }
        let (ta, tb) = (rec.t[k], rec.t[k + 1]);
        let (ua, ub) = (rec.free[k], rec.u_end[k]);
        let mut f = |t: f64, y: &[f64], dy: &mut [f64]| -> Result<(), StepFailure> {
            let s = (t - ta) / (tb - ta);
            model.rhs(y, &signals_at(ctx, rec, (m, k), t), ua + s * (ub - ua), dy);
            Ok(())
        };
        ode.restart();
        ode.advance(ta, tb, &mut x, &mut f)
            .map_err(|e: StepFailure| ctx.err(m, tb, format!("the replay failed: {}", e.reason)))?;
    }
    Ok(Tracking {
        max_abs,
        rms: (sum2 / ns as f64).sqrt(),
        x_end: x,
    })
}
