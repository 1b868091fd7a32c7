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
//! Dynamics affine in their one internal state (`ModelInfo::zero_dynamics_affine`: the manifold's filling in
//! the brake, coast, overrun and idle modes of the shipped cars) on output steps of 0.05 s and more are
//! integrated by the variation of constants (`crate::ode::AffineScalar`, `ode/affine.rs`), whose error does
//! not grow with the stiffness: a 1 s interval takes one sub-interval of 12 Gauss nodes, each node the
//! reference read once and A, b of η' = A η + b evaluated once (`InverseModel::zero_dynamics_affine`: ∂q/∂η
//! and q at η = 0, from codegen and the interpreter; a model without them gives b = η'(0) and A from η' at a
//! second η), against about six DOP853 steps of 12 stages (the 6-speed Fusion on the UDDS at dt = 1 s: 287
//! sub-intervals, none rejected, 3 444 nodes, for about 27 000 stages).
//! Against DOP853 at rtol 1e-13 (the 6-speed Fusion and si_engine_5speed on the UDDS, NEDC and WLTC 3b at
//! dt = 1 s) every column is within 3.5·10⁻¹³ of its largest value and the fuel within 10⁻¹⁵, where DOP853 at
//! rtol 1e-8 is within 3.5·10⁻¹⁰ (and at dt = 0.5 s 4.4·10⁻⁸ of a sample's manifold pressure). Steps below
//! 0.5 s take 5 nodes (one DOP853 step of 12 stages spans such an interval; the sums over 5 nodes unrolled):
//! at dt = 0.1 s, against DOP853 at rtol 1e-13 on the UDDS and WLTC 3b, both cars' speed and manifold
//! pressure are within 1.0·10⁻¹¹ at every sample (relative), the brake force 2.8·10⁻¹¹ and the fuel
//! 3.2·10⁻¹², where DOP853 at rtol 1e-8 is 5.4·10⁻⁹, 8.3·10⁻⁸ and 2.7·10⁻⁹ off; si_engine_5speed's run
//! (summary only) takes 0.89 of the time (4 nodes: 0.92; 6 nodes as 5; 3 nodes 2.9×, its estimate rejecting
//! sub-intervals). Below 0.05 s DOPRI5 crosses an interval in one step of 6 evaluations.
//!
//! A differentiated run logs each accepted step with its continuous extension (`crate::ode::StepLog`; DOP853's
//! costs three more evaluations a step, DOPRI5's none), and the gradient's sensitivities follow those steps
//! (`gradient_zd.rs`): the plain run's steps and values are the same. Where the plain run takes the variation
//! of constants, so does the differentiated one (the same η, bit for bit), with DOP853 beside it started from
//! that η at every interval for the logged steps (within the figures above of it).

use crate::ode::{AffineScalar, Dop853, Dopri5, StepFailure, StepLog};

/// Output steps from which DOP853 is used, s.
pub(super) const DOP853_FROM_DT: f64 = 0.05;
pub(super) const RTOL: f64 = 1e-8;
pub(super) const ATOL: f64 = 1e-10;

/// Output steps from which dynamics affine in one state are integrated by the variation of constants, and
/// the nodes of its sub-intervals (module docs; with 8 and 6 nodes the 6-speed Fusion at dt = 1 s took 1.1
/// and 1.3 times as long a run).
pub(super) const AFFINE_FROM_DT: f64 = 0.5;
const AFFINE_NODES: usize = 12;
pub(super) const AFFINE_SHORT_FROM_DT: f64 = 0.05;
const AFFINE_SHORT_NODES: usize = 5;

/// One mode's zero-dynamics integrator.
pub(super) enum ZdOde {
    /// Boxed: its seven stage vectors make it three times DOP853's size (one buffer).
    Dopri5(Box<Dopri5>),
    Dop853(Dop853),
    /// One internal state with dynamics affine in it (`ode/affine.rs`): a run that logs no steps.
    Affine(AffineScalar),
    /// The same where the run logs its steps: the variation of constants gives the run's η, and DOP853,
    /// started from it at every interval, the logged steps the gradient's sensitivities follow (boxed: the
    /// two integrators).
    AffineLogged(Box<(AffineScalar, Dop853)>),
}

