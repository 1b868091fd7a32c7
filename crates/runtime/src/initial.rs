//! Initial states (contract §5): `initial = VALUE` on a state in the model file and `--initial NAME=VALUE`
//! on the command line (which wins) give the value at the start of the run for a state the inversion does not
//! fix, an internal state η. For a causal run they replace the equilibrium start (an integrator such as a
//! charge state has none); stable inversion keeps its boundary conditions and warns; a value given for a
//! state the inversion fixes (a function of y_d and its derivatives through ψ⁻¹) is ignored with a warning.

use invsim_model_api::ModelInfo;
use thiserror::Error;

/// Why the initial values cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InitialError {
    #[error("--initial {name}: the model has no state `{name}` (its states: {known})")]
    Unknown { name: String, known: String },
    #[error("--initial {name}: the value {value} is not finite")]
    NotFinite { name: String, value: f64 },
    #[error("--initial {name} is given twice")]
    Duplicate { name: String },
    #[error(
        "the internal state(s) {given} have an initial value but {missing} do not: give every internal state \
         a start value (`initial = VALUE` on the state in the model file, or --initial NAME=VALUE), or none \
         (the run then starts at the equilibrium of the zero dynamics)"
    )]
    Partial { given: String, missing: String },
}

/// The start values of the internal coordinates η, if the model file or the command line give them all,
/// with the warnings for values given to states the inversion fixes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct InitialEta {
    pub eta: Option<Vec<f64>>,
    pub warnings: Vec<String>,
}

/// Each state's start value: the command line's `given` (NAME, VALUE) over the model file's `initial`.
pub fn state_values(
    info: &ModelInfo,
    given: &[(String, f64)],
) -> Result<Vec<Option<f64>>, InitialError> {
    let mut values: Vec<Option<f64>> = (0..info.n_states())
        .map(|j| info.state_initial.get(j).copied().flatten())
        .collect();
    for (i, (name, value)) in given.iter().enumerate() {
        let Some(j) = info.states.iter().position(|s| s == name) else {
            return Err(InitialError::Unknown {
                name: name.clone(),
                known: info.states.join(", "),
            });
        };
        if !value.is_finite() {
            return Err(InitialError::NotFinite {
                name: name.clone(),
                value: *value,
            });
        }
        if given[..i].iter().any(|(n, _)| n == name) {
            return Err(InitialError::Duplicate { name: name.clone() });
        }
        values[j] = Some(*value);
    }
    Ok(values)
}

/// η(t_0) from the states' start values: every internal state's, or none (see [`InitialError::Partial`]).
pub fn initial_eta(info: &ModelInfo, given: &[(String, f64)]) -> Result<InitialEta, InitialError> {
    let values = state_values(info, given)?;
    let mut warnings = Vec::new();
    for (j, v) in values.iter().enumerate() {
        if v.is_some() && !info.eta_states.contains(&j) {
            warnings.push(format!(
                "initial value of state `{}` ignored: the inversion fixes it (it follows from the reference \
                 through ψ⁻¹); only internal states ({}) take a start value",
                info.states[j],
                internal_names(info)
            ));
        }
    }
    let eta: Vec<Option<f64>> = info.eta_states.iter().map(|&j| values[j]).collect();
    if eta.iter().all(Option::is_none) {
        return Ok(InitialEta {
            eta: None,
            warnings,
        });
    }
    if eta.iter().any(Option::is_none) {
        let pick = |some: bool| -> String {
            info.eta_states
                .iter()
                .filter(|&&j| values[j].is_some() == some)
                .map(|&j| info.states[j].as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        return Err(InitialError::Partial {
            given: pick(true),
            missing: pick(false),
        });
    }
    Ok(InitialEta {
        eta: Some(eta.into_iter().flatten().collect()),
        warnings,
    })
}

/// The internal states' names, for messages (`none` when r = n).
pub fn internal_names(info: &ModelInfo) -> String {
    if info.eta_states.is_empty() {
        return "none".to_string();
    }
    info.eta_states
        .iter()
        .map(|&j| info.states[j].as_str())
        .collect::<Vec<_>>()
        .join(", ")
}
