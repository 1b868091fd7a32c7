//! Stable (non-causal) inversion of unstable zero dynamics (Devasia, Chen & Paden, IEEE TAC 41(7), 1996; Hunt &
//! Meyer, Automatica 33(8), 1997), as applied to drive cycles by Fröberg & Nielsen (IEEE TVT 57(3), 2008).
//!
//! # The problem
//!
//! For r < n the internal coordinates follow η̇ = q(ξ(t), η, y_d^(r)(t)) (Isidori, *Nonlinear Control Systems*,
//! §4.3). When ∂q/∂η has eigenvalues in the right half-plane (a non-minimum-phase system) integrating forward
//! from any η(t_0) blows up. Because the whole reference is known in advance, the *bounded* solution can be
//! computed instead: with A = ∂q/∂η split into its stable and unstable invariant subspaces E^s ⊕ E^u, the
//! bounded solution of the linearisation is (Devasia, Chen & Paden 1996, the linear time-invariant case)
//!
//! ```text
//! η(t) = ∫_{−∞}^{t} e^{A(t−τ)} P_s b(τ) dτ − ∫_{t}^{∞} e^{A(t−τ)} P_u b(τ) dτ,
//! ```
//!
//! i.e. the stable part integrated forward from the start and the unstable part backward from the end, and for
//! the nonlinear zero dynamics it is the solution of the boundary-value problem (Devasia–Chen–Paden solve it
//! as a fixed point around this linear one, Hunt & Meyer as a boundary-value problem in η)
//!
//! ```text
//! η̇ = q(ξ(t), η, y_d^(r)(t)) on [t_a, t_b],   P_s(a)(η(t_a) − η_a) = 0,   P_u(b)(η(t_b) − η_b) = 0,
//! ```
//!
//! where η_a, η_b are the equilibria of the zero dynamics for the constant reference before the cycle starts and
//! after it ends and P_s(a), P_u(b) the spectral projections of ∂q/∂η there: η leaves η_a along its unstable
//! manifold and arrives at η_b along its stable manifold. The reference is constant outside
//! [first corner − a, last corner + a] (the smoother's support), so ξ is known everywhere; the time grid is
//! extended before the cycle (pre-actuation) and after it (post-actuation) until the deviation from the
//! equilibria has decayed below the tolerance: T_pre = ln(1/tol)/min Re λ_u(a), T_post = ln(1/tol)/min |Re λ_s(b)|.
//!
//! # The method
//!
//! The boundary-value problem is discretised by Hermite–Simpson collocation (the 3-stage Lobatto IIIA method,
//! order 4, A-stable and symmetric, so it treats decaying and growing modes alike; Ascher, Mattheij & Russell,
//! *Numerical Solution of Boundary Value Problems for ODEs*, 1995, on symmetric collocation and dichotomy):
//!
//! ```text
//! η_{j+1} − η_j − h/6 (q_j + 4 q_{j+½} + q_{j+1}) = 0,   η_{j+½} = (η_j + η_{j+1})/2 + h/8 (q_j − q_{j+1}),
//! ```
//!
//! and solved by Newton's method on all nodes at once (the Newton step is the linear boundary-value problem
//! whose bounded solution is the formula above: the "integrate the stable part forward and the unstable part
//! backward" of the linearisation). The Jacobian is block bidiagonal plus the boundary rows, a band matrix
//! solved by Gaussian elimination with partial pivoting — for purely unstable zero dynamics an upper bidiagonal
//! matrix, whose back substitution is exactly the backward integration. Newton starts from the quasi-static
//! equilibria; it stops when the scaled step is below 1 % of the tolerance, with a clear error if it does not
//! converge.
//! The step size is chosen from the look-ahead, the solution computed on a grid and on the grid halved, and the
//! difference (Richardson: error ≈ difference/15 for order 4) must be below the tolerance, else the grid is
//! refined. Between nodes η is the collocation polynomial, the cubic Hermite interpolant of (η_j, q_j).

mod band;
mod bvp;
mod classify;
mod collocation;
mod error;
mod plan;

