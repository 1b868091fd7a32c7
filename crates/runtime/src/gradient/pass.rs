//! The sensitivity pass of a causal (or r = n) run: the run's grid sample by sample, η integrated exactly as
//! the run integrates it, its sensitivities S = ∂η/∂p alongside by an A-stable method, and the derivatives of
//! the accumulated outputs' integrals by the run's own quadrature.
//!
//! Sensitivity equations of the zero dynamics η̇ = q(ξ(t), η, y_d^(r)(t); p) (Hairer, Nørsett & Wanner,
//! *Solving Ordinary Differential Equations I*, §I.14):
//!
//! ```text
//! dS/dt = A(t) S + B(t),   A = ∂q/∂η (ne × ne),   B = ∂q/∂p (ne × P),   both along η(t)
//! S(t_0) = 0 for a given η(t_0), −(∂q/∂η)⁻¹ ∂q/∂p at an equilibrium start (implicit function theorem)
//! ```
//!
//! They are solved by the staggered direct method (Caracotsios & Stewart, *Sensitivity analysis of initial
//! value problems with mixed ODEs and algebraic equations*, Comput. Chem. Eng. 9, 1985): η alone is
//! integrated by the run's adaptive Dormand–Prince 5(4) method with its tolerances and its right-hand side,
//! from the same start between the same grid samples, so η is the run's bit for bit; after each accepted
//! step [t, t + h] S is advanced over the same step by the 2-stage Gauss–Legendre method ([`super::gauss`],
//! order 4, A-stable; Hairer & Wanner, *Solving ODEs II*, §IV.5), with A and B at its two nodes t + c_i h
//! from η's continuous extension there ([`Point::eta_jacobians`]). S's equations are linear with η's own
//! linearisation A, so the steps that control η's error resolve S's time scales too and S needs no error
//! control of its own; on the stiff modes, where the steps are held at DOPRI5's stability border
//! hλ ≈ −3.3, the method damps by |R(hλ)| ≈ 0.07 per step (R the (2, 2) Padé approximation of e^z).
//!
//! Why not the run's explicit method for S too: on stiff zero dynamics (driveline's shaft, λ ≈ −300/s) the
//! controller holds DOPRI5's steps at its stability limit, where η stays bounded only through step
//! rejections; the derivative of that frozen-step map grows without bound, so S had to enter the error norm,
//! which made the sensitivities' steps differ from the run's and cost ≥ 6 evaluations of A and B per step.
//! Gauss–Legendre is stable for any step of a stable A and costs two evaluations per step.
//!
//! The integrals ∫ o dt ≈ Σ_k dt·(o_k + o_{k+1})/2 are differentiated term by term:
//! ∂/∂p Σ = Σ_k dt·(do_k/dp + do_{k+1}/dp)/2, with do/dp = ∂o/∂x·dx/dp + ∂o/∂u·du/dp + ∂o/∂p
//! ([`super::point`]). The reference is evaluated block by block on the grid, as the run evaluates it, so that
//! the pass stores no column of the whole run.

use invsim_model_api::zero_dynamics::{default_starts, equilibrium};
use invsim_model_api::InverseModel;
use nalgebra::DMatrix;

use super::closed_jacobian::{ClosedJacobian, Rows};
use super::gauss::{Gauss, Singular, NODES};
use super::grid_columns::GridColumns;
use super::point::{Buffers, Point};
use super::sample::{Block, Samples};
use crate::error::RunError;
use crate::grid::{Grid, MAX_DERIVATIVES};
use crate::inverse::stage_reference::StageReference;
use crate::inverse::{SimulateError, SimulationOptions};
use crate::ode::{Dopri5, StepFailure};
use crate::smoother::{FineTable, Smoother};
use std::sync::Arc;

/// Samples per block of the reference's columns (the run's block size: the same numbers, bounded memory).
const BLOCK: usize = 4096;

/// What the pass runs along: the smoother and the grid (y_d … y_d^(r) and w evaluated on it block by block,
/// as the run evaluates them), and the run's sub-grid table of the zero dynamics' reference, if it has one
/// (read again, not evaluated again).
pub(crate) struct Along<'a> {
    pub smoother: &'a Smoother,
    pub grid: &'a Grid,
    pub fine: Option<&'a Arc<FineTable>>,
}

/// The model, the parameters (indices into [`invsim_model_api::ModelInfo::parameters`], and P + g for the
/// grid value g of `grid`) and the accumulated outputs (indices into its `outputs`) differentiated.
pub(crate) struct Wanted<'a, M: ?Sized> {
    pub model: &'a M,
    pub params: &'a [usize],
    pub grid: &'a GridColumns,
    pub accumulate: &'a [usize],
}

