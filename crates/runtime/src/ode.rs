//! Adaptive one-step integrators with error control and dense output, shared by the zero dynamics, the
//! verification replay and the forward simulation:
//!
//! * [`Dopri5`]: the explicit Dormand–Prince 5(4) pair (Hairer, Nørsett & Wanner, *Solving ODEs I*, 2nd ed.,
//!   §II.5, Table 5.2) with FSAL, its 4th-order continuous extension (§II.6, eq. 6.12 and the coefficients of
//!   the code DOPRI5) and the code's stiffness test (§IV.2 of Hairer & Wanner, *Solving ODEs II*: the
//!   estimate h·ρ ≈ h‖k7 − k6‖/‖y₁ − ŷ₆‖ of the step size times the dominant eigenvalue, compared with the
//!   border 3.25 of the stability region);
//! * [`Dop853`] (`ode/dop853.rs`): the explicit Prince–Dormand 8(5,3) pair of the code DOP853, with its
//!   optional continuous extension of order 7, for the zero dynamics of modes at tight tolerances (far fewer
//!   evaluations than [`Dopri5`] there);
//! * [`Rosenbrock23`]: the linearly implicit, L-stable Rosenbrock (W-)method of order 2 with a 3rd-order error
//!   estimate and a continuous extension, of Shampine & Reichelt (*The MATLAB ODE suite*, SIAM J. Sci.
//!   Comput. 18, 1997, §3; MATLAB's `ode23s`), for stiff problems (Hairer & Wanner II, §IV.7).
//!
//! Both use the error norm ‖e_i / (atol + rtol·max(|y_i|, |ŷ_i|))‖_rms ≤ 1 (Hairer I, eq. II.4.11) and the
//! step-size controller h_new = h·min(f_max, max(f_min, 0.9·err^(−1/(q+1)))) (q the order of the error
//! estimate's lower member; no growth right after a rejection, Hairer I §II.4). All buffers are allocated
//! once, except the Rosenbrock method's LU factorisation (a stiff path).

use nalgebra::{DMatrix, DVector};

mod affine;
mod dense;
mod dop853;
mod start;
pub(crate) use affine::AffineScalar;
pub use dense::{LoggedStep, StepLog};
pub use dop853::Dop853;

/// An integration failure: where, and why (a phrase).
#[derive(Debug, Clone, PartialEq)]
pub struct StepFailure {
    pub t: f64,
    pub reason: String,
}

/// Counters of one integrator.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct OdeStats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Evaluations of the right-hand side (Jacobian columns included).
    pub evaluations: usize,
    /// Jacobian evaluations (Rosenbrock only).
    pub jacobians: usize,
    /// Accepted steps whose size was limited by stability rather than accuracy: h·ρ beyond the border of the
    /// stability region (DOPRI5's stiffness estimate; Dormand–Prince only).
    pub stability_limited: usize,
}

impl std::ops::AddAssign for OdeStats {
    fn add_assign(&mut self, o: OdeStats) {
        self.accepted += o.accepted;
        self.rejected += o.rejected;
        self.evaluations += o.evaluations;
        self.jacobians += o.jacobians;
        self.stability_limited += o.stability_limited;
    }
}

/// Smallest step relative to |t| before the integrator gives up.
fn h_min(t: f64) -> f64 {
    16.0 * f64::EPSILON * t.abs().max(1.0)
}

/// Accepted steps one output interval may take.
const MAX_STEPS: usize = 1_000_000;

/// Accepted steps `step(t) → t_new` from `t0` until `t1`: `None` when t1 is reached, else the time where
/// [`MAX_STEPS`] ran out.
fn steps_until<E>(
    t0: f64,
    t1: f64,
    mut step: impl FnMut(f64) -> Result<f64, E>,
) -> Result<Option<f64>, E> {
    let mut t = t0;
    for _ in 0..MAX_STEPS {
        if t >= t1 {
            return Ok(None);
        }
        t = step(t)?;
    }
    Ok((t < t1).then_some(t))
}

/// The failure of an interval that needed more than [`MAX_STEPS`] steps.
fn too_many_steps(t: f64) -> StepFailure {
    StepFailure {
        t,
        reason: format!("more than {MAX_STEPS} steps in one output interval"),
    }
}

