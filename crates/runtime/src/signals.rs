//! Where each of a model's exogenous signals comes from (contract §5), first that applies: the command
//! line (`--signal NAME=FILE.csv` or `--signal NAME=VALUE`, given here as [`SignalInput`]s), the cycle file's
//! column (`column`, default the signal's name; a signal named `grade` also matches `cycGrade`), the model's
//! `default`. A grade signal may come as elevation over distance instead (a route file, or the cycle's
//! `elevation_m`/`elevation_ft` column), turned into grade along the run's distance (`elevation.rs`). None
//! of these is an error naming the signal. A raw signal is linear between its samples and
//! held outside its span; [`smoothers`] turns the resolved signals into smoothers with the reference's
//! kernel and look-ahead (exact derivatives, `smoother/signals.rs`).

use invsim_model_api::{ModelInfo, SignalInfo};
use thiserror::Error;

use crate::cycle::{BadCell, Cycle, GRADE_COLUMNS};
use crate::elevation::{Along, Route, TooSteep, ELEVATION_COLUMNS};
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
    /// `--signal grade=ROUTE.csv`: elevation over distance, from `file`, read as grade along the run's
    /// distance (`elevation.rs`).
    Route { file: String, route: Route },
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
    #[error(
        "signal `{name}`: {file} is a route profile (elevation over distance), which gives a road grade; only \
         a grade signal (named `grade`, or reading the column `grade` or `cycGrade`) takes one"
    )]
    RouteNotGrade { name: String, file: String },
    #[error("signal `{name}` from {origin}: {error}")]
    TooSteep {
        name: String,
        origin: String,
        error: TooSteep,
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

/// Every signal of the model, from the first source that applies (see the module documentation); a route
/// profile (elevation over distance) is read along the raw cycle's distance (the forward simulation).
pub fn resolve(
    info: &ModelInfo,
    cycle: &Cycle,
    given: &[SignalInput],
) -> Result<Vec<ResolvedSignal>, SignalError> {
    resolve_along(info, cycle, given, Along::Cycle)
}

/// [`resolve`] reading route profiles along `along` (the inverse: the smoothed reference's distance).
pub fn resolve_along(
    info: &ModelInfo,
    cycle: &Cycle,
    given: &[SignalInput],
    along: Along,
) -> Result<Vec<ResolvedSignal>, SignalError> {
    resolve_declared(&info.signals, cycle, given, along)
}

/// [`resolve_along`] for the signals `declared` (a mode's exogenous signals, without the inputs a strategy
/// decides, which its model carries as signals).
pub(crate) fn resolve_declared(
    declared: &[SignalInfo],
    cycle: &Cycle,
    given: &[SignalInput],
    along: Along,
) -> Result<Vec<ResolvedSignal>, SignalError> {
    for (i, g) in given.iter().enumerate() {
        if !declared.iter().any(|s| s.name == g.name) {
            let known: Vec<&str> = declared.iter().map(|s| s.name.as_str()).collect();
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
    declared
        .iter()
        .map(|s| {
            let value = given.iter().find(|g| g.name == s.name).map(|g| &g.value);
            resolve_one(s, cycle, value, along)
        })
        .collect()
}

/// The warning both runs give for a cycle with a non-zero road grade that `info`'s model does not take (it has
/// no grade signal: a signal named `grade` or reading the column `grade` or `cycGrade`).
pub(crate) fn grade_warning(info: &ModelInfo, cycle: &Cycle) -> Option<String> {
    let graded = cycle
        .grade
        .as_ref()
        .is_some_and(|g| g.iter().any(|&v| v != 0.0));
    (graded && !info.signals.iter().any(is_grade))
        .then(|| "the cycle's road grade is ignored (the model has no grade input)".to_string())
}

/// A signal is a grade (and may be given as elevation) when it is named `grade` or reads a grade column.
fn is_grade(s: &SignalInfo) -> bool {
    s.name == "grade"
        || s.column
            .as_deref()
            .is_some_and(|c| GRADE_COLUMNS.contains(&c))
}

/// One signal from the command line's `value`, the cycle or its default.
fn resolve_one(
    s: &SignalInfo,
    cycle: &Cycle,
    value: Option<&SignalValue>,
    along: Along,
) -> Result<ResolvedSignal, SignalError> {
    let t0 = cycle.time.first().copied().unwrap_or(0.0);
    let series = |source: String, (time, values): (Vec<f64>, Vec<f64>)| ResolvedSignal {
        name: s.name.clone(),
        source,
        time,
        values,
    };
    let column = s.column.clone().unwrap_or_else(|| s.name.clone());
    let steep = |source: &str, e| SignalError::TooSteep {
        name: s.name.clone(),
        origin: source.to_string(),
        error: e,
    };
    match value {
        Some(SignalValue::Constant(v)) if !v.is_finite() => Err(SignalError::NotFinite {
            name: s.name.clone(),
            value: *v,
        }),
        Some(SignalValue::Constant(v)) => Ok(series(
            "command line (constant)".into(),
            (vec![t0], vec![*v]),
        )),
        Some(SignalValue::Series { file, time, values }) => Ok(series(
            format!("command line ({file})"),
            (time.clone(), values.clone()),
        )),
        Some(SignalValue::Route { file, .. }) if !is_grade(s) => Err(SignalError::RouteNotGrade {
            name: s.name.clone(),
            file: file.clone(),
        }),
        Some(SignalValue::Route { file, route }) => {
            let samples = route
                .grade_over_time(cycle, along)
                .map_err(|e| steep(file, e))?;
            Ok(series(
                format!("command line ({file}, elevation over distance)"),
                samples,
            ))
        }
        None => {
            if let Some(values) = cycle_column(cycle, &s.name, &column)? {
                let samples = (cycle.time.clone(), values.to_vec());
                return Ok(series(format!("cycle column {column}"), samples));
            }
            if let Some((name, route)) = cycle_elevation(s, cycle)? {
                let samples = route
                    .grade_over_time(cycle, along)
                    .map_err(|e| steep(&format!("the cycle's column {name}"), e))?;
                return Ok(series(format!("cycle column {name}, as grade"), samples));
            }
            match s.default {
                Some(d) => Ok(series("default".into(), (vec![t0], vec![d]))),
                None => Err(SignalError::Missing {
                    name: s.name.clone(),
                    column,
                }),
            }
        }
    }
}

/// The route profile of the cycle's elevation column (`elevation_m`, `elevation_ft`) for a grade signal.
fn cycle_elevation(s: &SignalInfo, cycle: &Cycle) -> Result<Option<(String, Route)>, SignalError> {
    if !is_grade(s) {
        return Ok(None);
    }
    for &(name, factor) in ELEVATION_COLUMNS {
        if let Some(values) = cycle_column(cycle, &s.name, name)? {
            let metres: Vec<f64> = values.iter().map(|h| h * factor).collect();
            return Ok(Some((name.to_string(), Route::of_cycle(cycle, &metres))));
        }
    }
    Ok(None)
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
