//! The exogenous signals (`[signals]`, contract §5) of a model with modes: resolved once for the run from the
//! same sources as for a single-mode model (command line, cycle column, route/elevation, default;
//! `crate::signals`; `reference.rs` resolves them with the run's reference), smoothed with the reference's
//! kernel and look-ahead, and handed to each mode in the
//! layout that mode's evaluation methods take: [S, S_d1, …, S_dr] per signal with r that mode's relative
//! degree (modes may differ in r; the smoother evaluates every derivative order exactly, each mode takes the
//! first r + 1 of them), then the inputs a strategy decides in the mode (`decided`: its model carries them as
//! signals after the file's), 0 here and set by the strategy. A strategy's run evaluates the signals once, at
//! its samples and interval midpoints ([`Ctx::signal_rows`], R = r_max), and lays each mode's values out of
//! those rows ([`Ctx::w_from_row`]).

use super::record::Ctx;
use super::rows::Rows;
use super::ModalResult;
use crate::signals::ResolvedSignal;

/// The signals a run used, into its result and its summary (smoothed).
pub(super) fn record_signals(result: &mut ModalResult, resolved: Vec<ResolvedSignal>) {
    result.summary.signals = crate::signals::signal_uses(&resolved, "smoothed");
    result.signals = resolved;
}

impl Ctx<'_, '_> {
    /// The smoothed signals and their derivatives at t in mode `m`'s layout (empty without signals).
    pub(super) fn w(&self, m: usize, t: f64) -> Vec<f64> {
        let mut w = Vec::new();
        self.w_into(m, t, self.spec.modes[m].model.info().n_w(), &mut w);
        w
    }

    /// [`Ctx::w`] into the buffer `w` (resized to `n_w`, mode `m`'s layout; decided inputs' slots 0).
    pub(super) fn w_into(&self, m: usize, t: f64, n_w: usize, w: &mut Vec<f64>) {
        debug_assert_eq!(n_w, self.spec.modes[m].model.info().n_w());
        w.clear();
        if n_w == 0 {
            return;
        }
        w.resize(n_w, 0.0);
        self.w_fill(m, t, w);
    }

    /// [`Ctx::w`] into `w` of mode `m`'s length n_w, its decided inputs' slots already 0.
    pub(super) fn w_fill(&self, m: usize, t: f64, w: &mut [f64]) {
        let per = self.spec.modes[m].model.info().relative_degree + 1;
        let exogenous = self.reference.smoother.signals().len() * per;
        self.reference.smoother.eval_signals(t, &mut w[..exogenous]);
    }

    /// [S, S_d1, …, S_dR] of every exogenous signal at each of `times`, R = r_max (no rows without
    /// signals): the values [`Ctx::w_into`] gives at those times, every order of them.
    pub(super) fn signal_rows(&self, times: &[f64]) -> Rows {
        let n = self.reference.smoother.signals().len() * (self.r_max + 1);
        let mut rows = Rows::with_capacity(n, if n == 0 { 0 } else { times.len() });
        if n > 0 {
            let mut w = vec![0.0; n];
            for &t in times {
                self.reference.smoother.eval_signals(t, &mut w);
                rows.push(&w);
            }
        }
        rows
    }

    /// Mode `m`'s exogenous signal values out of a row of [`Ctx::signal_rows`] into the front of `w` (mode
    /// `m`'s layout, its length n_w): per signal j, w[j (r + 1) + i] = row[j (R + 1) + i] for i = 0 … r.
    pub(super) fn w_from_row(&self, m: usize, row: &[f64], w: &mut [f64]) {
        let per = self.spec.modes[m].model.info().relative_degree + 1;
        let wide = self.r_max + 1;
        for (chunk, signal) in w.chunks_mut(per).zip(row.chunks(wide)) {
            chunk.copy_from_slice(&signal[..per]);
        }
    }
}
