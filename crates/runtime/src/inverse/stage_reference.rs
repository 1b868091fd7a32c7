//! The reference y_d … y_d^(r) and the signals at the zero-dynamics integrator's stage times of a causal run:
//! the sub-grid interpolant of `smoother/fine.rs` (within 10⁻¹¹ of the smoother's pointwise values, at a few
//! multiply-adds a stage instead of every corner's kernel terms) or, where the options ask for it, the
//! smoother pointwise. The run evaluates η̇ here, and the sensitivities it carries (`gradient/pass.rs`) read
//! A and B at their Gauss nodes from a second reader of the same table.

use std::sync::Arc;

use invsim_model_api::{InverseModel, ModelInfo};

use super::options::SimulationOptions;
use crate::grid::{Grid, MAX_DERIVATIVES};
use crate::smoother::{FineReference, FineTable, Smoother, ZeroDynamicsReference};

/// The reference at stage times, with the last one read kept (a step's last two stages are both at its end).
pub(crate) struct StageReference {
    fine: Option<FineReference>,
    yd: [f64; MAX_DERIVATIVES],
    w: Vec<f64>,
    at: f64,
}

impl StageReference {
    /// For a run of the model `info` on `grid` with `opts`.
    pub(crate) fn new(
        smoother: &Smoother,
        grid: &Grid,
        opts: &SimulationOptions,
        info: &ModelInfo,
    ) -> StageReference {
        Self::sharing(smoother, grid, (opts, info), None)
    }

    /// [`StageReference::new`] reading the sub-grid table `table` where one is given (another reader's of the
    /// same run: the run's, for its sensitivity pass), so that its blocks are evaluated once.
    pub(crate) fn sharing(
        smoother: &Smoother,
        grid: &Grid,
        (opts, info): (&SimulationOptions, &ModelInfo),
        table: Option<&Arc<FineTable>>,
    ) -> StageReference {
        let fine =
            (opts.zero_dynamics_reference == ZeroDynamicsReference::SubGrid).then(|| match table {
                Some(table) => FineReference::on(table.clone()),
                None => {
                    let span = (grid.t0, grid.dt, grid.n);
                    FineReference::new(smoother, span, opts.lookahead, info.relative_degree)
                }
            });
        StageReference {
            fine,
            yd: [0.0; MAX_DERIVATIVES],
            w: vec![0.0; info.n_w()],
            at: f64::NAN,
        }
    }

    /// The sub-grid table it reads, if any.
    pub(crate) fn table(&self) -> Option<&Arc<FineTable>> {
        self.fine.as_ref().map(FineReference::table)
    }

    /// y_d … y_d^(r) and the signals at time s.
    pub(crate) fn at(&mut self, smoother: &Smoother, (s, r): (f64, usize)) -> (&[f64], &[f64]) {
        if s.to_bits() != self.at.to_bits() {
            let yd = &mut self.yd[..=r];
            match self.fine.as_mut() {
                Some(f) => f.eval(smoother, s, yd, &mut self.w),
                None => {
                    smoother.eval(s, yd);
                    smoother.eval_signals(s, &mut self.w);
                }
            }
            self.at = s;
        }
        (&self.yd[..=r], &self.w)
    }

    /// η̇ = q(ξ(s), η, w(s), y_d^(r)(s)) into `de` (`u_prev`: Newton's start for a non-affine input).
    pub(crate) fn zero_dynamics<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        smoother: &Smoother,
        (s, r): (f64, usize),
        (eta, u_prev): (&[f64], f64),
        de: &mut [f64],
    ) {
        let (yd, w) = self.at(smoother, (s, r));
        model.zero_dynamics_from(&yd[..r], eta, w, yd[r], u_prev, de);
    }
}