use invsim_model_api::InverseModel;

use crate::cycle::Cycle;
use crate::smoother::Smoother;
use bvp::{solve, Settings, Solution};
use classify::{classify_reference, Level};
use plan::{decay_horizons, plan, Plan};

pub(crate) use band::Band;
pub(crate) use collocation::{Collocation, CollocationPoint};
pub use error::StableError;
pub use invsim_model_api::zero_dynamics::ZeroDynamicsClass;

/// What the stable inversion takes from the simulation's options.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StableOptions {
    /// Tolerance (see `SimulationOptions::stable_tol`).
    pub tol: f64,
    /// Longest pre- or post-actuation allowed, s.
    pub max_pre_actuation: f64,
    /// The kernel half-width a, s: the node spacing starts at a/25 and is refined down to a/1000 at most.
    pub lookahead: f64,
    /// Causal integration asked for (forced, or by a given initial state): classify only.
    pub causal: bool,
}

/// A stable inversion ready for the driver: the solution on [t_a, t_b] and how many output samples it adds
/// before t_0 and after the cycle's end.
#[derive(Debug, Clone)]
pub(crate) struct StableRun {
    pub solution: Solution,
    pub plan: Plan,
    pub k_pre: usize,
    pub k_post: usize,
}

/// What the driver does with the zero dynamics.
#[derive(Debug, Clone)]
pub(crate) struct ZeroDynamicsPlan {
    pub class: ZeroDynamicsClass,
    /// Eigenvalues at the equilibrium for the reference's first value.
    pub eigenvalues: Vec<[f64; 2]>,
    /// `Some` when η is computed by stable inversion, `None` for causal integration (or r = n).
    pub stable: Option<StableRun>,
}

/// The options' stable-inversion values must be usable.
fn check_options(opts: &StableOptions) -> Result<(), StableError> {
    let fail = |reason: String| StableError::StableInversion { reason };
    if !(opts.tol > 0.0 && opts.tol < 1.0) {
        return Err(fail(format!(
            "the tolerance {} must lie strictly between 0 and 1",
            opts.tol
        )));
    }
    if !(opts.max_pre_actuation >= 0.0 && opts.max_pre_actuation.is_finite()) {
        return Err(fail(format!(
            "the pre-actuation limit {} s must be a finite, non-negative number of seconds",
            opts.max_pre_actuation
        )));
    }
    Ok(())
}

/// The levels the reference passes, (first, lowest, highest): y_d lies between the mapped extremes of the
/// cycle (the kernel is positive), and starts at the mapped first speed.
fn reference_levels(cycle: &Cycle, smoother: &Smoother) -> (f64, f64, f64) {
    let map = smoother.reference();
    let (v_min, v_max) = cycle
        .speed
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let (y_a, y_b) = (
        map.offset + map.scale * v_min,
        map.offset + map.scale * v_max,
    );
    let y_start = map.offset + map.scale * cycle.speed.first().copied().unwrap_or(0.0);
    (y_start, y_a.min(y_b), y_a.max(y_b))
}

/// The error for zero dynamics whose number of unstable eigenvalues differs between levels `a` and `b`.
fn type_change(a: &Level, b: &Level) -> StableError {
    let count = |l: &Level| {
        l.unstable.map(|u| u.to_string()).unwrap_or_else(|| {
            "an undetermined number of (an eigenvalue on the imaginary axis)".to_string()
        })
    };
    StableError::ZeroDynamicsTypeChange {
        y_from: a.y,
        y_to: b.y,
        from: count(a),
        to: count(b),
        eigenvalues_from: a.eigenvalues.clone(),
        eigenvalues_to: b.eigenvalues.clone(),
    }
}

/// Slowest decay rate |Re λ| of the unstable (or stable) eigenvalues.
fn slowest_rate(eigs: &[[f64; 2]], unstable: bool) -> f64 {
    eigs.iter()
        .map(|e| e[0])
        .filter(|&re| (re > 0.0) == unstable)
        .map(f64::abs)
        .fold(f64::INFINITY, f64::min)
}

