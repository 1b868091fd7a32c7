//! The exogenous signals (`[signals]`, contract §5) of a model with modes: resolved once for the run from the
//! same sources as for a single-mode model (command line, cycle column, route/elevation, default;
//! `crate::signals`), smoothed with the reference's kernel and look-ahead, and handed to each mode in the
//! layout that mode's evaluation methods take: [S, S_d1, …, S_dr] per signal with r that mode's relative
//! degree (modes may differ in r; the smoother evaluates every derivative order exactly, each mode takes the
//! first r + 1 of them).

use invsim_model_api::InverseModel;

use super::record::Ctx;
use super::{ModalError, ModalSpec};
use crate::cycle::Cycle;
use crate::elevation::Along;
use crate::signals::{resolve_along, ResolvedSignal, SignalInput};

/// The signals of the run, from the first mode's declaration (every mode of a model file declares the same
/// `[signals]`; a spec whose modes disagree is refused).
pub(super) fn resolve_modal(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    given: &[SignalInput],
    along: Along,
) -> Result<Vec<ResolvedSignal>, ModalError> {
    let Some(first) = spec.modes.first() else {
        return Ok(Vec::new());
    };
    let names = |m: &dyn InverseModel| -> Vec<String> {
        m.info().signals.iter().map(|s| s.name.clone()).collect()
    };
    let declared = names(first.model);
    if let Some(m) = spec.modes.iter().find(|m| names(m.model) != declared) {
        return Err(ModalError::Setup(format!(
            "mode `{}` declares other signals than mode `{}`",
            m.name, first.name
        )));
    }
    resolve_along(first.model.info(), cycle, given, along).map_err(|e| ModalError::Run(e.into()))
}

impl Ctx<'_, '_> {
    /// The smoothed signals and their derivatives at t in mode `m`'s layout (empty without signals).
    pub(super) fn w(&self, m: usize, t: f64) -> Vec<f64> {
        let mut w = vec![0.0; self.spec.modes[m].model.info().n_w()];
        if !self.smoother.signals().is_empty() {
            self.smoother.eval_signals(t, &mut w);
        }
        w
    }

    /// [`Ctx::w`] into the buffer `w` (resized to `n_w`, mode `m`'s layout).
    pub(super) fn w_into(&self, m: usize, t: f64, n_w: usize, w: &mut Vec<f64>) {
        debug_assert_eq!(n_w, self.spec.modes[m].model.info().n_w());
        w.clear();
        if n_w == 0 {
            return;
        }
        w.resize(n_w, 0.0);
        self.smoother.eval_signals(t, w);
    }
}
