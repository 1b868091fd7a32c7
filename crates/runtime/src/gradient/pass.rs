//! The sensitivity pass of a causal (or r = n) run: the run's grid sample by sample, η integrated with its
//! sensitivities S = ∂η/∂p by the run's own integrator, and the derivatives of the accumulated outputs'
//! integrals by the run's own quadrature.
//!
//! Sensitivity equations of the zero dynamics η̇ = q(ξ(t), η, y_d^(r)(t); p) (Hairer, Nørsett & Wanner,
//! *Solving Ordinary Differential Equations I*, §I.14):
//!
//! ```text
//! dS/dt = ∂q/∂η · S + ∂q/∂p,   S(t_0) = 0 for a given η(t_0), −(∂q/∂η)⁻¹ ∂q/∂p at an equilibrium start
//! ```
//!
//! integrated alongside η by the run's adaptive Dormand–Prince 5(4) method with its tolerances, from the same
//! start between the same grid samples, with S in the error norm too. (With η alone in the norm the steps
//! would be the run's and S the exact derivative of the discrete η for those frozen steps; but on stiff zero
//! dynamics — driveline's shaft — the controller holds the steps at the explicit method's stability limit,
//! which keeps η bounded only through step rejections, and the frozen-step derivative grows without bound.
//! So η here equals the run's within the integrator's tolerance, not bit for bit, and S is the derivative of
//! the exact η within the same tolerance.) The integrals ∫ o dt ≈ Σ_k dt·(o_k + o_{k+1})/2 are differentiated
//! term by term: ∂/∂p Σ = Σ_k dt·(do_k/dp + do_{k+1}/dp)/2, with do/dp = ∂o/∂x·dx/dp + ∂o/∂u·du/dp + ∂o/∂p
//! ([`super::point`]). The reference is evaluated block by block on the grid, as the run evaluates it, so that
//! the pass stores no column of the whole run.

use invsim_model_api::zero_dynamics::{default_starts, equilibrium};
use invsim_model_api::InverseModel;
use nalgebra::DMatrix;

use super::point::Point;
use crate::error::RunError;
use crate::grid::{Grid, MAX_DERIVATIVES};
use crate::inverse::{SimulateError, SimulationOptions};
use crate::ode::Dopri5;
use crate::smoother::Smoother;

/// Samples per block of the reference's columns (the run's block size: the same numbers, bounded memory).
const BLOCK: usize = 4096;

/// What the pass runs along: the smoother and the grid (y_d … y_d^(r) and w evaluated on it block by block,
/// as the run evaluates them).
pub(crate) struct Along<'a> {
    pub smoother: &'a Smoother,
    pub grid: &'a Grid,
}

/// The model, the parameters (indices into [`invsim_model_api::ModelInfo::parameters`]) and the accumulated
/// outputs (indices into its `outputs`) differentiated.
pub(crate) struct Wanted<'a, M: ?Sized> {
    pub model: &'a M,
    pub params: &'a [usize],
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
    let info = wanted.model.info();
    let (r, nw) = (info.relative_degree, info.n_w());
    let grid = along.grid;
    let samples = grid.samples();
    let y = if info.n_eta > 0 {
        start(wanted, along, eta0)?
    } else {
        Vec::new()
    };
    let mut sweep = Sweep::new(wanted, y, opts);
    let width = BLOCK.min(samples);
    let mut time = vec![0.0; width];
    let (mut yd, mut w) = (vec![vec![0.0; width]; r + 1], vec![vec![0.0; width]; nw]);
    let mut k0 = 0;
    while k0 < samples {
        let len = (k0 + BLOCK).min(samples) - k0;
        for (i, t) in time[..len].iter_mut().enumerate() {
            *t = grid.time(k0 + i);
        }
        let mut cols: Vec<&mut [f64]> = yd.iter_mut().map(|c| &mut c[..len]).collect();
        along
            .smoother
            .eval_grid(&time[..len], Some(grid.dt), &mut cols);
        let mut cols: Vec<&mut [f64]> = w.iter_mut().map(|c| &mut c[..len]).collect();
        along
            .smoother
            .eval_signals_grid(&time[..len], Some(grid.dt), &mut cols);
        for i in 0..len {
            sweep.sample(wanted, along, (k0 + i, &yd, &w, i))?;
        }
        k0 += len;
    }
    Ok(sweep.acc)
}

