//! The reference y_d … y_d^(r) and the signals at the zero-dynamics integrator's stage times of a causal run:
//! the sub-grid interpolant of `smoother/fine.rs` (within 10⁻¹¹ of the smoother's pointwise values, at a few
//! multiply-adds a stage instead of every corner's kernel terms) or, where the options ask for it, the
//! smoother pointwise. The run evaluates η̇ here, and the sensitivities it carries (`gradient/pass.rs`) read
//! A and B at their Gauss nodes from a second reader of the same table.

use invsim_model_api::{InverseModel, ModelInfo};

use super::options::SimulationOptions;
use crate::grid::{Grid, MAX_DERIVATIVES};
use crate::smoother::{FineReference, Smoother, ZeroDynamicsReference};

/// The reference at stage times, with the last one read kept (a step's last two stages are both at its end).
pub(crate) struct StageReference {
    fine: Option<FineReference>,
    yd: [f64; MAX_DERIVATIVES],
    w: Vec<f64>,
    at: f64,
}

impl StageReference {
    /// For a run of the model `info` on `grid` with `opts`, on a sub-grid table of its own (its blocks kept
    /// where `shared`: a second reader, [`StageReference::sharing`], reads them too).
    pub(crate) fn new(
        smoother: &Smoother,
        grid: &Grid,
        (opts, info): (&SimulationOptions, &ModelInfo),
        shared: bool,
    ) -> StageReference {
        let fine = (opts.zero_dynamics_reference == ZeroDynamicsReference::SubGrid).then(|| {
            let span = (grid.t0, grid.dt, grid.n);
            FineReference::new(
                smoother,
                span,
                (opts.lookahead, info.relative_degree),
                shared,
            )
        });
        Self::reading(fine, info)
    }

    /// Another reader of `stages`' sub-grid table (the run's, for its sensitivity pass), so that its blocks
    /// are evaluated once; pointwise where `stages` reads the smoother pointwise.
    pub(crate) fn sharing(stages: &StageReference, info: &ModelInfo) -> StageReference {
        let fine = stages
            .fine
            .as_ref()
            .map(|f| FineReference::on(f.table().clone()));
        Self::reading(fine, info)
    }

    fn reading(fine: Option<FineReference>, info: &ModelInfo) -> StageReference {
        StageReference {
            fine,
            yd: [0.0; MAX_DERIVATIVES],
            w: vec![0.0; info.n_w()],
            at: f64::NAN,
        }
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
