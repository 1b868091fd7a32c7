//! Where each of a model's exogenous signals comes from (contract §5), first that applies: the command
//! line (`--signal NAME=FILE.csv` or `--signal NAME=VALUE`, given here as [`SignalInput`]s), the cycle file's
//! column (`column`, default the signal's name; a signal named `grade` also matches `cycGrade`), the model's
//! `default`. None of these is an error naming the signal. A raw signal is linear between its samples and
//! held outside its span; [`smoothers`] turns the resolved signals into smoothers with the reference's
//! kernel and look-ahead (exact derivatives, `smoother/signals.rs`).

use invsim_model_api::ModelInfo;
use thiserror::Error;

use crate::cycle::{BadCell, Cycle, GRADE_COLUMNS};
use crate::smoother::Smoother;

/// A signal's values as given on the command line.
#[derive(Debug, Clone, PartialEq)]
pub enum SignalValue {
    /// `--signal NAME=VALUE`: constant over the run.
    Constant(f64),
    /// `--signal NAME=FILE.csv`: samples (time strictly increasing, values finite), from `file`.
    Series {
        file: String,
        time: Vec<f64>,
        values: Vec<f64>,
    },
}

/// One `--signal NAME=…`.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalInput {
    pub name: String,
    pub value: SignalValue,
}

/// A signal resolved for a run: where it came from and its raw samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedSignal {
    pub name: String,
    /// `"command line (FILE)"`, `"command line (constant)"`, `"cycle column NAME"` or `"default"`.
    pub source: String,
    pub time: Vec<f64>,
    pub values: Vec<f64>,
}

/// Why the signals of a run cannot be resolved.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SignalError {
    #[error(
        "unknown signal `{name}` given with --signal: the model declares {}",
        if known.is_empty() { "no signals".to_string() } else { format!("the signals {known}") }
    )]
    Unknown { name: String, known: String },
    #[error("signal `{name}` is given twice with --signal")]
    Duplicate { name: String },
    #[error(
        "signal `{name}` has no value: give it with --signal {name}=FILE.csv or --signal {name}=VALUE, add a \
         column `{column}` to the cycle file, or give it a `default` in the model's [signals]"
    )]
    Missing { name: String, column: String },
    #[error("signal `{name}`: the constant value {value} is not finite")]
    NotFinite { name: String, value: f64 },
    #[error(
        "{}:{}:{}: signal `{name}` reads the cycle column `{column}`, whose cell `{}` is not a finite number",
        cell.file, cell.line, cell.column, cell.text
    )]
    BadCell {
        name: String,
        column: String,
        cell: BadCell,
    },
}

/// The cycle's samples of the column `column`, if it has one: `grade` and `cycGrade` read the cycle's grade
/// column (either name, contract §4), any other name the extra column of that header name
/// (case-sensitive); a cell of it that is not a finite number is an error naming file, line and column.
fn cycle_column<'c>(
    cycle: &'c Cycle,
    name: &str,
    column: &str,
) -> Result<Option<&'c [f64]>, SignalError> {
    if GRADE_COLUMNS.contains(&column) && cycle.grade.is_some() {
        return Ok(cycle.grade.as_deref());
    }
    let Some(c) = cycle.columns.iter().find(|c| c.name == column) else {
        return Ok(None);
    };
    match &c.bad {
        Some(cell) => Err(SignalError::BadCell {
            name: name.to_string(),
            column: column.to_string(),
            cell: cell.clone(),
        }),
        None => Ok(Some(&c.values)),
    }
}

/// Every signal of the model, from the first source that applies (see the module documentation).
pub fn resolve(
    info: &ModelInfo,
    cycle: &Cycle,
    given: &[SignalInput],
) -> Result<Vec<ResolvedSignal>, SignalError> {
    for (i, g) in given.iter().enumerate() {
        if !info.signals.iter().any(|s| s.name == g.name) {
            let known: Vec<&str> = info.signals.iter().map(|s| s.name.as_str()).collect();
            return Err(SignalError::Unknown {
                name: g.name.clone(),
                known: known.join(", "),
            });
        }
        if given[..i].iter().any(|h| h.name == g.name) {
            return Err(SignalError::Duplicate {
                name: g.name.clone(),
            });
        }
    }
    let t0 = cycle.time.first().copied().unwrap_or(0.0);
    let constant = |name: &str, source: String, value: f64| ResolvedSignal {
        name: name.to_string(),
        source,
        time: vec![t0],
        values: vec![value],
    };
    let mut out = Vec::with_capacity(info.signals.len());
    for s in &info.signals {
        let column = s.column.clone().unwrap_or_else(|| s.name.clone());
        let resolved = match given.iter().find(|g| g.name == s.name).map(|g| &g.value) {
            Some(SignalValue::Constant(v)) if !v.is_finite() => {
                return Err(SignalError::NotFinite {
                    name: s.name.clone(),
                    value: *v,
                })
            }
            Some(SignalValue::Constant(v)) => {
                constant(&s.name, "command line (constant)".to_string(), *v)
            }
            Some(SignalValue::Series { file, time, values }) => ResolvedSignal {
                name: s.name.clone(),
                source: format!("command line ({file})"),
                time: time.clone(),
                values: values.clone(),
            },
            None => match (cycle_column(cycle, &s.name, &column)?, s.default) {
                (Some(values), _) => ResolvedSignal {
                    name: s.name.clone(),
                    source: format!("cycle column {column}"),
                    time: cycle.time.clone(),
                    values: values.to_vec(),
                },
                (None, Some(d)) => constant(&s.name, "default".to_string(), d),
                (None, None) => {
                    return Err(SignalError::Missing {
                        name: s.name.clone(),
                        column,
                    })
                }
            },
        };
        out.push(resolved);
    }
    Ok(out)
}

/// The resolved signals smoothed with the kernel of half-width `lookahead` (the reference's).
pub fn smoothers(signals: &[ResolvedSignal], lookahead: f64) -> Vec<Smoother> {
    signals
        .iter()
        .map(|s| Smoother::from_samples(&s.time, &s.values, lookahead))
        .collect()
}

/// How a run used one signal, for its summary: the signal, where its values came from, and whether the run
/// took the smoothed signal (the inverse and its replay) or the raw one (the forward simulation).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SignalUse {
    pub name: String,
    pub source: String,
    /// `"smoothed"` or `"raw"`.
    pub used: &'static str,
}

/// The summary's record of `resolved`, each `used` as given.
pub fn signal_uses(resolved: &[ResolvedSignal], used: &'static str) -> Vec<SignalUse> {
    resolved
        .iter()
        .map(|r| SignalUse {
            name: r.name.clone(),
            source: r.source.clone(),
            used,
        })
        .collect()
}

/// The summary's text line for the signals (nothing without signals).
pub fn write_signal_uses(s: &mut String, uses: &[SignalUse]) {
    use std::fmt::Write as _;
    if uses.is_empty() {
        return;
    }
    let list: Vec<String> = uses
        .iter()
        .map(|u| format!("{} = {}, {}", u.name, u.source, u.used))
        .collect();
    let _ = writeln!(s, "signals: {}", list.join("; "));
}
