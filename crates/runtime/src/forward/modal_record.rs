//! The samples of a forward run with modes: the columns of its series (mode, gear and every input beside the
//! single-mode run's) and the summary's bookkeeping — the integrals and the distance driven from the solver's
//! quadrature states, each input's range, the free input's bound violations (against the bounds of the mode
//! in force), trace misses, tracking error, the time per mode and the engine's operating points.

use invsim_model_api::InverseModel;

use super::driver::Drive;
use super::modal_summary::{self, ModalForwardSummary, SwitchAt, Tally};
use super::record::Layout;
use super::trace::TraceBand;
use super::{ForwardError, ForwardOptions};
use crate::cycle::Cycle;
use crate::error::RunError;
use crate::grid::Grid;
use crate::modes::{ModalSpec, Role};
use crate::ode::OdeStats;
use crate::operating_points::OperatingPointTally;
use crate::progress::Progress;

/// The result of a forward run with modes: summary and columns (`t`, `yc`, `mode`, `gear`, the output unless
/// it is a state, every input applied, the states, the model's `[outputs]`).
#[derive(Debug, Clone)]
pub struct ModalForwardResult {
    pub summary: ModalForwardSummary,
    pub columns: Vec<String>,
    pub units: Vec<Option<String>>,
    pub data: Vec<Vec<f64>>,
    /// Mode index (into the spec's modes) at each sample, after the decision there (empty, like the series,
    /// without `keep_series`).
    pub mode: Vec<usize>,
    /// The model's signals as the run resolved them (the forward run uses them raw).
    pub signals: Vec<crate::signals::ResolvedSignal>,
}

impl ModalForwardResult {
    /// The column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.data[i].as_slice())
    }
}

/// Records the samples of a forward run with modes.
pub(super) struct ModalRecorder<'a> {
    columns: Vec<String>,
    units: Vec<Option<String>>,
    data: Vec<Vec<f64>>,
    keep: bool,
    output_is_state: bool,
    outs: Vec<f64>,
    /// Every input's value and the row of the series at the sample (buffers reused from sample to sample).
    inputs: Vec<f64>,
    row: Vec<f64>,
    band: TraceBand<'a>,
    /// Each mode's free-input bounds, widened by the rounding tolerance (1e-6 of the range).
    bounds: Vec<(f64, f64)>,
    tally: Tally,
    /// The previous sample's time and mode (the mode in force over the interval that ends at this sample).
    last: Option<(f64, usize)>,
    progress: Progress,
    n: usize,
}

/// The columns and their units: `t`, `yc`, `mode`, `gear`, the output (unless it is a state), every
/// input, the states, the model's `[outputs]`.
pub(super) fn layout(spec: &ModalSpec<'_>, x0: &[f64]) -> (Vec<String>, Vec<Option<String>>, bool) {
    let model = spec.modes[0].model;
    let info = model.info();
    let output_is_state = Layout::new(model, x0).output_is_state;
    let mut c: Vec<(String, Option<String>)> = vec![
        ("t".into(), Some("s".into())),
        ("yc".into(), info.output_unit.clone()),
        ("mode".into(), None),
        ("gear".into(), None),
    ];
    if !output_is_state {
        c.push((info.output.clone(), info.output_unit.clone()));
    }
    c.extend(spec.inputs.iter().map(|i| (i.name.clone(), i.unit.clone())));
    c.extend(
        info.states
            .iter()
            .cloned()
            .zip(info.state_units.iter().cloned()),
    );
    c.extend(
        info.outputs[..spec.n_outputs]
            .iter()
            .map(|o| (o.name.clone(), o.unit.clone())),
    );
    let (names, units) = c.into_iter().unzip();
    (names, units, output_is_state)
}