/// ∂(∫ o_a dt)/∂p_c for every accumulated output a and wanted parameter c (`[a][c]`), over the whole grid
/// (a causal run reports every sample). `eta0`: the run's given η(t_0) (`None`: the equilibrium start).
pub(crate) fn integral_gradients<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    along: &Along<'_>,
    eta0: Option<Vec<f64>>,
    opts: &SimulationOptions,
) -> Result<Vec<Vec<f64>>, SimulateError> {
    Ok(sweep(wanted, along, eta0, opts, &mut |_, _| ())?
        .samples
        .sums
        .integrals())
}

/// The pass over the whole grid; `seen(k, η)` after each sample k.
fn sweep<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    along: &Along<'_>,
    eta0: Option<Vec<f64>>,
    opts: &SimulationOptions,
    seen: &mut dyn FnMut(usize, &[f64]),
) -> Result<Sweep, SimulateError> {
    let info = wanted.model.info();
    let (r, nw) = (info.relative_degree, info.n_w());
    let grid = along.grid;
    let samples = grid.samples();
    let (eta, s) = if info.n_eta > 0 {
        start(wanted, along, eta0)?
    } else {
        (Vec::new(), Vec::new())
    };
    let mut sweep = Sweep::new(wanted, along, (eta, s), opts);
    let mut block = Block::new(BLOCK.min(samples), r, nw);
    let mut k0 = 0;
    while k0 < samples {
        let len = (k0 + BLOCK).min(samples) - k0;
        block.fill(along.smoother, grid, (k0, len));
        for i in 0..len {
            sweep.sample(wanted, along, (k0 + i, &block.yd, &block.w, i))?;
            seen(k0 + i, &sweep.eta);
        }
        k0 += len;
    }
    Ok(sweep)
}

/// The pass's state from sample to sample: η and its integrator, S (ne × P column-major, column c = ∂η/∂p_c),
/// and what every pass carries ([`Samples`]: the last sample's state and input, the integrals' derivatives).
struct Sweep {
    eta: Vec<f64>,
    s: Vec<f64>,
    integrator: Dopri5,
    /// The reference at η's stage times, read as the run reads it (`inverse/stage_reference.rs`).
    stages: StageReference,
    nodes: Nodes,
    samples: Samples,
}

impl Sweep {
    fn new<M: InverseModel + ?Sized>(
        wanted: &Wanted<'_, M>,
        along: &Along<'_>,
        (eta, s): (Vec<f64>, Vec<f64>),
        opts: &SimulationOptions,
    ) -> Sweep {
        let info = wanted.model.info();
        let (na, np) = (wanted.accumulate.len(), wanted.params.len());
        // Both readers of the reference at stage times share one table: the run's where it has one.
        let stages = StageReference::sharing(along.smoother, along.grid, (opts, info), along.fine);
        let nodes =
            StageReference::sharing(along.smoother, along.grid, (opts, info), stages.table());
        Sweep {
            // The run's integrator (inverse/causal.rs): the same size, tolerances and first step.
            integrator: Dopri5::new(eta.len(), opts.rtol, opts.atol, opts.dt),
            stages,
            eta,
            s,
            nodes: Nodes::new(info, wanted.params, nodes),
            samples: Samples::new(info.n_states(), na, np),
        }
    }

    /// Grid sample k (column index i of the block's `yd` and `w`): η and S advanced from sample k − 1, the
    /// inverse, the outputs' derivatives, and the trapezoidal rule's term dt·(do_(k−1) + do_k)/2.
    fn sample<M: InverseModel + ?Sized>(
        &mut self,
        wanted: &Wanted<'_, M>,
        along: &Along<'_>,
        (k, yd, w, i): (usize, &[Vec<f64>], &[Vec<f64>], usize),
    ) -> Result<(), SimulateError> {
        let model = wanted.model;
        let info = model.info();
        let ne = info.n_eta;
        let grid = along.grid;
        let t = grid.time(k);
        if k > 0 && ne > 0 {
            self.advance(wanted, along.smoother, (grid.time(k - 1), t))?;
        }
        let point = self
            .samples
            .point((model, wanted.grid), (t, yd, w, i), &self.eta)?;
        let half = (k > 0).then_some(0.5 * grid.dt);
        self.samples.add_outputs(
            &point,
            (wanted.params, wanted.accumulate),
            &self.s[..ne * wanted.params.len()],
            half,
        );
        self.samples.recycle(point);
        Ok(())
    }

