//! A sweep's rows: the parameter values and the summary figures of every variant × cycle, and their CSV.

use std::io::Write;

use super::hybrid_columns::{Cell, HYBRID_COLUMNS};
use crate::headline::Headline;
use crate::inverse::Summary;
use crate::modes::{HybridBlock, ModalSummary};
use crate::report::Totals;

/// The summary figures of one run (see [`crate::Summary`], whose numbers they are).
#[derive(Debug, Clone, PartialEq)]
pub struct Figures {
    /// Reported samples.
    pub samples: usize,
    /// Distance of the cycle, m.
    pub distance_m: f64,
    /// ∫ o dt of every accumulated output, in the order of [`SweepResult::integrals`].
    pub integrals: Vec<f64>,
    /// The integrals per 100 km (NaN when the cycle covers no distance).
    pub integrals_per_100km: Vec<f64>,
    /// The headline's figures under [`SweepResult::headline`] (NaN where the summary has null).
    pub headline: Vec<f64>,
    /// The input's range over the run.
    pub input_min: f64,
    pub input_max: f64,
    /// Number of intervals with the input outside its bounds and their total length, s.
    pub violations: usize,
    pub violation_s: f64,
    /// With `verify`: max |y − y_d| and rms (y − y_d) of the forward replay.
    pub max_abs_tracking_error: Option<f64>,
    pub rms_tracking_error: Option<f64>,
    /// A model with modes: the time in each mode, the switches and the largest transition deviation.
    pub modes: Option<ModeFigures>,
    /// With `--gradient`: d figure/d parameter, by figure, then parameter (the summary's `gradient` block).
    pub gradient: Option<crate::gradient::Figures>,
    /// With a strategy: the summary's `hybrid` block (its columns: [`HYBRID_COLUMNS`]).
    pub hybrid: Option<Box<HybridBlock>>,
}

/// The figures of a run with modes beside those of every run.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeFigures {
    /// Time in each mode, s, in the order of [`SweepResult::modes`].
    pub time_s: Vec<f64>,
    /// Number of mode switches.
    pub switches: usize,
    /// The largest deviation |y − y_c| of a re-entry from the smoothed cycle (the tracked output's unit).
    pub max_transition_deviation: f64,
}

impl Figures {
    /// The figures of `summary`, integrals in the order of `integrals`.
    pub fn from_summary(summary: &Summary, integrals: &[String]) -> Figures {
        let tracking = (summary.max_abs_tracking_error, summary.rms_tracking_error);
        let run = (summary.samples, summary.run.distance_m);
        Figures {
            headline: headline_values(summary.headline.as_ref()),
            gradient: summary.gradient.as_ref().map(|g| g.figures.clone()),
            ..Figures::of(run, &summary.totals, tracking, integrals)
        }
    }

    /// The figures of a run with modes, integrals in the order of `integrals`: its input block is the traction
    /// input's, its violations those of every mode's free input.
    pub fn from_modal(summary: &ModalSummary, integrals: &[String]) -> Figures {
        let tracking = (summary.max_abs_tracking_error, summary.rms_tracking_error);
        let run = (summary.samples, summary.run.distance_m);
        let m = &summary.modes;
        Figures {
            modes: Some(ModeFigures {
                time_s: m.per_mode.iter().map(|t| t.time_s).collect(),
                switches: m.switches,
                max_transition_deviation: m.max_transition_deviation,
            }),
            headline: headline_values(summary.headline.as_ref()),
            gradient: summary.gradient.as_ref().map(|g| g.figures.clone()),
            hybrid: summary.hybrid.clone(),
            ..Figures::of(run, &summary.totals, tracking, integrals)
        }
    }

    /// The figures every run has: (samples, distance), the totals, the tracking errors.
    fn of(
        (samples, distance_m): (usize, f64),
        totals: &Totals,
        (max_abs_tracking_error, rms_tracking_error): (Option<f64>, Option<f64>),
        integrals: &[String],
    ) -> Figures {
        let pick = |map: &std::collections::BTreeMap<String, f64>| -> Vec<f64> {
            let value = |name: &String| map.get(name).copied().unwrap_or(f64::NAN);
            integrals.iter().map(value).collect()
        };
        let violations = &totals.input_bound_violations;
        Figures {
            samples,
            distance_m,
            integrals: pick(&totals.integrals),
            integrals_per_100km: pick(&totals.integrals_per_100km),
            headline: Vec::new(),
            input_min: totals.input_min,
            input_max: totals.input_max,
            violations: violations.len(),
            violation_s: total_length(violations),
            max_abs_tracking_error,
            rms_tracking_error,
            modes: None,
            gradient: None,
            hybrid: None,
        }
    }
}

