//! The exogenous signals (`[signals]`, contract §5) of a model with modes: resolved once for the run from the
//! same sources as for a single-mode model (command line, cycle column, route/elevation, default;
//! `crate::signals`), smoothed with the reference's kernel and look-ahead, and handed to each mode in the
//! layout that mode's evaluation methods take: [S, S_d1, …, S_dr] per signal with r that mode's relative
//! degree (modes may differ in r; the smoother evaluates every derivative order exactly, each mode takes the
//! first r + 1 of them), then the inputs a strategy decides in the mode (`decided`: its model carries them as
//! signals after the file's), 0 here and set by the strategy. A strategy's run evaluates the signals once, at
//! its samples and interval midpoints ([`Ctx::signal_rows`], R = r_max), and lays each mode's values out of
//! those rows ([`Ctx::w_from_row`]).

use invsim_model_api::{InverseModel, ModelInfo, SignalInfo};

use super::record::Ctx;
use super::rows::Rows;
use super::{ModalError, ModalOptions, ModalResult, ModalSpec};
use crate::cycle::Cycle;
use crate::elevation::Along;
use crate::signals::{resolve_declared, ResolvedSignal, SignalInput};
use crate::smoother::Smoother;

/// The exogenous signals a mode's model declares: its signals less the inputs a strategy decides, which the
/// model carries as signals named like the input.
pub(super) fn exogenous<'i>(spec: &ModalSpec<'_>, info: &'i ModelInfo) -> Vec<&'i SignalInfo> {
    let is_input = |s: &SignalInfo| spec.inputs.iter().any(|i| i.name == s.name);
    info.signals.iter().filter(|s| !is_input(s)).collect()
}

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
        let exo = exogenous(spec, m.info());
        exo.iter().map(|s| s.name.clone()).collect()
    };
    let declared = names(first.model);
    if let Some(m) = spec.modes.iter().find(|m| names(m.model) != declared) {
        return Err(ModalError::Setup(format!(
            "mode `{}` declares other signals than mode `{}`",
            m.name, first.name
        )));
    }
    let declared: Vec<SignalInfo> = exogenous(spec, first.model.info())
        .into_iter()
        .cloned()
        .collect();
    resolve_declared(&declared, cycle, given, along).map_err(|e| ModalError::Run(e.into()))
}

/// The run's smoother: the smoothed cycle carrying the signals of `given` and the other sources
/// ([`resolve_modal`], a route profile read along the smoothed reference's distance as in a single-mode
/// inverse run), with the signals resolved.
pub(super) fn smoother_with_signals(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
    given: &[SignalInput],
) -> Result<(Smoother, Vec<ResolvedSignal>), ModalError> {
    let along = Along::Smoothed {
        lookahead: opts.lookahead,
    };
    let resolved = resolve_modal(spec, cycle, given, along)?;
    let smoother = Smoother::new(cycle, opts.lookahead)
        .map_err(|e| ModalError::Setup(e.to_string()))?
        .with_signals(crate::signals::smoothers(&resolved, opts.lookahead));
    Ok((smoother, resolved))
}

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
        let per = self.spec.modes[m].model.info().relative_degree + 1;
        let exogenous = self.smoother.signals().len() * per;
        self.smoother.eval_signals(t, &mut w[..exogenous]);
    }

    /// [S, S_d1, …, S_dR] of every exogenous signal at each of `times`, R = r_max (no rows without
    /// signals): the values [`Ctx::w_into`] gives at those times, every order of them.
    pub(super) fn signal_rows(&self, times: &[f64]) -> Rows {
        let n = self.smoother.signals().len() * (self.r_max + 1);
        let mut rows = Rows::with_capacity(n, if n == 0 { 0 } else { times.len() });
        if n > 0 {
            let mut w = vec![0.0; n];
            for &t in times {
                self.smoother.eval_signals(t, &mut w);
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
