//! The integrator of the forward run behind one trait, so that the driver is generic over the method
//! (dispatched once per run, not per call).

use crate::ode::{Dopri5, OdeStats, Rosenbrock23};

use super::budget::StepState;
use super::error::ForwardError;

/// An adaptive one-step method with dense output, as the forward run uses it.
pub(super) trait Integrator {
    /// One accepted step from t towards `t_end` (never beyond it); returns the new time.
    fn step_to<F>(
        &mut self,
        t: f64,
        t_end: f64,
        z: &mut [f64],
        f: &mut F,
    ) -> Result<f64, ForwardError>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), ForwardError>;
    /// The dense output of the last step at t.
    fn dense(&self, t: f64, out: &mut [f64]);
    /// Forget the last step (at a breakpoint of the right-hand side).
    fn restart(&mut self);
    /// Step statistics so far.
    fn stats(&self) -> OdeStats;
    /// The step size proposed next and DOPRI5's stiffness estimate h·ρ of the last step (NaN otherwise).
    fn step_state(&self) -> StepState {
        StepState {
            stats: self.stats(),
            h: self.step_size(),
            h_rho: f64::NAN,
        }
    }
    /// The step size proposed next.
    fn step_size(&self) -> f64;
}

impl Integrator for Dopri5 {
    fn step_to<F>(
        &mut self,
        t: f64,
        t_end: f64,
        z: &mut [f64],
        f: &mut F,
    ) -> Result<f64, ForwardError>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), ForwardError>,
    {
        Dopri5::step_to(self, t, t_end, z, f)
    }
    fn dense(&self, t: f64, out: &mut [f64]) {
        Dopri5::dense(self, t, out)
    }
    fn restart(&mut self) {
        Dopri5::restart(self)
    }
    fn stats(&self) -> OdeStats {
        self.stats
    }
    fn step_state(&self) -> StepState {
        StepState {
            stats: self.stats,
            h: Dopri5::step_size(self),
            h_rho: self.last_h_rho,
        }
    }
    fn step_size(&self) -> f64 {
        Dopri5::step_size(self)
    }
}

impl Integrator for Rosenbrock23 {
    fn step_to<F>(
        &mut self,
        t: f64,
        t_end: f64,
        z: &mut [f64],
        f: &mut F,
    ) -> Result<f64, ForwardError>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), ForwardError>,
    {
        Rosenbrock23::step_to(self, t, t_end, z, f)
    }
    fn dense(&self, t: f64, out: &mut [f64]) {
        Rosenbrock23::dense(self, t, out)
    }
    fn restart(&mut self) {
        Rosenbrock23::restart(self)
    }
    fn stats(&self) -> OdeStats {
        self.stats
    }
    fn step_size(&self) -> f64 {
        Rosenbrock23::step_size(self)
    }
}