    /// η from `t0` to `t1` exactly as the run integrates it (inverse/causal.rs `integrate`: the same
    /// right-hand side, the last sample's input as Newton's start), and S over each of its accepted steps.
    fn advance<M: InverseModel + ?Sized>(
        &mut self,
        wanted: &Wanted<'_, M>,
        smoother: &Smoother,
        (t0, t1): (f64, f64),
    ) -> Result<(), SimulateError> {
        let model = wanted.model;
        let r = model.info().relative_degree;
        let u_prev = self.samples.u_prev;
        let stages = &mut self.stages;
        let mut q = |s: f64, e: &[f64], de: &mut [f64]| {
            stages.zero_dynamics(model, smoother, (s, r), (e, u_prev), de);
            Ok(())
        };
        self.nodes.x.copy_from_slice(&self.samples.x);
        let (nodes, s) = (&mut self.nodes, &mut self.s);
        let mut each = |ode: &Dopri5, ta: f64, tb: f64| {
            nodes.step(wanted, smoother, (ode, ta, tb - ta, u_prev), s)
        };
        self.integrator
            .advance_each(t0, t1, &mut self.eta, &mut q, &mut each)
    }
}

/// η(t_0) and S(t_0) (ne × P, column-major): the given η with S = 0, or the run's equilibrium q(ξ(t_0), η, y_d^(r)(t_0)) = 0
/// (the same Newton from the same starts) with S = −(∂q/∂η)⁻¹ ∂q/∂p there (implicit function theorem).
fn start<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    along: &Along<'_>,
    eta0: Option<Vec<f64>>,
) -> Result<(Vec<f64>, Vec<f64>), SimulateError> {
    let model = wanted.model;
    let info = model.info();
    let (r, ne, np) = (info.relative_degree, info.n_eta, wanted.params.len());
    let t0 = along.grid.t0;
    let mut yd = [0.0_f64; MAX_DERIVATIVES];
    along.smoother.eval(t0, &mut yd[..=r]);
    let mut w = vec![0.0; info.n_w()];
    along.smoother.eval_signals(t0, &mut w);
    let (xi, yr) = (&yd[..r], yd[r]);
    if let Some(e) = eta0 {
        return Ok((e, vec![0.0; ne * np]));
    }
    let eta = equilibrium(model, xi, &w, yr, None, &default_starts(xi[0])).map_err(|f| {
        SimulateError::ZeroDynamicsEquilibrium {
            t: t0,
            reason: f.to_string(),
        }
    })?;
    let mut x = vec![0.0; info.n_states()];
    let model_err = |source| SimulateError::from(RunError::Model { t: t0, source });
    let u = model
        .invert_from(xi, &eta, &w, yr, &mut x, f64::NAN)
        .map_err(model_err)?;
    let at = (&info.eta_states[..], wanted.grid);
    let point = Point::new(model, (&x, &w, u), at, Default::default()).map_err(model_err)?;
    let (mut q_eta, mut q_p) = (vec![0.0; ne * ne], vec![0.0; ne * np]);
    point.eta_jacobians(wanted.params, &mut q_eta, &mut q_p);
    let s = DMatrix::from_vec(ne, ne, q_eta)
        .lu()
        .solve(&(-DMatrix::from_vec(ne, np, q_p)))
        .unwrap_or_else(|| DMatrix::from_element(ne, np, f64::NAN));
    Ok((eta, s.as_slice().to_vec()))
}

/// A and B (column-major) at the Gauss nodes of one step, the buffers of their evaluation and the method's.
struct Nodes {
    /// The guess for a numerically solved ψ⁻¹: the last grid sample's state.
    x: Vec<f64>,
    /// The reference at the nodes (a sub-grid of its own: the run's is read in the run's order).
    stages: StageReference,
    eta: Vec<f64>,
    buf: Buffers,
    a: [Vec<f64>; 2],
    b: [Vec<f64>; 2],
    gauss: Gauss,
    /// The model's closed-form A and B, where it has them ([`ClosedJacobian`]); `columns`: the wanted
    /// parameters as B's columns.
    closed: ClosedJacobian,
    columns: Vec<Option<usize>>,
}

impl Nodes {
    /// For the model `info`, the parameters `params` (B's columns) and the reference at the nodes `stages`.
    fn new(info: &invsim_model_api::ModelInfo, params: &[usize], stages: StageReference) -> Nodes {
        let (ne, np) = (info.n_eta, params.len());
        Nodes {
            x: vec![0.0; info.n_states()],
            stages,
            eta: vec![0.0; ne],
            buf: Buffers::default(),
            a: std::array::from_fn(|_| vec![0.0; ne * ne]),
            b: std::array::from_fn(|_| vec![0.0; ne * np]),
            gauss: Gauss::new(ne, np),
            closed: ClosedJacobian::default(),
            columns: params.iter().map(|&k| Some(k)).collect(),
        }
    }

