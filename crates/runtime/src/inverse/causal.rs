//! Causal inversion: the zero dynamics η̇ = q(ξ(t), η, y_d^(r)(t)) integrated forward from their equilibrium at
//! t_0 (adaptive Dormand–Prince 5(4), the reference at its stage times from the sub-grid interpolant of
//! `smoother/fine.rs` unless the options ask for the smoother pointwise), with the eigenvalues of ∂q/∂η
//! checked along the run (Isidori §4.3: only minimum-phase zero dynamics can be inverted causally).

use invsim_model_api::zero_dynamics::{
    critical_tol, default_starts, eigenvalues, equilibrium, JacobianWork,
};
use invsim_model_api::InverseModel;
use nalgebra::DMatrix;

use super::error::SimulateError;
use super::options::SimulationOptions;
use super::stage_reference::StageReference;
use crate::error::RunError;
use crate::gradient::{Along, Derivatives, Sensitivities};
use crate::grid::{Grid, MAX_DERIVATIVES};
use crate::ode::Dopri5;
use crate::report::fmt_sig;
use crate::smoother::Smoother;

/// |η| above this means the internal dynamics have blown up.
pub const ETA_BLOWUP: f64 = 1e12;

/// The state of a causal run: η, its integrator and the buffers of the stability checks.
pub(super) struct Causal {
    eta: Vec<f64>,
    integrator: Dopri5,
    ws: JacobianWork,
    /// Check the eigenvalues every this many samples.
    check_every: usize,
    yd: [f64; MAX_DERIVATIVES],
    /// The smoothed signal values at the current sample (`InverseModel`'s `w`).
    w: Vec<f64>,
    /// The last sample's input: Newton's start for a non-affine y^(r) (NaN before the first sample).
    u: f64,
    /// The reference at the integrator's stage times.
    stages: StageReference,
    /// The sensitivities carried along, where the run is differentiated.
    track: Option<Box<Sensitivities>>,
}

impl Causal {
    /// Start at t_0 from `eta0`, else from the equilibrium q(ξ(t_0), η, y_d^(r)(t_0)) = 0 (Newton from several
    /// starting points: internal states in physical units are rarely near 0), checked for stability; with
    /// `wrt`, the run carries the sensitivities by those derivatives along.
    pub(super) fn start<M: InverseModel + ?Sized>(
        model: &M,
        (smoother, grid): (&Smoother, &Grid),
        eta0: Option<Vec<f64>>,
        wrt: Option<&Derivatives>,
        opts: &SimulationOptions,
    ) -> Result<Causal, SimulateError> {
        let t0 = grid.t0;
        let info = model.info();
        let (r, ne) = (info.relative_degree, info.n_eta);
        let mut yd = [0.0_f64; MAX_DERIVATIVES];
        smoother.eval(t0, &mut yd[..=r]);
        let mut w = vec![0.0; info.n_w()];
        smoother.eval_signals(t0, &mut w);
        let (xi, yr) = (&yd[..r], yd[r]);
        let given = eta0.is_some();
        let eta = match eta0 {
            Some(e) => e,
            None => equilibrium(model, xi, &w, yr, None, &default_starts(xi[0])).map_err(|f| {
                SimulateError::ZeroDynamicsEquilibrium {
                    t: t0,
                    reason: f.to_string(),
                }
            })?,
        };
        let mut ws = JacobianWork::new(ne);
        check_stability(model, t0, (xi, &w), &eta, yr, &mut ws)?;
        let stages = StageReference::new(smoother, grid, (opts, info), wrt.is_some());
        let track = match wrt {
            Some(wrt) => {
                // The Gauss nodes read the run's sub-grid table.
                let nodes = StageReference::sharing(&stages, info);
                let along = Along { smoother, grid };
                let start = Sensitivities::start(model, (wrt, &along), (&eta, given), nodes)?;
                Some(Box::new(start))
            }
            None => None,
        };
        Ok(Causal {
            w,
            eta,
            integrator: Dopri5::new(ne, opts.rtol, opts.atol, opts.dt),
            ws,
            check_every: ((opts.stability_check_interval / opts.dt).round() as usize).max(1),
            yd,
            u: f64::NAN,
            stages,
            track,
        })
    }

    /// The integrals' derivatives summed so far, where the run is differentiated.
    pub(super) fn gradient_integrals(&self) -> Option<Vec<Vec<f64>>> {
        self.track.as_ref().map(|t| t.integrals())
    }