/// The step-size controller of an explicit pair (Hairer I, §II.4): after an accepted step
/// h_new = h·min(grow, max(shrink, 0.9·err^(−exponent))) (no growth right after a rejection), after a rejected one
/// h·min(0.9, max(reject_shrink, 0.9·err^(−exponent))), and h/10 where the error is not finite.
#[derive(Debug, Clone, Copy)]
struct Controller {
    exponent: f64,
    shrink: f64,
    grow: f64,
    reject_shrink: f64,
}

impl Controller {
    /// The step to try after a step of `h` with error `err` that was accepted (err ≤ 1) or not.
    fn next(&self, err: f64, h: f64, rejected_last: bool) -> f64 {
        let factor = if err <= 1.0 {
            let grow = if rejected_last { 1.0 } else { self.grow };
            if err == 0.0 {
                grow
            } else {
                (0.9 * self.inverse_root(err)).clamp(self.shrink, grow)
            }
        } else if err.is_finite() {
            (0.9 * self.inverse_root(err)).clamp(self.reject_shrink, 0.9)
        } else {
            0.1
        };
        h * factor
    }

    /// err^(−exponent); DOP853's exponent 1/8 as three square roots (a step-size factor needs no more than
    /// their accuracy, a few ulps, and a power costs several times their time).
    fn inverse_root(&self, err: f64) -> f64 {
        if self.exponent == 0.125 {
            1.0 / err.sqrt().sqrt().sqrt()
        } else {
            err.powf(-self.exponent)
        }
    }
}

/// The step to take from t towards `t_end` with the proposed step `h`: exactly the rest where h reaches
/// `t_end` or leaves a sliver of it (then `true`).
fn clip(h: f64, t: f64, t_end: f64) -> (f64, bool) {
    let remaining = t_end - t;
    let clipped = h >= remaining * (1.0 - 1e-12) || h * 1.01 >= remaining;
    (if clipped { remaining } else { h }, clipped)
}

fn too_small<E: From<StepFailure>>(t: f64) -> E {
    E::from(StepFailure {
        t,
        reason: format!(
            "the step size fell below {} s (the right-hand side is not finite near this state, or the problem \
             is too stiff)",
            crate::numfmt::num(h_min(t))
        ),
    })
}

/// Adaptive Dormand–Prince 5(4) (Hairer, Nørsett & Wanner I, §II.5) with FSAL, dense output and stiffness
/// detection; the step size is carried over from one call to the next.
pub struct Dopri5 {
    rtol: f64,
    atol: f64,
    h: f64,
    k: [Vec<f64>; 7],
    y_stage: Vec<f64>,
    y_new: Vec<f64>,
    fsal: bool,
    /// Dense output of the last accepted step [t_old, t_old + h_old] (Hairer I, §II.6; code DOPRI5 `CONTD5`).
    t_old: f64,
    h_old: f64,
    rcont: [Vec<f64>; 5],
    /// Stiffness test (Hairer II, §IV.2): steps with h·ρ > 3.25 and steps since the last such step.
    stiff_hits: usize,
    nonstiff_run: usize,
    stiff: bool,
    /// h·ρ of the last accepted step (NaN when not measurable).
    pub last_h_rho: f64,
    pub stats: OdeStats,
    /// Where and with which state the last failure happened (for diagnostics).
    pub t_fail: f64,
    pub y_fail: Vec<f64>,
    /// The leading components that enter the error norm and the stiffness test (all by default).
    n_err: usize,
    /// Whether `accept` prepares the dense output (see [`Dopri5::without_dense_output`]).
    dense_output: bool,
}

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
// Error coefficients b − b̂.
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
// Dense output (Hairer I, §II.6; Shampine 1986), as in the code DOPRI5.
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// DOPRI5's controller: exponent 1/5 (its error estimate is of order 4), growth at most 5, shrinking at most to
/// 0.2 after an accepted step and 0.1 after a rejected one (the code's bounds).
const DOPRI5_CONTROL: Controller = Controller {
    exponent: 0.2,
    shrink: 0.2,
    grow: 5.0,
    reject_shrink: 0.1,
};

/// Border of the stability region of DOPRI5 on the negative real axis, about 3.3 (Hairer II, §IV.2).
pub const DOPRI5_STIFF_BORDER: f64 = 3.25;
/// Accepted steps with h·ρ beyond the border after which DOPRI5 declares the problem stiff (the code's 15).
pub const DOPRI5_STIFF_STEPS: usize = 15;

