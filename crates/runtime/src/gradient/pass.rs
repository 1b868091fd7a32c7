//! The sensitivities of a causal run, carried along the run's own integration of η: after each of its
//! accepted steps S = ∂η/∂p is advanced over the same step by an A-stable method, and at each grid sample the
//! derivatives of the accumulated outputs' integrals are summed by the run's own quadrature (one pass: η is
//! integrated once, by the run).
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
//! integrated by the run's adaptive Dormand–Prince 5(4) method (`inverse/causal.rs`); after each accepted
//! step [t, t + h] S is advanced over the same step by the 2-stage Gauss–Legendre method ([`super::gauss`],
//! order 4, A-stable; Hairer & Wanner, *Solving ODEs II*, §IV.5), with A and B at its two nodes t + c_i h
//! from η's continuous extension there ([`Sensitivities::step`]). S's equations are linear with η's own
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
//! ([`super::point`], [`Sensitivities::sample`]).

use invsim_model_api::InverseModel;
use nalgebra::DMatrix;

use super::closed_jacobian::{ClosedJacobian, Rows};
use super::derivatives::Derivatives;
use super::gauss::{Gauss, Singular, NODES};
use super::grid_columns::GridColumns;
use super::point::{Buffers, Point};
use super::sample::{Block, Samples};
use crate::error::RunError;
use crate::grid::Grid;
use crate::inverse::stage_reference::StageReference;
use crate::inverse::{SimulateError, SimulationOptions};
use crate::ode::{Dopri5, StepFailure};
use crate::smoother::Smoother;

/// Samples per block of the reference's columns (the run's block size: the same numbers, bounded memory).
const BLOCK: usize = 4096;

/// What a pass runs along: the smoother (y_d … y_d^(r) and w evaluated on the grid block by block, as the run
/// evaluates them) and the grid.
pub(crate) struct Along<'a> {
    pub smoother: &'a Smoother,
    pub grid: &'a Grid,
}

/// The model, the parameters (indices into [`invsim_model_api::ModelInfo::parameters`], and P + g for the
/// grid value g of `grid`) and the accumulated outputs (indices into its `outputs`) differentiated.
pub(crate) struct Wanted<'a, M: ?Sized> {
    pub model: &'a M,
    pub params: &'a [usize],
    pub grid: &'a GridColumns,
    pub accumulate: &'a [usize],
}

/// The sensitivities a causal run carries: what is differentiated, S (ne × P column-major, column c =
/// ∂η/∂p_c), the Gauss nodes' matrices, and what every pass carries from sample to sample ([`Samples`]: the
/// last sample's state and input, the integrals' derivatives).
pub(crate) struct Sensitivities {
    params: Vec<usize>,
    grid: GridColumns,
    accumulate: Vec<usize>,
    s: Vec<f64>,
    nodes: Nodes,
    samples: Samples,
    /// dt/2, the trapezoids' weight; whether a sample has been summed yet.
    half: f64,
    started: bool,
}

impl Sensitivities {
    /// For the run of `model` on `grid` by `wrt`, starting from η(t_0) = `eta` (`given`: set by the user,
    /// else the zero dynamics' equilibrium there); `stages`: the reference at the Gauss nodes (reading the
    /// run's sub-grid table).
    pub(crate) fn start<M: InverseModel + ?Sized>(
        model: &M,
        (wrt, along): (&Derivatives, &Along<'_>),
        (eta, given): (&[f64], bool),
        stages: StageReference,
    ) -> Result<Sensitivities, SimulateError> {
        let info = model.info();
        let params = wrt.columns(info.parameters.len());
        let grid = GridColumns::new(model.maps(), &wrt.grid);
        let accumulate: Vec<usize> = (0..info.outputs.len())
            .filter(|&i| info.outputs[i].accumulate)
            .collect();
        let wanted = Wanted {
            model,
            params: &params,
            grid: &grid,
            accumulate: &accumulate,
        };
        let s = if given {
            vec![0.0; info.n_eta * params.len()]
        } else {
            equilibrium_sensitivity(&wanted, along, eta)?
        };
        Ok(Sensitivities {
            nodes: Nodes::new(info, &params, stages),
            samples: Samples::new(info.n_states(), accumulate.len(), params.len()),
            half: 0.5 * along.grid.dt,
            started: false,
            s,
            params,
            grid,
            accumulate,
        })
    }

    /// S over η's accepted step [t, t_new] (`ode` interpolating in it).
    pub(crate) fn step<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        smoother: &Smoother,
        (ode, t, t_new): (&Dopri5, f64, f64),
    ) -> Result<(), SimulateError> {
        let wanted = Wanted {
            model,
            params: &self.params,
            grid: &self.grid,
            accumulate: &self.accumulate,
        };
        let u_prev = self.samples.u_prev;
        (self.nodes).step(&wanted, smoother, (ode, t, t_new - t, u_prev), &mut self.s)
    }