    /// S over η's accepted step [t, t + h] (`ode` interpolating in it): A and B at t + c_i h, one Gauss step.
    fn step<M: InverseModel + ?Sized>(
        &mut self,
        wanted: &Wanted<'_, M>,
        smoother: &Smoother,
        (ode, t, h, u_prev): (&Dopri5, f64, f64, f64),
        s: &mut [f64],
    ) -> Result<(), SimulateError> {
        for (i, c) in NODES.iter().enumerate() {
            ode.dense(t + c * h, &mut self.eta);
            self.jacobians_at(wanted, smoother, (t + c * h, u_prev), i)?;
        }
        let (a, b) = (&self.a, &self.b);
        let stages = self.gauss.step(h, [&a[0], &a[1]], [&b[0], &b[1]], s);
        stages.map_err(|Singular| {
            SimulateError::from(StepFailure {
                t,
                reason: "the sensitivities' Gauss–Legendre stage system is singular or not finite"
                    .to_string(),
            })
        })
    }

    /// A = ∂q/∂η and B = ∂q/∂p into node i's matrices at time s and the interpolated η, x = ψ⁻¹(ξ, η) and u
    /// solved as the run solves them.
    fn jacobians_at<M: InverseModel + ?Sized>(
        &mut self,
        wanted: &Wanted<'_, M>,
        smoother: &Smoother,
        (s, u_prev): (f64, f64),
        i: usize,
    ) -> Result<(), SimulateError> {
        let model = wanted.model;
        let info = model.info();
        let r = info.relative_degree;
        let (yd, w) = self.stages.at(smoother, (s, r));
        // The closed form where the model has it (then neither x nor u is needed).
        let at = Rows::ZeroDynamics(&yd[..r], &self.eta, w, yd[r]);
        let ab = (&mut self.a[i][..], &mut self.b[i][..], None);
        if self.closed.eval(model, (at, &self.columns), ab) {
            return Ok(());
        }
        let model_err = |source| SimulateError::from(RunError::Model { t: s, source });
        let u = model
            .invert_from(&yd[..r], &self.eta, w, yd[r], &mut self.x, u_prev)
            .map_err(model_err)?;
        let buf = std::mem::take(&mut self.buf);
        let at = (&info.eta_states[..], wanted.grid);
        let point = Point::new(model, (&self.x, w, u), at, buf).map_err(model_err)?;
        point.eta_jacobians(wanted.params, &mut self.a[i], &mut self.b[i]);
        self.buf = point.into_buffer();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cycle::Cycle;

    /// The pass integrates η exactly as the run does (the same integrator, right-hand side and steps): on
    /// driveline's NEDC run (stiff zero dynamics, η at DOPRI5's stability limit) its η equals the run's
    /// `eta` columns bit for bit at every sample.
    #[test]
    fn eta_is_the_runs_bit_for_bit() {
        let model = invsim_models::builtin("driveline").expect("built in");
        let info = model.info();
        assert!(info.signals.is_empty() && info.n_eta == 3);
        let cycle = Cycle::builtin("nedc").expect("built in");
        let opts = SimulationOptions::builder()
            .keep_series(true)
            .build()
            .expect("valid");
        let run = crate::simulate(model.as_ref(), &cycle, &opts).expect("runs");
        let columns: Vec<&[f64]> = (1..=info.n_eta)
            .map(|j| {
                let name = format!("eta{j}");
                let c = run.columns.iter().position(|c| *c == name).expect("eta");
                run.data[c].as_slice()
            })
            .collect();
        let smoother = Smoother::new(&cycle, opts.lookahead)
            .expect("smooths")
            .with_reference(model.reference());
        let grid = Grid::new(cycle.time[0], cycle.duration(), opts.dt).expect("a grid");
        let params: Vec<usize> = ["k_s", "c_s"]
            .iter()
            .map(|p| info.parameters.iter().position(|q| q == p).expect(p))
            .collect();
        let wanted = Wanted {
            model: model.as_ref(),
            params: &params,
            grid: &GridColumns::default(),
            accumulate: &[0],
        };
        let along = Along {
            smoother: &smoother,
            grid: &grid,
            fine: None,
        };
        let mut samples = 0;
        sweep(&wanted, &along, None, &opts, &mut |k, eta| {
            for (j, c) in columns.iter().enumerate() {
                assert_eq!(
                    eta[j].to_bits(),
                    c[k].to_bits(),
                    "eta{} at sample {k}",
                    j + 1
                );
            }
            samples += 1;
        })
        .expect("the pass runs");
        assert_eq!(
            (samples, columns[0].len()),
            (grid.samples(), grid.samples())
        );
    }
}