impl Dopri5 {
    pub fn new(n: usize, rtol: f64, atol: f64, h0: f64) -> Self {
        Dopri5 {
            rtol,
            atol,
            h: h0,
            k: std::array::from_fn(|_| vec![0.0; n]),
            y_stage: vec![0.0; n],
            y_new: vec![0.0; n],
            fsal: false,
            t_old: 0.0,
            h_old: 0.0,
            rcont: std::array::from_fn(|_| vec![0.0; n]),
            stiff_hits: 0,
            nonstiff_run: 0,
            stiff: false,
            last_h_rho: f64::NAN,
            stats: OdeStats::default(),
            t_fail: 0.0,
            y_fail: vec![0.0; n],
            n_err: n,
            dense_output: true,
        }
    }

    /// Only the first `m` components enter the error norm and the stiffness test; the others (quadrature
    /// states Q' = o(t, y) that nothing depends on) are integrated along with the same steps, so appending
    /// them leaves the solution of the first `m` unchanged.
    pub fn error_components(mut self, m: usize) -> Self {
        self.n_err = m;
        self
    }

    /// No dense output: an accepted step skips the continuous extension's coefficients (the steps and the
    /// solution are the same bit for bit) and [`Dopri5::dense`] gives NaN. For a caller that only needs the
    /// solution at the ends of its calls.
    pub fn without_dense_output(mut self) -> Self {
        self.dense_output = false;
        self
    }

    /// Forget the FSAL stage and the step size (after a jump in the state).
    pub fn reset(&mut self, h0: f64) {
        self.fsal = false;
        self.h = h0;
    }

