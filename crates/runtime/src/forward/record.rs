//! The samples of a forward run: the columns of its series and the bookkeeping of the summary (integrals and
//! distance driven, read from the solver's quadrature states; input range and bound violations, trace misses,
//! tracking error).

use invsim_model_api::{InverseModel, ModelInfo};

use super::driver::Drive;
use super::error::ForwardError;
use super::options::ForwardOptions;
use super::trace::TraceBand;
use crate::cycle::Cycle;
use crate::error::RunError;
use crate::grid::Grid;
use crate::operating_points::OperatingPointTally;
use crate::progress::Progress;
use crate::report::Intervals;

/// The columns of the forward run's series.
pub(super) struct Layout {
    pub(super) columns: Vec<String>,
    /// The output column is left out when it would repeat a state column of the same name.
    pub(super) output_is_state: bool,
    pub(super) input_column: usize,
    pub(super) state_column: usize,
    pub(super) output_column: usize,
}

impl Layout {
    pub(super) fn new<M: InverseModel + ?Sized>(model: &M, x0: &[f64]) -> Layout {
        let info = model.info();
        let mut columns = vec!["t".to_string(), "yc".to_string()];
        let output_is_state = info
            .states
            .iter()
            .position(|s| *s == info.output)
            .is_some_and(|j| {
                let w = info.nominal_w();
                let mut probe = x0.to_vec();
                (0..3).all(|p| {
                    for (i, v) in probe.iter_mut().enumerate() {
                        *v = x0[i] * (1.0 + 0.1 * p as f64) + 0.01 * (p * (i + 1)) as f64;
                    }
                    model.h(&probe, &w) == probe[j]
                })
            });
        if !output_is_state {
            columns.push(info.output.clone());
        }
        let input_column = columns.len();
        columns.push(info.input.clone());
        let state_column = columns.len();
        columns.extend(info.states.iter().cloned());
        let output_column = columns.len();
        columns.extend(info.outputs.iter().map(|o| o.name.clone()));
        Layout {
            columns,
            output_is_state,
            input_column,
            state_column,
            output_column,
        }
    }
}

/// The bookkeeping of the forward run over its samples.
pub(super) struct ForwardTally {
    pub(super) accumulate: Vec<usize>,
    /// ∫ o dt of the accumulated outputs and ∫ y dt from t_0 to the last sample, by the solver.
    pub(super) integrals: Vec<f64>,
    pub(super) distance_driven: f64,
    pub(super) range: [f64; 2],
    pub(super) violations: Intervals,
    pub(super) misses: Intervals,
    pub(super) max_err: f64,
    pub(super) sum_sq: f64,
    /// The engine's operating points (models with an `[engine]`).
    pub(super) operating: Option<OperatingPointTally>,
}

/// Records the samples: the series (if kept) and the bookkeeping.
pub(super) struct Recorder<'a> {
    pub(super) info: &'a ModelInfo,
    pub(super) data: Vec<Vec<f64>>,
    pub(super) keep: bool,
    pub(super) output_is_state: bool,
    pub(super) columns: (usize, usize, usize),
    pub(super) outs: Vec<f64>,
    pub(super) band: TraceBand<'a>,
    /// Bounds of the demand, widened by the rounding tolerance.
    pub(super) bounds: (f64, f64),
    pub(super) tally: ForwardTally,
    progress: Progress,
    /// The grid's last index (for the progress fraction).
    last: usize,
}

impl<'a> Recorder<'a> {
    pub(super) fn new(
        info: &'a ModelInfo,
        cycle: &'a Cycle,
        grid: &Grid,
        layout: &Layout,
        opts: &ForwardOptions,
    ) -> Recorder<'a> {
        let no = info.outputs.len();
        let stored = if opts.keep_series { grid.samples() } else { 0 };
        let accumulate: Vec<usize> = (0..no).filter(|&i| info.outputs[i].accumulate).collect();
        // Excursions below 1e-6 of the bounds' range (or of the bound's magnitude) are rounding, not
        // violations (a vehicle at rest holds u = 0 ± 1e-11 here).
        let u_tol = 1e-6
            * match (info.input_min, info.input_max) {
                (Some(a), Some(b)) => b - a,
                (Some(a), None) | (None, Some(a)) => a.abs(),
                (None, None) => 0.0,
            };
        let (lo, hi) = (
            info.input_min.unwrap_or(f64::NEG_INFINITY),
            info.input_max.unwrap_or(f64::INFINITY),
        );
        Recorder {
            info,
            data: vec![Vec::with_capacity(stored); layout.columns.len()],
            keep: opts.keep_series,
            output_is_state: layout.output_is_state,
            columns: (
                layout.input_column,
                layout.state_column,
                layout.output_column,
            ),
            outs: vec![0.0; no],
            band: TraceBand::new(cycle, opts.trace_band(cycle)),
            bounds: (lo - u_tol, hi + u_tol),
            tally: ForwardTally {
                integrals: vec![0.0; accumulate.len()],
                accumulate,
                distance_driven: 0.0,
                range: [f64::INFINITY, f64::NEG_INFINITY],
                violations: Intervals::default(),
                misses: Intervals::default(),
                max_err: 0.0,
                sum_sq: 0.0,
                operating: OperatingPointTally::new(info, stored),
            },
            progress: opts.progress.clone(),
            last: grid.n,
        }
    }

    /// Sample k at time t: state z = (x, I, quadratures), the loop's values `d`.
    pub(super) fn emit<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        (k, t): (usize, f64),
        z: &[f64],
        d: Drive,
        w: &[f64],
    ) -> Result<(), ForwardError> {
        let info = self.info;
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
        if self.keep {
            self.store(t, x, d);
        }
        self.count(t, &z[info.n_states() + 1..], d);
        if let Some(op) = &mut self.tally.operating {
            let outs = &self.outs;
            op.push(|o| outs[o]);
        }
        if k % 256 == 0 || k == self.last {
            self.progress.report(k, self.last);
        }
        Ok(())
    }

    fn store(&mut self, t: f64, x: &[f64], d: Drive) {
        let (input_column, state_column, output_column) = self.columns;
        let data = &mut self.data;
        data[0].push(t);
        data[1].push(d.yc);
        if !self.output_is_state {
            data[2].push(d.y);
        }
        data[input_column].push(d.applied);
        for (j, &v) in x.iter().enumerate() {
            data[state_column + j].push(v);
        }
        for (j, &v) in self.outs.iter().enumerate() {
            data[output_column + j].push(v);
        }
    }

    /// The summary's bookkeeping at sample t; `quadrature` is z's tail (ForwardTally::integrals, then ∫ y dt)
    /// at t, integrated by the solver.
    fn count(&mut self, t: f64, quadrature: &[f64], d: Drive) {
        let tally = &mut self.tally;
        let m = tally.integrals.len();
        tally.integrals.copy_from_slice(&quadrature[..m]);
        tally.distance_driven = quadrature[m];
        tally.range = [tally.range[0].min(d.applied), tally.range[1].max(d.applied)];
        let (lo, hi) = self.bounds;
        tally.violations.push(t, d.demand < lo || d.demand > hi);
        let (band_lo, band_hi) = self.band.at(t);
        tally.misses.push(t, d.y < band_lo || d.y > band_hi);
        let e = d.y - d.yc;
        tally.max_err = tally.max_err.max(e.abs());
        tally.sum_sq += e * e;
    }
}