impl ZdOde {
    /// The integrator for `n` internal states on intervals of `dt`, starting with step `h0`; with its
    /// continuous extension where `dense` (a differentiated run logs its steps with it: the same steps); by
    /// the variation of constants where the dynamics are `affine` in one state and dt ≥ 0.05 s (with DOP853
    /// beside it for the logged steps where `dense`).
    pub(super) fn new(n: usize, dt: f64, h0: f64, (dense, affine): (bool, bool)) -> ZdOde {
        if affine && n == 1 && dt >= AFFINE_SHORT_FROM_DT {
            let nodes = if dt >= AFFINE_FROM_DT {
                AFFINE_NODES
            } else {
                AFFINE_SHORT_NODES
            };
            let mut o = AffineScalar::new(nodes);
            o.reset(h0);
            return match dense {
                false => ZdOde::Affine(o),
                true => ZdOde::AffineLogged(Box::new((
                    o,
                    Dop853::new(n, RTOL, ATOL, h0).with_dense_output(),
                ))),
            };
        }
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
            ZdOde::Affine(o) => o.step_size(),
            ZdOde::AffineLogged(o) => o.0.step_size(),
        }
    }

    /// Steps accepted and rejected so far.
    pub(super) fn steps_taken(&self) -> (usize, usize) {
        let stats = match self {
            ZdOde::Dopri5(o) => &o.stats,
            ZdOde::Dop853(o) => &o.stats,
            ZdOde::Affine(o) => &o.stats,
            ZdOde::AffineLogged(o) => &o.0.stats,
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
            // Its first sub-interval is the whole interval, shortened where the estimate asks.
            ZdOde::Affine(_) => Ok(()),
            ZdOde::AffineLogged(o) => o.1.start(t, y, h_max, f),
        }
    }

    /// Forget the FSAL stage and start with step `h0`.
    pub(super) fn reset(&mut self, h0: f64) {
        match self {
            ZdOde::Dopri5(o) => o.reset(h0),
            ZdOde::Dop853(o) => o.reset(h0),
            ZdOde::Affine(o) => o.reset(h0),
            // DOP853 beside it continues with its own step (h0 < 0: a start, [`ZdOde::start`]).
            ZdOde::AffineLogged(o) => {
                let h = if h0 < 0.0 {
                    h0
                } else {
                    o.1.step_size().min(h0)
                };
                o.0.reset(h0);
                o.1.reset(h);
            }
        }
    }

    /// Whether it is the variation of constants (which [`ZdOde::advance_affine`] advances; in a logged run
    /// [`ZdOde::advance`] advances the DOP853 beside it and logs its steps, η left as it is).
    pub(super) fn is_affine(&self) -> bool {
        matches!(self, ZdOde::Affine(_) | ZdOde::AffineLogged(_))
    }

    /// The variation of constants' η from t0 to t1 in place, `ab(t, s, out)` writing [A, b] of η' = A η + b
    /// at t (s = |η(t0)|, 1 where it is 0: the second η where A is taken from two evaluations of η').
    #[inline(never)]
    pub(super) fn advance_affine<A>(
        &mut self,
        t0: f64,
        t1: f64,
        y: &mut [f64],
        ab: &mut A,
    ) -> Result<(), StepFailure>
    where
        A: FnMut(f64, f64, &mut [f64; 2]) -> Result<(), StepFailure>,
    {
        let o = match self {
            ZdOde::Affine(o) => o,
            ZdOde::AffineLogged(o) => &mut o.0,
            ZdOde::Dopri5(_) | ZdOde::Dop853(_) => {
                return Err(StepFailure {
                    t: t0,
                    reason: "not the variation of constants".into(),
                })
            }
        };
        let s = if y[0] != 0.0 { y[0].abs() } else { 1.0 };
        let mut coefficients = |t: f64| -> Result<(f64, f64), StepFailure> {
            let mut c = [0.0; 2];
            ab(t, s, &mut c)?;
            Ok((c[0], c[1]))
        };
        o.advance((t0, t1), &mut y[0], &mut coefficients)
    }

    /// Integrate y from `t0` to `t1` in place, each accepted step with its continuous extension into `log`
    /// where there is one (the integrator built with it, [`ZdOde::new`]). The variation of constants reads A
    /// and b, not η' ([`ZdOde::advance_affine`]): with a log this advances only the DOP853 beside it.
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
            (ZdOde::Affine(_) | ZdOde::AffineLogged(_), None) => Err(StepFailure {
                t: t0,
                reason: "the variation of constants reads A and b (`advance_affine`)".into(),
            }),
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
            // The DOP853 beside the variation of constants, from the same η: its steps logged, η left as it
            // is (the run's η comes from `advance_affine`).
            ZdOde::AffineLogged(o) => {
                let mut shadow = [y[0]];
                o.1.advance_each(t0, t1, &mut shadow, &mut g, &mut |o: &Dop853, _, _| {
                    let (t, h, r) = o.continuous_extension();
                    log.push((t, h), n, &[r])
                })
            }
            // Never built for a run that logs (`ZdOde::new`).
            ZdOde::Affine(_) => Err(StepFailure {
                t: t0,
                reason: "the affine integrator logs no steps".into(),
            }),
        }
    }
}

