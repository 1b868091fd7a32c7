//! The integrator of a mode's zero dynamics over one output interval [t_k, t_k + dt] at rtol 1e-8, atol 1e-10:
//! DOP853 (order 8, 12 evaluations a step) where an interval is long enough for the 5th-order pair to need
//! several steps, DOPRI5 (6 a step) where one of its steps spans an interval anyway.
//!
//! The tolerance. The zero dynamics of a brake or idle mode are mildly stiff (the intake manifold's filling:
//! ∂η̇/∂η ≈ −s_i V_d ω_e/(4π V_i) ≈ −10 … −25 1/s), so an explicit method's step is bounded by its error on
//! e^(hλ) — (hλ)⁹/9! for an 8th-order one — and costs about 4× more evaluations at λ than at λ/10 (measured:
//! the 6-speed Fusion's UDDS at dt = 1 s with the manifold's volume ×10). The error of the result is far below
//! the tolerance, since the mode damps it: against rtol 1e-13 (the 6-speed Fusion and si_engine_5speed on UDDS,
//! dt 1 s and 0.1 s) the largest error of η, the brake force and the engine torque is 1.4·10⁻¹⁰, 2.2·10⁻¹⁰,
//! 1.1·10⁻¹⁰ of the column's largest value at rtol 1e-8 (3·10⁻¹² at rtol 1e-10), which takes 41 % fewer
//! evaluations at dt = 1 s and 30 % fewer at dt = 0.1 s than rtol 1e-10. The test
//! `the_tolerance_keeps_the_stiff_zero_dynamics_within_1e_9` (below) checks the bound on an exact solution.
//! On UDDS with `si_engine_5speed` DOPRI5 takes about 5 steps per 0.1 s interval and one per 0.01 s interval.
//!
//! A differentiated run logs each accepted step with its continuous extension (`crate::ode::StepLog`; DOP853's
//! costs three more evaluations a step, DOPRI5's none), and the gradient's sensitivities follow those steps
//! (`gradient_zd.rs`): the plain run's steps and values are the same.

use crate::ode::{Dop853, Dopri5, StepFailure, StepLog};

/// Output steps from which DOP853 is used, s.
pub(super) const DOP853_FROM_DT: f64 = 0.05;
pub(super) const RTOL: f64 = 1e-8;
pub(super) const ATOL: f64 = 1e-10;

/// One mode's zero-dynamics integrator.
pub(super) enum ZdOde {
    /// Boxed: its seven stage vectors make it three times DOP853's size (one buffer).
    Dopri5(Box<Dopri5>),
    Dop853(Dop853),
}

impl ZdOde {
    /// The integrator for `n` internal states on intervals of `dt`, starting with step `h0`; with its
    /// continuous extension where `dense` (a differentiated run logs its steps with it: the same steps).
    pub(super) fn new(n: usize, dt: f64, h0: f64, dense: bool) -> ZdOde {
        match (dt >= DOP853_FROM_DT, dense) {
            (true, false) => ZdOde::Dop853(Dop853::new(n, RTOL, ATOL, h0)),
            (true, true) => ZdOde::Dop853(Dop853::new(n, RTOL, ATOL, h0).with_dense_output()),
            (false, false) => ZdOde::Dopri5(Box::new(
                Dopri5::new(n, RTOL, ATOL, h0).without_dense_output(),
            )),
            (false, true) => ZdOde::Dopri5(Box::new(Dopri5::new(n, RTOL, ATOL, h0))),
        }
    }

    /// The step size the controller proposes.
    pub(super) fn step_size(&self) -> f64 {
        match self {
            ZdOde::Dopri5(o) => o.step_size(),
            ZdOde::Dop853(o) => o.step_size(),
        }
    }

    /// Steps accepted and rejected so far.
    pub(super) fn steps_taken(&self) -> (usize, usize) {
        let stats = match self {
            ZdOde::Dopri5(o) => &o.stats,
            ZdOde::Dop853(o) => &o.stats,
        };
        (stats.accepted, stats.rejected)
    }