/// One variant on one cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRow {
    /// Index of the variant (grid point or table row, from 0).
    pub variant: usize,
    /// The cycle's name.
    pub cycle: String,
    /// The look-ahead of the run, s (`--lookahead auto`: the one chosen for the cycle).
    pub lookahead_s: f64,
    /// The swept parameters' values, in the order of [`SweepResult::parameters`].
    pub params: Vec<f64>,
    /// The figures, or why the run failed (the error's message).
    pub outcome: Result<Figures, String>,
}

/// Every row of a sweep, with the names that label their numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepResult {
    /// The model's name.
    pub model: String,
    /// The engine that ran it (the options' `engine`).
    pub engine: String,
    /// Names of the swept parameters.
    pub parameters: Vec<String>,
    /// Names of the accumulated outputs (sorted, as in the summary's `integrals`).
    pub integrals: Vec<String>,
    /// The headline's columns (`l_per_100km`, `mpg_us`, `mpg_uk`, `co2_g_per_km` for a fuel,
    /// `kwh_per_100km`, `mpgge` for electric energy; none for a model without `[headline]`).
    pub headline: Vec<String>,
    /// Whether the rows have tracking errors.
    pub verify: bool,
    /// The modes' names of a model with modes (then every row has their times), else empty.
    pub modes: Vec<String>,
    /// Whether the runs had a strategy (then every row has the [`HYBRID_COLUMNS`]).
    pub hybrid: bool,
    /// With `--gradient`: the (figure, parameter) of each derivative column `d(FIGURE)/d(PARAMETER)`, in the
    /// order of the first successful row's `gradient` (every row's has the same entries), else empty.
    pub gradient: Vec<(String, String)>,
    /// Variant 0 on each cycle, then variant 1 on each cycle, ….
    pub rows: Vec<SweepRow>,
}

/// The derivative columns of `rows`: every (figure, parameter) of the first successful row's gradient.
pub(super) fn gradient_columns(rows: &[SweepRow]) -> Vec<(String, String)> {
    let first = rows
        .iter()
        .find_map(|r| r.outcome.as_ref().ok().and_then(|f| f.gradient.as_ref()));
    first.map_or_else(Vec::new, |g| {
        g.iter()
            .flat_map(|(f, row)| row.keys().map(move |p| (f.clone(), p.clone())))
            .collect()
    })
}

/// A row's derivative `d(figure)/d(parameter)` (NaN where it has none).
pub(super) fn derivative(f: &Figures, (figure, parameter): &(String, String)) -> f64 {
    f.gradient
        .as_ref()
        .and_then(|g| g.get(figure)?.get(parameter).copied())
        .unwrap_or(f64::NAN)
}

impl SweepResult {
    /// Number of rows whose run failed.
    pub fn failed(&self) -> usize {
        self.rows.iter().filter(|r| r.outcome.is_err()).count()
    }

    /// The CSV header: `variant`, `cycle`, `lookahead_s`, the parameters, `status`, `error`, `samples`,
    /// `distance_m`, the integrals, `NAME_per_100km` for each, the headline's columns, `input_min`, `input_max`,
    /// `violations`, `violation_s`, and with
    /// `verify` `max_abs_tracking_error`, `rms_tracking_error`, for a model with modes `switches`,
    /// `max_transition_deviation` and `time_MODE_s` for each mode, with a strategy the [`HYBRID_COLUMNS`], and
    /// with `--gradient`
    /// `d(FIGURE)/d(PARAMETER)` for each figure and parameter.
    pub fn header(&self) -> Vec<String> {
        let mut h = ["variant", "cycle", "lookahead_s"]
            .map(String::from)
            .to_vec();
        h.extend(self.parameters.iter().cloned());
        h.extend(["status", "error", "samples", "distance_m"].map(String::from));
        h.extend(self.integrals.iter().cloned());
        h.extend(self.integrals.iter().map(|n| format!("{n}_per_100km")));
        h.extend(self.headline.iter().cloned());
        h.extend(["input_min", "input_max", "violations", "violation_s"].map(String::from));
        if self.verify {
            h.extend(["max_abs_tracking_error", "rms_tracking_error"].map(String::from));
        }
        if !self.modes.is_empty() {
            h.extend(["switches", "max_transition_deviation"].map(String::from));
            h.extend(self.modes.iter().map(|m| format!("time_{m}_s")));
        }
        if self.hybrid {
            h.extend(HYBRID_COLUMNS.iter().map(|c| c.name.to_string()));
        }
        h.extend(self.gradient.iter().map(|(f, p)| format!("d({f})/d({p})")));
        h
    }