/// Pre- and post-actuation (s) beyond [t0, t_end] that the decay to `tol` needs, checked against the limit.
fn actuation(
    p: &Plan,
    smoother: &Smoother,
    (s_start, s_end): (f64, f64),
    (t0, t_end): (f64, f64),
    opts: &StableOptions,
) -> Result<(f64, f64), StableError> {
    let (t_pre, t_post) = decay_horizons(&p.eig_a, &p.eig_b, opts.tol);
    // A constant reference needs none: η rests at the equilibrium throughout.
    let moving = smoother.support().is_some();
    let need_pre = if moving {
        (t0 - (s_start - t_pre)).max(0.0)
    } else {
        0.0
    };
    let need_post = if moving {
        (s_end + t_post - t_end).max(0.0)
    } else {
        0.0
    };
    if need_pre > opts.max_pre_actuation {
        return Err(StableError::PreActuationTooLong {
            which: "pre",
            needed: need_pre,
            rate: slowest_rate(&p.eig_a, true),
            max: opts.max_pre_actuation,
        });
    }
    if need_post > opts.max_pre_actuation {
        return Err(StableError::PreActuationTooLong {
            which: "post",
            needed: need_post,
            rate: slowest_rate(&p.eig_b, false),
            max: opts.max_pre_actuation,
        });
    }
    Ok((need_pre, need_post))
}

/// Classify the zero dynamics over the reference and, when they have unstable eigenvalues and causal
/// integration was not asked for, compute the stable inverse on the grid t_0 − k_pre·dt … t_end + k_post·dt
/// (`t_end` the grid's last time).
pub(crate) fn plan_run<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    smoother: &Smoother,
    (t0, t_end, dt): (f64, f64, f64),
    opts: &StableOptions,
) -> Result<ZeroDynamicsPlan, StableError> {
    if model.info().n_eta == 0 {
        return Ok(ZeroDynamicsPlan {
            class: ZeroDynamicsClass::None,
            eigenvalues: Vec::new(),
            stable: None,
        });
    }
    check_options(opts)?;
    let (y_start, y_lo, y_hi) = reference_levels(cycle, smoother);
    let c = classify_reference(model, y_start, y_lo, y_hi);
    let eigenvalues = c
        .start
        .as_ref()
        .map(|l| l.eigenvalues.clone())
        .unwrap_or_default();
    if opts.causal || !c.any_unstable {
        return Ok(ZeroDynamicsPlan {
            class: c.class,
            eigenvalues,
            stable: None,
        });
    }
    if let Some((a, b)) = &c.change {
        return Err(type_change(a, b));
    }
    let start = c.start.as_ref().map(|l| l.eta.clone());
    // Boundary conditions where the reference is constant: before the smoother's support and after it.
    let support = smoother.support().unwrap_or((t0, t_end));
    let (t_a, t_b) = (support.0.min(t0), support.1.max(t_end));
    let mut p = plan(model, smoother, t_a, t_b, c.unstable, start.as_deref())?;
    let (need_pre, need_post) = actuation(&p, smoother, support, (t0, t_end), opts)?;
    let samples = |t: f64| (t / dt - 1e-9).ceil().max(0.0) as usize;
    let (k_pre, k_post) = (samples(need_pre), samples(need_post));
    p.t_a = t0 - k_pre as f64 * dt;
    // A grid of one sample (a cycle of zero duration) still needs an interval for the collocation: beyond the
    // grid's end the reference is held, so the boundary condition may sit a second later.
    p.t_b = (t_end + k_post as f64 * dt).max(p.t_a + 1.0);
    let settings = Settings {
        tol: opts.tol,
        h0: opts.lookahead / 25.0,
        h_min: opts.lookahead * 1e-3,
    };
    let solution = solve(model, smoother, &p, settings)?;
    Ok(ZeroDynamicsPlan {
        class: c.class,
        eigenvalues,
        stable: Some(StableRun {
            solution,
            plan: p,
            k_pre,
            k_post,
        }),
    })
}