    /// The grid sample at t, with the signals `w` there, as the run solved it (state `x`, input `u`): the
    /// outputs' derivatives and the trapezoidal rule's term dt·(do_(k−1) + do_k)/2.
    pub(crate) fn sample<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        (t, w): (f64, &[f64]),
        (x, u): (&[f64], f64),
    ) -> Result<(), SimulateError> {
        let ne = model.info().n_eta;
        let point = (self.samples).point_of((model, &self.grid), (t, w), (x, u))?;
        let half = self.started.then_some(self.half);
        let (params, accumulate) = (&self.params[..], &self.accumulate[..]);
        let s = &self.s[..ne * params.len()];
        self.samples
            .add_outputs(&point, (params, accumulate), s, half);
        self.samples.recycle(point);
        self.started = true;
        // The guess of a numerically solved ψ⁻¹ at the next interval's nodes: this sample's state.
        self.nodes.x.copy_from_slice(x);
        Ok(())
    }

    /// ∂(∫ o_a dt)/∂p_c for every accumulated output a and wanted parameter c (`[a][c]`), over the samples so
    /// far.
    pub(crate) fn integrals(&self) -> Vec<Vec<f64>> {
        self.samples.sums.integrals()
    }
}

/// ∂(∫ o_a dt)/∂p_c for every accumulated output a and wanted parameter c (`[a][c]`) of a run without
/// internal states, sample by sample (where grid values are wanted: their columns come from the map calls at
/// each point), the reference read block by block as the run reads it.
pub(crate) fn pointwise_integrals<M: InverseModel + ?Sized>(
    model: &M,
    (wrt, along): (&Derivatives, &Along<'_>),
    opts: &SimulationOptions,
) -> Result<Vec<Vec<f64>>, SimulateError> {
    let info = model.info();
    let (r, nw) = (info.relative_degree, info.n_w());
    debug_assert_eq!(info.n_eta, 0);
    let stages = StageReference::new(along.smoother, along.grid, (opts, info), false);
    let mut sens = Sensitivities::start(model, (wrt, along), (&[], true), stages)?;
    let samples = along.grid.samples();
    let mut block = Block::new(BLOCK.min(samples), r, nw);
    let (mut yd, mut w) = ([0.0_f64; crate::grid::MAX_DERIVATIVES], vec![0.0; nw]);
    let (mut x, mut u) = (vec![0.0; info.n_states()], f64::NAN);
    let mut k0 = 0;
    while k0 < samples {
        let len = (k0 + BLOCK).min(samples) - k0;
        block.fill(along.smoother, along.grid, (k0, len));
        for i in 0..len {
            for (v, c) in yd[..=r].iter_mut().zip(&block.yd) {
                *v = c[i];
            }
            for (v, c) in w.iter_mut().zip(&block.w) {
                *v = c[i];
            }
            let t = block.time[i];
            // The inverse as the run solves it: the last sample's state and input as the guesses.
            u = model
                .invert_from(&yd[..r], &[], &w, yd[r], &mut x, u)
                .map_err(|source| SimulateError::from(RunError::Model { t, source }))?;
            sens.sample(model, (t, &w), (&x, u))?;
        }
        k0 += len;
    }
    Ok(sens.integrals())
}

/// S(t_0) = −(∂q/∂η)⁻¹ ∂q/∂p (ne × P, column-major) at the equilibrium `eta` of q(ξ(t_0), η, y_d^(r)(t_0)) = 0
/// (implicit function theorem).
fn equilibrium_sensitivity<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    along: &Along<'_>,
    eta: &[f64],
) -> Result<Vec<f64>, SimulateError> {
    let model = wanted.model;
    let info = model.info();
    let (r, ne, np) = (info.relative_degree, info.n_eta, wanted.params.len());
    let t0 = along.grid.t0;
    let mut yd = [0.0_f64; crate::grid::MAX_DERIVATIVES];
    along.smoother.eval(t0, &mut yd[..=r]);
    let mut w = vec![0.0; info.n_w()];
    along.smoother.eval_signals(t0, &mut w);
    let (xi, yr) = (&yd[..r], yd[r]);
    let mut x = vec![0.0; info.n_states()];
    let model_err = |source| SimulateError::from(RunError::Model { t: t0, source });
    let u = model
        .invert_from(xi, eta, &w, yr, &mut x, f64::NAN)
        .map_err(model_err)?;
    let at = (&info.eta_states[..], wanted.grid);
    let point = Point::new(model, (&x, &w, u), at, Default::default()).map_err(model_err)?;
    let (mut q_eta, mut q_p) = (vec![0.0; ne * ne], vec![0.0; ne * np]);
    point.eta_jacobians(wanted.params, &mut q_eta, &mut q_p);
    let s = DMatrix::from_vec(ne, ne, q_eta)
        .lu()
        .solve(&(-DMatrix::from_vec(ne, np, q_p)))
        .unwrap_or_else(|| DMatrix::from_element(ne, np, f64::NAN));
    Ok(s.as_slice().to_vec())
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
        let stages = self.gauss.step(h, &[&a[0], &a[1]], &[&b[0], &b[1]], s);
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
    use crate::cycle::Cycle;
    use crate::inverse::SimulationOptions;

    /// Carrying the sensitivities along does not move the run: on driveline's NEDC run (stiff zero dynamics,
    /// η at DOPRI5's stability limit; `Sensitivities`) and si_engine's (r = n, `DirectSensitivities`) every
    /// column and every integral is the same bits with and without the gradient, and the gradient block is
    /// there.
    #[test]
    fn a_differentiated_run_is_the_same_run_bit_for_bit() {
        let cycle = Cycle::builtin("nedc").expect("built in");
        for (name, n_eta) in [("driveline", 3), ("si_engine", 0)] {
            let model = invsim_models::builtin(name).expect("built in");
            assert_eq!(model.info().n_eta, n_eta);
            let run = |gradient: Option<Vec<String>>| {
                let opts = SimulationOptions::builder()
                    .keep_series(true)
                    .gradient(gradient)
                    .build()
                    .expect("valid");
                crate::simulate(model.as_ref(), &cycle, &opts).expect("runs")
            };
            let plain = run(None);
            let differentiated = run(Some(vec!["m".into(), "eta_trm".into()]));
            assert_eq!(plain.columns, differentiated.columns);
            for (c, (a, b)) in plain.data.iter().zip(&differentiated.data).enumerate() {
                let same = a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same && a.len() == b.len(), "{name}: {}", plain.columns[c]);
            }
            let (a, b) = (&plain.summary.totals, &differentiated.summary.totals);
            assert_eq!(a.integrals, b.integrals, "{name}");
            assert!(plain.summary.gradient.is_none());
            let gradient = differentiated.summary.gradient.expect("a gradient block");
            assert!(!gradient.figures.is_empty(), "{name}");
        }
    }
}