    /// Start afresh from (t, y): f(t, y) as the first stage, and the starting step of `start.rs` (at most
    /// `h_max`) as the step size; one more evaluation.
    pub fn start<F, E>(&mut self, t: f64, y: &[f64], h_max: f64, f: &mut F) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        f(t, y, &mut self.k[0])?;
        let [f0, f1, ..] = &mut self.k;
        let bufs = (&mut self.y_stage[..], &mut f1[..]);
        let tol = (self.rtol, self.atol);
        self.h = start::starting_step((t, y, f0), tol, 5, h_max, bufs, f)?;
        self.stats.evaluations += 2;
        self.fsal = true;
        Ok(())
    }

    /// Forget the FSAL stage but keep the step size (after a jump in the right-hand side, e.g. at a corner of
    /// a piecewise-linear drive cycle: the next step starts with a fresh k1 = f(t, y)).
    pub fn restart(&mut self) {
        self.fsal = false;
    }

    /// The step size the controller proposes for the next step.
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// True once the stiffness test has fired: 15 accepted steps with h·ρ > 3.25, none separated by 6
    /// consecutive non-stiff steps (the rule of the code DOPRI5).
    pub fn is_stiff(&self) -> bool {
        self.stiff
    }

    /// Integrate y from `t0` to `t1` (> t0) in place.
    pub fn advance<F, E>(&mut self, t0: f64, t1: f64, y: &mut [f64], f: &mut F) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
        E: From<StepFailure>,
    {
        self.advance_each(t0, t1, y, f, &mut |_, _, _| Ok(()))
    }

    /// [`Dopri5::advance`] (the same steps, bit for bit), calling `each(self, t, t_new)` after every accepted
    /// step [t, t_new], while [`Dopri5::dense`] interpolates in it.
    pub fn advance_each<F, G, E>(
        &mut self,
        t0: f64,
        t1: f64,
        y: &mut [f64],
        f: &mut F,
        each: &mut G,
    ) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
        G: FnMut(&Dopri5, f64, f64) -> Result<(), E>,
        E: From<StepFailure>,
    {
        let Some(t) = steps_until(t0, t1, |t| -> Result<f64, E> {
            let t_new = self.step_to(t, t1, y, f)?;
            each(self, t, t_new)?;
            Ok(t_new)
        })?
        else {
            return Ok(());
        };
        self.t_fail = t;
        self.y_fail.copy_from_slice(y);
        Err(E::from(too_many_steps(t)))
    }

    /// One accepted step from (t, y) towards `t_end` (> t), retrying with smaller steps after rejections; y is
    /// updated in place and the new time returned (exactly `t_end` when the step reaches it). Afterwards
    /// [`Dopri5::dense`] interpolates anywhere in the step.
    pub fn step_to<F, E>(&mut self, t: f64, t_end: f64, y: &mut [f64], f: &mut F) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
        E: From<StepFailure>,
    {
        if !self.fsal {
            f(t, y, &mut self.k[0])?;
            self.stats.evaluations += 1;
            self.fsal = true;
        }
        let mut rejected_last = false;
        loop {
            if self.h < h_min(t) || !self.h.is_finite() {
                self.t_fail = t;
                self.y_fail.copy_from_slice(y);
                return Err(too_small(t));
            }
            // Land exactly on t_end (and avoid a sliver of a last step).
            let (h, clipped) = clip(self.h, t, t_end);
            let err = self.step(t, h, y, f)?;
            let next = DOPRI5_CONTROL.next(err, h, rejected_last);
            if err <= 1.0 {
                let t_new = if clipped { t_end } else { t + h };
                self.accept(t, h, y);
                // A step shortened to land on t_end says little about the step size the solution allows.
                self.h = if clipped { next.max(self.h) } else { next };
                return Ok(t_new);
            }
            self.stats.rejected += 1;
            self.h = next;
            rejected_last = true;
        }
    }

    /// One step of exactly `h` from (t, y), accepted whatever its error (for convergence studies); returns the
    /// error estimate.
    pub fn fixed_step<F, E>(&mut self, t: f64, h: f64, y: &mut [f64], f: &mut F) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        if !self.fsal {
            f(t, y, &mut self.k[0])?;
            self.stats.evaluations += 1;
            self.fsal = true;
        }
        let err = self.step(t, h, y, f)?;
        self.accept(t, h, y);
        Ok(err)
    }

    /// Commit the step just computed by [`Dopri5::step`]: dense-output coefficients, stiffness test, y = ŷ and
    /// FSAL (k7 = f(t + h, ŷ) is the next k1).
    fn accept(&mut self, t: f64, h: f64, y: &mut [f64]) {
        let n = y.len();
        let [k1, _, k3, k4, k5, k6, k7] = &self.k;
        let [r1, r2, r3, r4, r5] = &mut self.rcont;
        // Stiffness: h·ρ ≈ h‖k7 − k6‖ / ‖ŷ − y₆‖, y₆ the argument of the 6th stage (both at t + h).
        let (mut num, mut den) = (0.0, 0.0);
        let m = self.n_err.min(n);
        if self.dense_output {
            for i in 0..n {
                let ydiff = self.y_new[i] - y[i];
                let bspl = h * k1[i] - ydiff;
                r1[i] = y[i];
                r2[i] = ydiff;
                r3[i] = bspl;
                r4[i] = ydiff - h * k7[i] - bspl;
                r5[i] = h
                    * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i] + D7 * k7[i]);
            }
        }
        for i in 0..m {
            num += (k7[i] - k6[i]) * (k7[i] - k6[i]);
            den += (self.y_new[i] - self.y_stage[i]) * (self.y_new[i] - self.y_stage[i]);
        }
        self.last_h_rho = if den > 0.0 {
            h * (num / den).sqrt()
        } else {
            f64::NAN
        };
        if self.last_h_rho > DOPRI5_STIFF_BORDER {
            self.stats.stability_limited += 1;
            self.nonstiff_run = 0;
            self.stiff_hits += 1;
            if self.stiff_hits >= DOPRI5_STIFF_STEPS {
                self.stiff = true;
            }
        } else {
            self.nonstiff_run += 1;
            if self.nonstiff_run >= 6 {
                self.stiff_hits = 0;
            }
        }
        self.t_old = t;
        self.h_old = h;
        y.copy_from_slice(&self.y_new[..n]);
        self.k.swap(0, 6);
        self.stats.accepted += 1;
    }

    /// The continuous extension of the last accepted step at `t` (4th order; exact at both ends):
    /// y(t_old + θh) = r1 + θ(r2 + (1 − θ)(r3 + θ(r4 + (1 − θ) r5))).
    pub fn dense(&self, t: f64, out: &mut [f64]) {
        if !self.dense_output {
            out.fill(f64::NAN);
            return;
        }
        let theta = if self.h_old > 0.0 {
            (t - self.t_old) / self.h_old
        } else {
            0.0
        };
        let theta1 = 1.0 - theta;
        let [r1, r2, r3, r4, r5] = &self.rcont;
        for (i, o) in out.iter_mut().enumerate() {
            *o = r1[i] + theta * (r2[i] + theta1 * (r3[i] + theta * (r4[i] + theta1 * r5[i])));
        }
    }

    /// The last accepted step's start, size and continuous extension r1 … r5 (NaN-free only with dense
    /// output).
    pub fn continuous_extension(&self) -> (f64, f64, [&[f64]; 5]) {
        (
            self.t_old,
            self.h_old,
            self.rcont.each_ref().map(Vec::as_slice),
        )
    }

    /// One step of size h from (t, y) with k1 = f(t, y) in k[0]; fills ŷ (5th order) and k[1..7], returns the
    /// error norm (NaN → rejected).
    pub fn step<F, E>(&mut self, t: f64, h: f64, y: &[f64], f: &mut F) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        let n = y.len();
        let [k1, k2, k3, k4, k5, k6, k7] = &mut self.k;
        let ys = &mut self.y_stage;
        for i in 0..n {
            ys[i] = y[i] + h * A21 * k1[i];
        }
        f(t + C2 * h, ys, k2)?;
        for i in 0..n {
            ys[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i]);
        }
        f(t + C3 * h, ys, k3)?;
        for i in 0..n {
            ys[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        f(t + C4 * h, ys, k4)?;
        for i in 0..n {
            ys[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        f(t + C5 * h, ys, k5)?;
        for i in 0..n {
            ys[i] =
                y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
        }
        f(t + h, ys, k6)?;
        let yn = &mut self.y_new;
        for i in 0..n {
            yn[i] =
                y[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i]);
        }
        f(t + h, yn, k7)?;
        self.stats.evaluations += 6;
        let mut sum = 0.0;
        let m = self.n_err.min(n);
        for i in 0..m {
            let e =
                h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            let sc = self.atol + self.rtol * y[i].abs().max(yn[i].abs());
            sum += (e / sc) * (e / sc);
        }
        let err = (sum / m.max(1) as f64).sqrt();
        Ok(if err.is_finite() { err } else { f64::NAN })
    }
}

/// The L-stable Rosenbrock 2(3) method of Shampine & Reichelt (1997, §3; MATLAB's `ode23s`), for stiff
/// problems; with W = I − h d J, J = ∂f/∂y and T = ∂f/∂t (both by finite differences at the start of every
/// step), d = 1/(2 + √2), e32 = 6 + √2:
///
/// ```text
/// k1 = W⁻¹ (f(t, y) + h d T)
/// k2 = W⁻¹ (f(t + h/2, y + h k1/2) − k1) + k1
/// y₁ = y + h k2                                                     (order 2)
/// k3 = W⁻¹ (f(t + h, y₁) − e32 (k2 − f(t + h/2, …)) − 2 (k1 − f(t, y)) + h d T)
/// err = h (k1 − 2 k2 + k3) / 6                                      (3rd-order estimate of the local error)
/// y(t + θh) = y + h (θ(1 − θ) k1 + θ(θ − 2d) k2) / (1 − 2d)          (continuous extension)
/// ```
///
/// f(t + h, y₁) is the next step's f(t, y) (FSAL).
pub struct Rosenbrock23 {
    rtol: f64,
    atol: f64,
    h: f64,
    f0: Vec<f64>,
    f1: Vec<f64>,
    f2: Vec<f64>,
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    dfdt: Vec<f64>,
    jac: Vec<f64>,
    scratch: Vec<f64>,
    y_new: Vec<f64>,
    fsal: bool,
    t_old: f64,
    h_old: f64,
    y_old: Vec<f64>,
    pub stats: OdeStats,
    /// The leading components that enter the error norm (all by default).
    n_err: usize,
}

const RB_D: f64 = 0.292_893_218_813_452_5; // 1/(2 + √2)
const RB_E32: f64 = 7.414_213_562_373_095; // 6 + √2

// The stages combine several vectors element by element; index loops say that most plainly.
#[allow(clippy::needless_range_loop)]
impl Rosenbrock23 {
    pub fn new(n: usize, rtol: f64, atol: f64, h0: f64) -> Self {
        Rosenbrock23 {
            rtol,
            atol,
            h: h0,
            f0: vec![0.0; n],
            f1: vec![0.0; n],
            f2: vec![0.0; n],
            k1: vec![0.0; n],
            k2: vec![0.0; n],
            k3: vec![0.0; n],
            dfdt: vec![0.0; n],
            jac: vec![0.0; n * n],
            scratch: vec![0.0; n],
            y_new: vec![0.0; n],
            fsal: false,
            t_old: 0.0,
            h_old: 0.0,
            y_old: vec![0.0; n],
            stats: OdeStats::default(),
            n_err: n,
        }
    }

    /// Only the first `m` components enter the error norm (see [`Dopri5::error_components`]).
    pub fn error_components(mut self, m: usize) -> Self {
        self.n_err = m;
        self
    }

    /// Forget f(t, y) but keep the step size (after a jump in the right-hand side).
    pub fn restart(&mut self) {
        self.fsal = false;
    }

    /// Set the next step size (e.g. when taking over from another integrator).
    pub fn set_step_size(&mut self, h: f64) {
        self.h = h;
    }

    /// The step size the controller proposes for the next step.
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// J = ∂f/∂y (column major) and T = ∂f/∂t at (t, y) by forward differences, with f(t, y) in `f0`
    /// (increments √ε·max(|y_j|, atol/rtol-scale)).
    fn jacobian<F, E>(&mut self, t: f64, y: &[f64], f: &mut F) -> Result<(), E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        let n = y.len();
        let sqrt_eps = f64::EPSILON.sqrt();
        self.scratch.copy_from_slice(y);
        for j in 0..n {
            let delta = sqrt_eps * y[j].abs().max(self.atol / self.rtol).max(1e-8);
            self.scratch[j] = y[j] + delta;
            let delta = self.scratch[j] - y[j];
            f(t, &self.scratch, &mut self.k3)?;
            self.scratch[j] = y[j];
            let column = &mut self.jac[j * n..(j + 1) * n];
            for i in 0..n {
                column[i] = (self.k3[i] - self.f0[i]) / delta;
            }
        }
        let dt = sqrt_eps * t.abs().max(1.0);
        f(t + dt, y, &mut self.k3)?;
        for i in 0..n {
            self.dfdt[i] = (self.k3[i] - self.f0[i]) / dt;
        }
        self.stats.evaluations += n + 1;
        self.stats.jacobians += 1;
        Ok(())
    }

    /// One accepted step from (t, y) towards `t_end` (see [`Dopri5::step_to`]).
    pub fn step_to<F, E>(&mut self, t: f64, t_end: f64, y: &mut [f64], f: &mut F) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
        E: From<StepFailure>,
    {
        let n = y.len();
        if !self.fsal {
            f(t, y, &mut self.f0)?;
            self.stats.evaluations += 1;
            self.fsal = true;
        }
        self.jacobian(t, y, f)?;
        let jac = DMatrix::from_column_slice(n, n, &self.jac);
        let mut rejected_last = false;
        loop {
            let remaining = t_end - t;
            if self.h < h_min(t) || !self.h.is_finite() {
                return Err(too_small(t));
            }
            let clipped = self.h >= remaining * (1.0 - 1e-12) || self.h * 1.01 >= remaining;
            let h = if clipped { remaining } else { self.h };
            let err = self.attempt(t, h, y, &jac, f)?;
            if err <= 1.0 {
                let t_new = if clipped { t_end } else { t + h };
                self.t_old = t;
                self.h_old = h;
                self.y_old.copy_from_slice(y);
                y.copy_from_slice(&self.y_new);
                std::mem::swap(&mut self.f0, &mut self.f2);
                self.stats.accepted += 1;
                let grow = if rejected_last { 1.0 } else { 5.0 };
                let factor = if err == 0.0 {
                    grow
                } else {
                    (0.9 * err.powf(-1.0 / 3.0)).clamp(0.2, grow)
                };
                let proposed = h * factor;
                self.h = if clipped {
                    proposed.max(self.h)
                } else {
                    proposed
                };
                return Ok(t_new);
            }
            self.stats.rejected += 1;
            let factor = if err.is_finite() {
                (0.9 * err.powf(-1.0 / 3.0)).clamp(0.1, 0.9)
            } else {
                0.1
            };
            self.h = h * factor;
            rejected_last = true;
        }
    }

    /// One step of exactly `h`, accepted whatever its error (for convergence studies); returns the error.
    pub fn fixed_step<F, E>(&mut self, t: f64, h: f64, y: &mut [f64], f: &mut F) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        let n = y.len();
        if !self.fsal {
            f(t, y, &mut self.f0)?;
            self.stats.evaluations += 1;
            self.fsal = true;
        }
        self.jacobian(t, y, f)?;
        let jac = DMatrix::from_column_slice(n, n, &self.jac);
        let err = self.attempt(t, h, y, &jac, f)?;
        self.t_old = t;
        self.h_old = h;
        self.y_old.copy_from_slice(y);
        y.copy_from_slice(&self.y_new);
        std::mem::swap(&mut self.f0, &mut self.f2);
        self.stats.accepted += 1;
        Ok(err)
    }

    /// The stages of one step of size h; fills y_new and f2 = f(t + h, y_new), returns the error norm (NaN or
    /// a singular W → ∞, i.e. rejected).
    fn attempt<F, E>(
        &mut self,
        t: f64,
        h: f64,
        y: &[f64],
        jac: &DMatrix<f64>,
        f: &mut F,
    ) -> Result<f64, E>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), E>,
    {
        let n = y.len();
        let w = DMatrix::<f64>::identity(n, n) - jac * (h * RB_D);
        let lu = w.lu();
        let solve = |rhs: &[f64], out: &mut [f64]| -> bool {
            match lu.solve(&DVector::from_column_slice(rhs)) {
                Some(s) if s.iter().all(|v| v.is_finite()) => {
                    out.copy_from_slice(s.as_slice());
                    true
                }
                _ => false,
            }
        };
        // k1 = W⁻¹ (F0 + h d T).
        for i in 0..n {
            self.scratch[i] = self.f0[i] + h * RB_D * self.dfdt[i];
        }
        if !solve(&self.scratch, &mut self.k1) {
            return Ok(f64::INFINITY);
        }
        // F1 = f(t + h/2, y + h k1/2); k2 = W⁻¹ (F1 − k1) + k1.
        for i in 0..n {
            self.scratch[i] = y[i] + 0.5 * h * self.k1[i];
        }
        f(t + 0.5 * h, &self.scratch, &mut self.f1)?;
        for i in 0..n {
            self.scratch[i] = self.f1[i] - self.k1[i];
        }
        if !solve(&self.scratch, &mut self.k2) {
            return Ok(f64::INFINITY);
        }
        for i in 0..n {
            self.k2[i] += self.k1[i];
            self.y_new[i] = y[i] + h * self.k2[i];
        }
        // F2 = f(t + h, y₁); k3 = W⁻¹ (F2 − e32 (k2 − F1) − 2 (k1 − F0) + h d T).
        f(t + h, &self.y_new, &mut self.f2)?;
        self.stats.evaluations += 2;
        for i in 0..n {
            self.scratch[i] =
                self.f2[i] - RB_E32 * (self.k2[i] - self.f1[i]) - 2.0 * (self.k1[i] - self.f0[i])
                    + h * RB_D * self.dfdt[i];
        }
        if !solve(&self.scratch, &mut self.k3) {
            return Ok(f64::INFINITY);
        }
        let mut sum = 0.0;
        let m = self.n_err.min(n);
        for i in 0..m {
            let e = h / 6.0 * (self.k1[i] - 2.0 * self.k2[i] + self.k3[i]);
            let sc = self.atol + self.rtol * y[i].abs().max(self.y_new[i].abs());
            sum += (e / sc) * (e / sc);
        }
        let err = (sum / m.max(1) as f64).sqrt();
        Ok(if err.is_finite() { err } else { f64::INFINITY })
    }

    /// The continuous extension of the last accepted step at `t` (2nd order; exact at both ends).
    pub fn dense(&self, t: f64, out: &mut [f64]) {
        let s = if self.h_old > 0.0 {
            (t - self.t_old) / self.h_old
        } else {
            0.0
        };
        let c1 = s * (1.0 - s) / (1.0 - 2.0 * RB_D);
        let c2 = s * (s - 2.0 * RB_D) / (1.0 - 2.0 * RB_D);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.y_old[i] + self.h_old * (c1 * self.k1[i] + c2 * self.k2[i]);
        }
    }
}