    /// The fields of `row` under [`SweepResult::header`]; numbers in Rust's shortest round-trip form, the
    /// floats always with a decimal point as in the run's CSV ([`crate::output::float_text`]: `1000.0`, not
    /// `1000`, whole counts as integers), empty fields where a failed run has no figure.
    pub fn record(&self, row: &SweepRow) -> Vec<String> {
        let float = crate::output::float_text;
        let mut r = vec![
            row.variant.to_string(),
            row.cycle.clone(),
            float(row.lookahead_s),
        ];
        r.extend(row.params.iter().map(|&v| float(v)));
        let n_modal = if self.modes.is_empty() {
            0
        } else {
            2 + self.modes.len()
        };
        let n_figures = 2
            + 2 * self.integrals.len()
            + self.headline.len()
            + 4
            + if self.verify { 2 } else { 0 }
            + n_modal
            + if self.hybrid { HYBRID_COLUMNS.len() } else { 0 }
            + self.gradient.len();
        match &row.outcome {
            Err(e) => {
                r.extend(["error".to_string(), e.clone()]);
                r.extend(std::iter::repeat_n(String::new(), n_figures));
            }
            Ok(f) => {
                r.extend(["ok".to_string(), String::new(), f.samples.to_string()]);
                r.push(float(f.distance_m));
                r.extend(f.integrals.iter().map(|&v| float(v)));
                r.extend(f.integrals_per_100km.iter().map(|&v| float(v)));
                r.extend(
                    (0..self.headline.len())
                        .map(|j| float(f.headline.get(j).copied().unwrap_or(f64::NAN))),
                );
                r.extend([f.input_min, f.input_max].map(float));
                r.extend([f.violations.to_string(), float(f.violation_s)]);
                if self.verify {
                    let opt = |v: Option<f64>| v.map_or(String::new(), float);
                    r.extend([opt(f.max_abs_tracking_error), opt(f.rms_tracking_error)]);
                }
                if let Some(m) = f.modes.as_ref().filter(|_| !self.modes.is_empty()) {
                    r.push(m.switches.to_string());
                    r.push(float(m.max_transition_deviation));
                    r.extend(m.time_s.iter().map(|&v| float(v)));
                }
                if self.hybrid {
                    r.extend(hybrid_fields(f.hybrid.as_deref()));
                }
                r.extend(self.gradient.iter().map(|c| float(derivative(f, c))));
            }
        }
        r
    }

    /// Write the rows as CSV (header first).
    pub fn write_csv<W: Write>(&self, w: W) -> Result<(), csv::Error> {
        let mut out = csv::Writer::from_writer(w);
        out.write_record(self.header())?;
        for row in &self.rows {
            out.write_record(self.record(row))?;
        }
        out.flush()?;
        Ok(())
    }
}

/// The [`HYBRID_COLUMNS`]' fields of a run's `hybrid` block (empty where a field is null or the run has no
/// block).
fn hybrid_fields(block: Option<&HybridBlock>) -> Vec<String> {
    let field = |c: &super::hybrid_columns::HybridColumn| match block.map(|b| (c.cell)(b)) {
        Some(Cell::Float(Some(v))) => crate::output::float_text(v),
        Some(Cell::Count(n)) => n.to_string(),
        Some(Cell::Float(None)) | None => String::new(),
    };
    HYBRID_COLUMNS.iter().map(field).collect()
}

/// A run's headline figures (none without a headline).
fn headline_values(headline: Option<&Headline>) -> Vec<f64> {
    headline.map(Headline::sweep_values).unwrap_or_default()
}

/// The total length of `intervals`, s (+0 when there are none: an empty float sum is −0).
fn total_length(intervals: &[[f64; 2]]) -> f64 {
    intervals.iter().map(|[a, b]| b - a).sum::<f64>() + 0.0
}