/// A and b of η' = q(η) = A η + b from q at η = 0 (b) and at η = s (A = (q(s) − b)/s; s = |η(t0)|, 1 where it
/// is 0, so that near the balance A η ≈ −b the difference keeps b's relative precision): for a model that
/// does not give them from one evaluation (`InverseModel::zero_dynamics_affine`).
pub(super) fn coefficients_from_two_states(s: f64, mut q: impl FnMut(f64) -> f64) -> [f64; 2] {
    let b = q(0.0);
    [(q(s) - b) / s, b]
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
            let mut ode = ZdOde::new(1, dt, dt / 4.0, (false, false));
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

    /// η' = a(t)(η − g(t)) + g'(t), a = −25 − 3 sin(0.7 t) 1/s, is affine in η with the exact solution
    /// η = g + (η₀ − g(0)) e^(A(t)), A = ∫_0^t a; on intervals of 1 s and 0.5 s the integrator is the
    /// variation of constants, a and b taken from two evaluations of η' (as a run has them), and over 20 s it
    /// stays within 1e-10 of η's largest value.
    #[test]
    fn affine_dynamics_on_long_intervals_follow_their_exact_solution() {
        let g = |t: f64| 2e4 + 3e3 * (0.7 * t).sin() + 1e3 * (2.1 * t).cos();
        let dg = |t: f64| 2.1e3 * (0.7 * t).cos() - 2.1e3 * (2.1 * t).sin();
        let a = |t: f64| -25.0 - 3.0 * (0.7 * t).sin();
        let big_a = |t: f64| -25.0 * t + 3.0 / 0.7 * ((0.7 * t).cos() - 1.0);
        let eta0 = g(0.0) + 5e3;
        let exact = |t: f64| g(t) + (eta0 - g(0.0)) * big_a(t).exp();
        let f = |t: f64, e: &[f64], de: &mut [f64]| -> Result<(), StepFailure> {
            de[0] = a(t) * (e[0] - g(t)) + dg(t);
            Ok(())
        };
        let mut ab = |t: f64, s: f64, out: &mut [f64; 2]| -> Result<(), StepFailure> {
            *out = coefficients_from_two_states(s, |e| {
                let mut d = [0.0];
                f(t, &[e], &mut d).map_or(f64::NAN, |()| d[0])
            });
            Ok(())
        };
        for dt in [1.0, 0.5] {
            let mut ode = ZdOde::new(1, dt, dt, (false, true));
            assert!(matches!(ode, ZdOde::Affine(_)), "dt {dt}");
            let mut eta = [eta0];
            let mut worst = 0.0f64;
            for k in 0..(20.0 / dt) as usize {
                let (t0, t1) = (k as f64 * dt, (k + 1) as f64 * dt);
                ode.advance_affine(t0, t1, &mut eta, &mut ab)
                    .expect("integrates");
                worst = worst.max((eta[0] - exact(t1)).abs());
            }
            let rel = worst / 2.5e4;
            assert!(rel < 1e-10, "dt {dt}: {rel:e}");
        }
        // A short interval, a state that is not alone or a logged run keep DOP853 and DOPRI5.
        assert!(!matches!(
            ZdOde::new(1, 0.01, 0.01, (false, true)),
            ZdOde::Affine(_)
        ));
        assert!(!matches!(
            ZdOde::new(2, 1.0, 1.0, (false, true)),
            ZdOde::Affine(_)
        ));
        assert!(!matches!(
            ZdOde::new(1, 1.0, 1.0, (true, true)),
            ZdOde::Affine(_)
        ));
    }
}
