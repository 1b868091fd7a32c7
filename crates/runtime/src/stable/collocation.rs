//! The collocation points of a solved stable inversion as its equations saw them — per interval the two nodes
//! and the midpoint, each with its reference values and η — for the sensitivities of the solution
//! (`crate::gradient`'s stable pass).
//!
//! Node j sits at t_a + j·h, the midpoint of interval j at t_a + (j + ½)·h with the Hermite–Simpson value
//! η_{j+½} = (η_j + η_{j+1})/2 + h/8 (q_j − q_{j+1}) ([`crate::stable`]'s method); the reference there is
//! evaluated exactly as the collocation equations evaluate it.

use invsim_model_api::InverseModel;

use super::bvp::Bvp;
use super::StableRun;
use crate::smoother::Smoother;

/// The collocation points of the solution of `run`.
pub(crate) struct Collocation<'a, M: ?Sized> {
    bvp: Bvp<'a, M>,
    run: &'a StableRun,
    /// y_d … y_d^(r) and the signal values at the times of the boundary equilibria, `Plan::t_eq`.
    ends: [(Vec<f64>, Vec<f64>); 2],
}

/// One collocation point: its time, y_d … y_d^(r) and signal values there, and η.
pub(crate) struct CollocationPoint<'c> {
    pub t: f64,
    pub yd: &'c [f64],
    pub w: &'c [f64],
    pub eta: &'c [f64],
}

impl<'a, M: InverseModel + ?Sized> Collocation<'a, M> {
    /// The points of `run`'s solution, the reference evaluated along `smoother`.
    pub(crate) fn of(model: &'a M, smoother: &Smoother, run: &'a StableRun) -> Collocation<'a, M> {
        let info = model.info();
        let end = |t: f64| {
            let mut yd = vec![0.0; info.relative_degree + 1];
            let mut w = vec![0.0; info.n_w()];
            smoother.eval(t, &mut yd);
            smoother.eval_signals(t, &mut w);
            (yd, w)
        };
        Collocation {
            bvp: Bvp::new(model, smoother, &run.plan, run.solution.k),
            run,
            ends: [end(run.plan.t_eq.0), end(run.plan.t_eq.1)],
        }
    }

    /// The equilibrium η_a (`end` 0) or η_b (`end` 1) with the constant reference it is solved for, as the
    /// plan evaluates it.
    pub(crate) fn equilibrium(&self, end: usize) -> CollocationPoint<'_> {
        let plan = &self.run.plan;
        let (t, eta) = match end {
            0 => (plan.t_eq.0, &plan.eta_a),
            _ => (plan.t_eq.1, &plan.eta_b),
        };
        let (yd, w) = &self.ends[end.min(1)];
        CollocationPoint { t, yd, w, eta }
    }

    /// Where the boundary conditions sit and how η is split there.
    pub(crate) fn plan(&self) -> &'a super::plan::Plan {
        &self.run.plan
    }

    /// Number of intervals K (nodes 0 … K).
    pub(crate) fn intervals(&self) -> usize {
        self.run.solution.k
    }

    /// The node spacing h.
    pub(crate) fn h(&self) -> f64 {
        self.run.solution.h
    }

    /// Node j.
    pub(crate) fn node(&self, j: usize) -> CollocationPoint<'_> {
        let (yd, w) = self.bvp.reference_at(2 * j);
        CollocationPoint {
            t: self.run.plan.t_a + j as f64 * self.h(),
            yd,
            w,
            eta: self.run.solution.node(j).0,
        }
    }

    /// The midpoint of interval j, its η (the Hermite–Simpson value) written into `eta`.
    pub(crate) fn midpoint<'c>(&'c self, j: usize, eta: &'c mut [f64]) -> CollocationPoint<'c> {
        let h = self.h();
        let ((ea, qa), (eb, qb)) = (self.run.solution.node(j), self.run.solution.node(j + 1));
        for (i, e) in eta.iter_mut().enumerate() {
            *e = 0.5 * (ea[i] + eb[i]) + h / 8.0 * (qa[i] - qb[i]);
        }
        let (yd, w) = self.bvp.reference_at(2 * j + 1);
        CollocationPoint {
            t: self.run.plan.t_a + (j as f64 + 0.5) * h,
            yd,
            w,
            eta,
        }
    }
}