impl<'a> ModalRecorder<'a> {
    pub(super) fn new(
        spec: &ModalSpec<'_>,
        cycle: &'a Cycle,
        grid: &Grid,
        opts: &ForwardOptions,
        x0: &[f64],
    ) -> ModalRecorder<'a> {
        let info = spec.modes[0].model.info();
        let (columns, units, output_is_state) = layout(spec, x0);
        let stored = if opts.keep_series { grid.samples() } else { 0 };
        let bounds = spec
            .modes
            .iter()
            .map(|m| {
                let i = m.model.info();
                let tol = 1e-6
                    * match (i.input_min, i.input_max) {
                        (Some(a), Some(b)) => b - a,
                        (Some(a), None) | (None, Some(a)) => a.abs(),
                        (None, None) => 0.0,
                    };
                // At a standstill a demand below the minimum is clipped, not violated (see `modal`).
                let lo = match m.role {
                    Role::Standstill => None,
                    _ => i.input_min,
                };
                (
                    lo.unwrap_or(f64::NEG_INFINITY) - tol,
                    i.input_max.unwrap_or(f64::INFINITY) + tol,
                )
            })
            .collect();
        ModalRecorder {
            data: vec![Vec::with_capacity(stored); columns.len()],
            columns,
            units,
            keep: opts.keep_series,
            output_is_state,
            outs: vec![0.0; info.outputs.len()],
            inputs: Vec::with_capacity(spec.inputs.len()),
            row: Vec::new(),
            band: TraceBand::new(cycle, opts.trace_band(cycle)),
            bounds,
            tally: Tally::new(spec, OperatingPointTally::new(info, stored)),
            last: None,
            progress: opts.progress.clone(),
            n: grid.n,
        }
    }

    /// Sample k at time t in the run's current mode: state z = (x, I, quadratures), that mode's drive `d` and
    /// its raw signal values `w` at t.
    pub(super) fn emit(
        &mut self,
        spec: &ModalSpec<'_>,
        m: usize,
        (k, t): (usize, f64),
        z: &[f64],
        (d, w): (Drive, &[f64]),
    ) -> Result<(), ForwardError> {
        let mode = &spec.modes[m];
        let model: &dyn InverseModel = mode.model;
        let info = model.info();
        let x = &z[..info.n_states()];
        model.outputs(x, w, d.applied, &mut self.outs);
        let bad = |quantity: String, value: f64| RunError::NonFinite { t, quantity, value };
        if let Some(j) = x.iter().position(|v| !v.is_finite()) {
            return Err(bad(info.states[j].clone(), x[j]).into());
        }
        if !d.applied.is_finite() {
            return Err(bad(info.input.clone(), d.applied).into());
        }
        if let Some(j) = self.outs.iter().position(|v| !v.is_finite()) {
            return Err(bad(info.outputs[j].name.clone(), self.outs[j]).into());
        }
        let mut inputs = std::mem::take(&mut self.inputs);
        inputs.clear();
        inputs.extend((0..spec.inputs.len()).map(|i| {
            if i == mode.free_input {
                d.applied
            } else {
                mode.fixed_outputs
                    .iter()
                    .find(|(j, _)| *j == i)
                    .map_or(f64::NAN, |(_, o)| self.outs[*o])
            }
        }));
        if self.keep {
            let gear = mode.gear.unwrap_or(0) as f64;
            self.store(t, (m, gear), x, d, &inputs);
        }
        if let Some((t_prev, m_prev)) = self.last {
            self.tally.time[m_prev] += t - t_prev;
        }
        self.last = Some((t, m));
        let (lo, hi) = self.bounds[m];
        let tail = &z[info.n_states() + 1..];
        self.tally.count(t, tail, d, &inputs, (m, lo, hi));
        let (band_lo, band_hi) = self.band.at(t);
        self.tally.misses.push(t, d.y < band_lo || d.y > band_hi);
        if let Some(op) = &mut self.tally.operating {
            let outs = &self.outs;
            op.push(|o| outs[o]);
        }
        if k % 256 == 0 || k == self.n {
            self.progress.report(k, self.n);
        }
        self.inputs = inputs;
        Ok(())
    }

    fn store(&mut self, t: f64, (m, gear): (usize, f64), x: &[f64], d: Drive, inputs: &[f64]) {
        let row = &mut self.row;
        row.clear();
        row.extend([t, d.yc, m as f64, gear]);
        if !self.output_is_state {
            row.push(d.y);
        }
        row.extend_from_slice(inputs);
        row.extend_from_slice(x);
        row.extend_from_slice(&self.outs[..self.data.len() - row.len()]);
        for (c, v) in self.data.iter_mut().zip(row.iter()) {
            c.push(*v);
        }
    }

    /// The result of the finished run.
    pub(super) fn finish(
        self,
        spec: &ModalSpec<'_>,
        switches: &[SwitchAt],
        (cycle, opts): (&Cycle, &ForwardOptions),
        stats: OdeStats,
    ) -> ModalForwardResult {
        let mode = self.data.get(2).cloned().unwrap_or_default();
        let summary = modal_summary::summarise(
            (spec, switches),
            cycle,
            opts,
            (self.tally, stats),
            (&self.columns, &self.units),
        );
        ModalForwardResult {
            summary,
            columns: self.columns,
            units: self.units,
            data: self.data,
            mode: mode.iter().map(|&m| m as usize).collect(),
            signals: Vec::new(),
        }
    }
}