/// The pass's state from sample to sample: [η, S_1, …, S_P] and their integrator, the last sample's state and
/// input (the guesses the run uses), the integrals' derivatives and the last sample's output derivatives.
struct Sweep {
    y: Vec<f64>,
    integrator: Dopri5,
    x: Vec<f64>,
    u_prev: f64,
    stage: Stage,
    buf: Vec<f64>,
    acc: Vec<Vec<f64>>,
    prev: Vec<Vec<f64>>,
}

impl Sweep {
    fn new<M: InverseModel + ?Sized>(
        wanted: &Wanted<'_, M>,
        y: Vec<f64>,
        opts: &SimulationOptions,
    ) -> Sweep {
        let info = wanted.model.info();
        let (na, np) = (wanted.accumulate.len(), wanted.params.len());
        Sweep {
            integrator: Dopri5::new(y.len(), opts.rtol, opts.atol, opts.dt),
            y,
            x: vec![0.0; info.n_states()],
            u_prev: f64::NAN,
            stage: Stage::new(info.n_states(), info.n_w()),
            buf: Vec::new(),
            acc: vec![vec![0.0; np]; na],
            prev: vec![vec![0.0; np]; na],
        }
    }

    /// Grid sample k (column index i of the block's `yd` and `w`): η and S integrated from sample k − 1, the
    /// inverse, the outputs' derivatives, and the trapezoidal rule's term dt·(do_(k−1) + do_k)/2.
    fn sample<M: InverseModel + ?Sized>(
        &mut self,
        wanted: &Wanted<'_, M>,
        along: &Along<'_>,
        (k, yd, w, i): (usize, &[Vec<f64>], &[Vec<f64>], usize),
    ) -> Result<(), SimulateError> {
        let model = wanted.model;
        let info = model.info();
        let (r, ne) = (info.relative_degree, info.n_eta);
        let grid = along.grid;
        let t = grid.time(k);
        if k > 0 && ne > 0 {
            self.stage.x.copy_from_slice(&self.x);
            let (stage, u_prev) = (&mut self.stage, self.u_prev);
            let mut q = |s: f64, yv: &[f64], dy: &mut [f64]| {
                stage.rhs(wanted, along.smoother, (s, yv, u_prev), dy)
            };
            self.integrator
                .advance(grid.time(k - 1), t, &mut self.y, &mut q)?;
        }
        let mut ydk = [0.0_f64; MAX_DERIVATIVES];
        for (v, c) in ydk[..=r].iter_mut().zip(yd) {
            *v = c[i];
        }
        let wk: Vec<f64> = w.iter().map(|c| c[i]).collect();
        let model_err = |source| SimulateError::from(RunError::Model { t, source });
        let u = model
            .invert_from(
                &ydk[..r],
                &self.y[..ne],
                &wk,
                ydk[r],
                &mut self.x,
                self.u_prev,
            )
            .map_err(model_err)?;
        self.u_prev = u;
        let buf = std::mem::take(&mut self.buf);
        let point =
            Point::new(model, (&self.x, &wk, u), &info.eta_states, buf).map_err(model_err)?;
        let h = 0.5 * grid.dt;
        let mut dir = point.direction(&self.y[ne..ne + ne], None);
        for (c, &p) in wanted.params.iter().enumerate() {
            point.direction_into(&self.y[ne + c * ne..ne + (c + 1) * ne], Some(p), &mut dir);
            for (a, &o) in wanted.accumulate.iter().enumerate() {
                let v = point.row_change(point.layout().output(o), &dir, Some(p));
                if k > 0 {
                    self.acc[a][c] += h * (self.prev[a][c] + v);
                }
                self.prev[a][c] = v;
            }
        }
        self.buf = point.into_buffer();
        Ok(())
    }
}

