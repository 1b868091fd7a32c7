//! The result of an inverse run: its summary and its time series, column by column.

use super::summary::Summary;

/// Result of a run: the summary and the time series, stored column by column.
#[derive(Debug, Clone)]
pub struct SimulationResult {
    pub summary: Summary,
    /// Column names: `t`, `yd_0` … `yd_r`, the input, the states, `eta1` …, the `[outputs]`.
    pub columns: Vec<String>,
    /// One vector per column, each with `summary.samples` entries.
    pub data: Vec<Vec<f64>>,
    /// Index of the input's column in `columns`/`data`.
    pub input_column: usize,
    /// The input's bounds [min, max] as declared by the model (reported, never clipped).
    pub input_bounds: [Option<f64>; 2],
    /// How the cycle defined the reference: y_d = offset + scale · (smoothed cycle) (the model's
    /// [`invsim_model_api::InverseModel::reference`]).
    pub reference: invsim_model_api::ReferenceMap,
    /// The model's signals as the run resolved them (raw samples and where they came from).
    pub signals: Vec<crate::signals::ResolvedSignal>,
}

impl SimulationResult {
    /// The column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.data[i].as_slice())
    }
    /// Sample times t_k.
    pub fn time(&self) -> &[f64] {
        &self.data[0]
    }
    /// y_d^(k) at the samples, k = 0 … r.
    pub fn yd(&self, k: usize) -> Option<&[f64]> {
        (k <= self.summary.relative_degree).then(|| self.data[1 + k].as_slice())
    }
    /// The computed input u at the samples.
    pub fn input(&self) -> &[f64] {
        &self.data[self.input_column]
    }
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.data[0].len()
    }
    /// True if there are no samples (never the case for a successful run).
    pub fn is_empty(&self) -> bool {
        self.data[0].is_empty()
    }
}