    /// η at grid sample k (time t, reference `yd` = y_d … y_d^(r) there): integrated from sample k − 1, checked
    /// for blow-up and (every `check_every` samples) for stability.
    pub(super) fn advance<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        smoother: &Smoother,
        grid: &Grid,
        (k, t): (usize, f64),
        yd: &[f64],
    ) -> Result<&[f64], SimulateError> {
        let r = yd.len() - 1;
        if k > 0 {
            self.integrate(model, smoother, grid.time(k - 1), t, r)?;
        }
        smoother.eval_signals(t, &mut self.w);
        let (xi, yr) = (&yd[..r], yd[r]);
        let w = &self.w;
        if let Some(j) = self
            .eta
            .iter()
            .position(|v| !v.is_finite() || v.abs() > ETA_BLOWUP)
        {
            let eigenvalues = eigenvalues_at(model, (xi, w), &self.eta, yr, &mut self.ws);
            return Err(SimulateError::UnstableZeroDynamics {
                t,
                eigenvalues,
                detail: format!(
                    "eta{} = {} has blown up",
                    j + 1,
                    crate::numfmt::num(self.eta[j])
                ),
            });
        }
        if k % self.check_every == 0 && k > 0 {
            check_stability(model, t, (xi, w), &self.eta, yr, &mut self.ws)?;
        }
        Ok(&self.eta)
    }

    /// Integrate η from `t_prev` to `t`; a failing integrator usually means that η is running away: say so if
    /// it is.
    fn integrate<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        smoother: &Smoother,
        t_prev: f64,
        t: f64,
        r: usize,
    ) -> Result<(), SimulateError> {
        // An input solved by Newton's method starts from the last sample's (the root the inverse follows).
        let u_prev = self.u;
        let stages = &mut self.stages;
        let mut q = |s: f64, e: &[f64], de: &mut [f64]| {
            stages.zero_dynamics(model, smoother, (s, r), (e, u_prev), de);
            Ok(())
        };
        // Where the run is differentiated, S follows each accepted step (the same steps, bit for bit). One
        // call of the integrator either way, so that its step is compiled once, into the run's loop.
        let mut track = self.track.as_deref_mut();
        let mut each = |ode: &Dopri5, ta: f64, tb: f64| match track.as_mut() {
            Some(track) => track.step(model, smoother, (ode, ta, tb)),
            None => Ok(()),
        };
        let advanced = (self.integrator).advance_each(t_prev, t, &mut self.eta, &mut q, &mut each);
        let Err(err) = advanced else {
            return Ok(());
        };
        let (t_fail, eta_fail) = (self.integrator.t_fail, &self.integrator.y_fail);
        smoother.eval(t_fail, &mut self.yd[..=r]);
        smoother.eval_signals(t_fail, &mut self.w);
        let (xi, yr) = (&self.yd[..r], self.yd[r]);
        let w = &self.w;
        if let Some(i) = eta_fail
            .iter()
            .position(|v| !v.is_finite() || v.abs() > ETA_BLOWUP)
        {
            return Err(SimulateError::UnstableZeroDynamics {
                t: t_fail,
                eigenvalues: eigenvalues_at(model, (xi, w), eta_fail, yr, &mut self.ws),
                detail: format!(
                    "eta{} = {} has blown up",
                    i + 1,
                    crate::numfmt::num(eta_fail[i])
                ),
            });
        }
        check_stability(model, t_fail, (xi, w), eta_fail, yr, &mut self.ws)?;
        Err(err)
    }

    /// x = ψ⁻¹(ξ, η) (the previous x as the guess) and u = (y_d^(r) − α)/β (paper eq. 26) at time t (the
    /// signal values of the last [`Causal::advance`], at the same sample); a u solved by Newton's method
    /// starts from the previous sample's. Where the run is differentiated, the sample's term of the
    /// integrals' derivatives follows.
    pub(super) fn invert<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        t: f64,
        yd: &[f64],
        x: &mut [f64],
    ) -> Result<f64, SimulateError> {
        let r = yd.len() - 1;
        let u = model
            .invert_from(&yd[..r], &self.eta, &self.w, yd[r], x, self.u)
            .map_err(|source| RunError::Model { t, source })?;
        self.u = u;
        if let Some(track) = self.track.as_deref_mut() {
            track.sample(model, (t, &self.w), (x, u))?;
        }
        Ok(u)
    }
}

/// Eigenvalues [re, im] of ∂q/∂η at (ξ, η, y^(r)); empty if the Jacobian is not finite.
fn eigenvalues_at<M: InverseModel + ?Sized>(
    model: &M,
    (xi, w): (&[f64], &[f64]),
    eta: &[f64],
    yr: f64,
    ws: &mut JacobianWork,
) -> Vec<[f64; 2]> {
    let n = eta.len();
    eigenvalues(&DMatrix::from_column_slice(
        n,
        n,
        ws.jacobian(model, xi, w, eta, yr),
    ))
}

/// Stop with [`SimulateError::UnstableZeroDynamics`] if ∂q/∂η has an eigenvalue with positive real part
/// (beyond finite-difference noise, [`critical_tol`]): the zero dynamics are then locally unstable and
/// the system non-minimum phase (Isidori §4.3).
fn check_stability<M: InverseModel + ?Sized>(
    model: &M,
    t: f64,
    (xi, w): (&[f64], &[f64]),
    eta: &[f64],
    yr: f64,
    ws: &mut JacobianWork,
) -> Result<(), SimulateError> {
    let n = eta.len();
    let jac = ws.jacobian(model, xi, w, eta, yr);
    let tol = critical_tol(jac);
    // One internal coordinate: the Jacobian is the eigenvalue; no allocation needed on the stable path.
    if n == 1 && jac[0].is_finite() && jac[0] <= tol {
        return Ok(());
    }
    let eigs = eigenvalues(&DMatrix::from_column_slice(n, n, jac));
    if eigs.is_empty() {
        return Err(SimulateError::UnstableZeroDynamics {
            t,
            eigenvalues: eigs,
            detail: "the linearisation ∂q/∂η is not finite".to_string(),
        });
    }
    if let Some(e) = eigs.iter().find(|e| e[0] > tol) {
        return Err(SimulateError::UnstableZeroDynamics {
            t,
            detail: format!(
                "∂q/∂η has an eigenvalue with positive real part {}",
                fmt_sig(e[0], 6)
            ),
            eigenvalues: eigs,
        });
    }
    Ok(())
}