/// η(t_0) and S(t_0), laid out as the integrated vector [η, S_1, …, S_P] (S_c = ∂η/∂p_c): the given η with
/// S = 0, or the run's equilibrium q(ξ(t_0), η, y_d^(r)(t_0)) = 0 (the same Newton from the same starts) with
/// S = −(∂q/∂η)⁻¹ ∂q/∂p there (implicit function theorem).
fn start<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    along: &Along<'_>,
    eta0: Option<Vec<f64>>,
) -> Result<Vec<f64>, SimulateError> {
    let model = wanted.model;
    let info = model.info();
    let (r, ne, np) = (info.relative_degree, info.n_eta, wanted.params.len());
    let t0 = along.grid.t0;
    let mut yd = [0.0_f64; MAX_DERIVATIVES];
    along.smoother.eval(t0, &mut yd[..=r]);
    let mut w = vec![0.0; info.n_w()];
    along.smoother.eval_signals(t0, &mut w);
    let (xi, yr) = (&yd[..r], yd[r]);
    let mut y = vec![0.0; ne * (1 + np)];
    let Some(eta) = (match eta0 {
        Some(e) => {
            y[..ne].copy_from_slice(&e);
            None
        }
        None => Some(
            equilibrium(model, xi, &w, yr, None, &default_starts(xi[0])).map_err(|f| {
                SimulateError::ZeroDynamicsEquilibrium {
                    t: t0,
                    reason: f.to_string(),
                }
            })?,
        ),
    }) else {
        return Ok(y);
    };
    y[..ne].copy_from_slice(&eta);
    let mut x = vec![0.0; info.n_states()];
    let model_err = |source| SimulateError::from(RunError::Model { t: t0, source });
    let u = model
        .invert_from(xi, &eta, &w, yr, &mut x, f64::NAN)
        .map_err(model_err)?;
    let point = Point::new(model, (&x, &w, u), &info.eta_states, Vec::new()).map_err(model_err)?;
    let l = *point.layout();
    let q_eta = DMatrix::from_fn(ne, ne, |i, j| {
        let mut e = vec![0.0; ne];
        e[j] = 1.0;
        point.row_change(l.eta(i), &point.direction(&e, None), None)
    });
    let zero = vec![0.0; ne];
    let q_p = DMatrix::from_fn(ne, np, |i, c| {
        let p = wanted.params[c];
        point.row_change(l.eta(i), &point.direction(&zero, Some(p)), Some(p))
    });
    let s = q_eta
        .lu()
        .solve(&(-q_p))
        .unwrap_or_else(|| DMatrix::from_element(ne, np, f64::NAN));
    for c in 0..np {
        for j in 0..ne {
            y[ne + c * ne + j] = s[(j, c)];
        }
    }
    Ok(y)
}

/// The buffers of one stage evaluation of the sensitivity equations.
struct Stage {
    /// The guess for a numerically solved ψ⁻¹: the last grid sample's state.
    x: Vec<f64>,
    w: Vec<f64>,
    buf: Vec<f64>,
}

impl Stage {
    fn new(n: usize, nw: usize) -> Stage {
        Stage {
            x: vec![0.0; n],
            w: vec![0.0; nw],
            buf: Vec::new(),
        }
    }

    /// [η̇, Ṡ_1, …, Ṡ_P] at time s: η̇ exactly as the run evaluates it (`zero_dynamics_from` with the last
    /// sample's input as Newton's start), Ṡ_c = dq/dp_c along S_c (the chain rule of [`super::point`]).
    fn rhs<M: InverseModel + ?Sized>(
        &mut self,
        wanted: &Wanted<'_, M>,
        smoother: &Smoother,
        (s, y, u_prev): (f64, &[f64], f64),
        dy: &mut [f64],
    ) -> Result<(), SimulateError> {
        let model = wanted.model;
        let info = model.info();
        let (r, ne) = (info.relative_degree, info.n_eta);
        let mut yd = [0.0_f64; MAX_DERIVATIVES];
        smoother.eval(s, &mut yd[..=r]);
        smoother.eval_signals(s, &mut self.w);
        let (xi, yr, eta) = (&yd[..r], yd[r], &y[..ne]);
        model.zero_dynamics_from(xi, eta, &self.w, yr, u_prev, &mut dy[..ne]);
        let model_err = |source| SimulateError::from(RunError::Model { t: s, source });
        let u = model
            .invert_from(xi, eta, &self.w, yr, &mut self.x, u_prev)
            .map_err(model_err)?;
        let buf = std::mem::take(&mut self.buf);
        let point =
            Point::new(model, (&self.x, &self.w, u), &info.eta_states, buf).map_err(model_err)?;
        let l = *point.layout();
        let mut dir = point.direction(&y[..ne], None);
        for (c, &p) in wanted.params.iter().enumerate() {
            let range = ne + c * ne..ne + (c + 1) * ne;
            point.direction_into(&y[range.clone()], Some(p), &mut dir);
            for (j, d) in dy[range].iter_mut().enumerate() {
                *d = point.row_change(l.eta(j), &dir, Some(p));
            }
        }
        self.buf = point.into_buffer();
        Ok(())
    }
}