    /// Start afresh from (t, y) with the first stage evaluated and the starting step of `ode/start.rs` (at most
    /// `h_max`): where nothing is known of the step the solution allows (a mode just entered).
    pub(super) fn start<F>(
        &mut self,
        t: f64,
        y: &[f64],
        h_max: f64,
        f: &mut F,
    ) -> Result<(), StepFailure>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), StepFailure>,
    {
        match self {
            ZdOde::Dopri5(o) => o.start(t, y, h_max, f),
            ZdOde::Dop853(o) => o.start(t, y, h_max, f),
        }
    }

    /// Forget the FSAL stage and start with step `h0`.
    pub(super) fn reset(&mut self, h0: f64) {
        match self {
            ZdOde::Dopri5(o) => o.reset(h0),
            ZdOde::Dop853(o) => o.reset(h0),
        }
    }

    /// Integrate y from `t0` to `t1` in place, each accepted step with its continuous extension into `log`
    /// where there is one (the integrator built with it, [`ZdOde::new`]).
    #[inline(always)]
    pub(super) fn advance<F>(
        &mut self,
        t0: f64,
        t1: f64,
        y: &mut [f64],
        f: &mut F,
        log: Option<&mut StepLog>,
    ) -> Result<(), StepFailure>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), StepFailure>,
    {
        match (self, log) {
            (ZdOde::Dopri5(o), None) => o.advance(t0, t1, y, f),
            (ZdOde::Dop853(o), None) => o.advance(t0, t1, y, f),
            (ode, Some(log)) => ode.advance_logged((t0, t1), y, f, log),
        }
    }

    /// [`ZdOde::advance`] with a log. Out of line, and stepping through its own instance of the step (`g`, a
    /// closure of another type), so that the plain run's step keeps the one call site it is inlined at.
    #[inline(never)]
    fn advance_logged<F>(
        &mut self,
        (t0, t1): (f64, f64),
        y: &mut [f64],
        f: &mut F,
        log: &mut StepLog,
    ) -> Result<(), StepFailure>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), StepFailure>,
    {
        let n = y.len();
        let mut g = |t: f64, y: &[f64], d: &mut [f64]| f(t, y, d);
        match self {
            ZdOde::Dopri5(o) => o.advance_each(t0, t1, y, &mut g, &mut |o: &Dopri5, _, _| {
                let (t, h, r) = o.continuous_extension();
                log.push((t, h), n, &r)
            }),
            ZdOde::Dop853(o) => o.advance_each(t0, t1, y, &mut g, &mut |o: &Dop853, _, _| {
                let (t, h, r) = o.continuous_extension();
                log.push((t, h), n, &[r])
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// η' = λ(η − g(t)) + g'(t) with λ = −25 1/s (the stiffest brake mode's manifold) has the exact solution
    /// η = g + (η₀ − g(0)) e^(λt); started off g (a switch into the mode), over 20 intervals of 1 s and of
    /// 0.1 s, each started as the runner starts it, the error stays within 1e-9 of η's largest value.
    #[test]
    fn the_tolerance_keeps_the_stiff_zero_dynamics_within_1e_9() {
        let lambda = -25.0;
        let g = |t: f64| 2e4 + 3e3 * (0.7 * t).sin() + 1e3 * (2.1 * t).cos();
        let dg = |t: f64| 2.1e3 * (0.7 * t).cos() - 2.1e3 * (2.1 * t).sin();
        let eta0 = g(0.0) + 5e3;
        let exact = |t: f64| g(t) + (eta0 - g(0.0)) * (lambda * t).exp();
        let mut f = |t: f64, e: &[f64], de: &mut [f64]| -> Result<(), StepFailure> {
            de[0] = lambda * (e[0] - g(t)) + dg(t);
            Ok(())
        };
        for dt in [1.0, 0.1] {
            let mut ode = ZdOde::new(1, dt, dt / 4.0, false);
            let mut eta = [eta0];
            let mut worst = 0.0f64;
            for k in 0..(20.0 / dt) as usize {
                let (t0, t1) = (k as f64 * dt, (k + 1) as f64 * dt);
                let h0 = if k == 0 {
                    dt / 4.0
                } else {
                    ode.step_size().min(dt)
                };
                ode.reset(h0);
                ode.advance(t0, t1, &mut eta, &mut f, None)
                    .expect("integrates");
                worst = worst.max((eta[0] - exact(t1)).abs());
            }
            let rel = worst / 2.5e4;
            assert!(rel < 1e-9, "dt {dt}: {rel:e}");
            assert!(
                rel > 1e-16,
                "dt {dt}: the test integrates nothing ({rel:e})"
            );
        }
    }
}
