//! Loading a model for Python: `invsim_loader::load_source`, the command line's rule of `--engine auto|
//! compiled|interpreted` (compiled code for a file that is byte for byte a built-in model's, with or without
//! modes; the interpreter otherwise), with the derivation as the command line's `derive --format json` prints
//! it and, for a model without modes, the unit of every column.

use std::path::Path;
use std::sync::OnceLock;

use invsim_inversion::{Derivation, Model, ModelFile};
use invsim_loader::LoadError;
pub use invsim_loader::{EngineChoice, Loaded as Kind};
use invsim_model_api::InverseModel;
use invsim_runtime::modes::ModalPlant;
use invsim_runtime::Plant;

use crate::error::Failure;

/// A loaded model.
pub struct Loaded {
    pub kind: Kind,
    /// The derivation as JSON, made when first asked for (compact).
    derive_json: OnceLock<Result<String, Failure>>,
    /// Unit of each column of an inverse run's series of a model without modes, by column name (empty for a
    /// model with modes: its runs carry their units).
    pub units: Vec<(String, Option<String>)>,
    /// The model as the runtime runs it at the file's parameters, made once: the runs without parameters to
    /// set (most of a script's) share it instead of building every mode's constants and maps again.
    kept: Plant,
}

impl Loaded {
    /// Load the model file `path` given as `bytes`, with the requested engine: a bad file gives the same error
    /// whichever engine was asked for.
    pub fn new(path: &Path, bytes: &[u8], choice: EngineChoice) -> Result<Loaded, Failure> {
        // A model of Python's may be differentiated by any of its runs: derived with the gradient's
        // closed-form Jacobians.
        let extent = invsim_loader::Extent::Full;
        let kind = invsim_loader::load_source(path, bytes, (choice, extent))
            .map_err(|e| failure(e, path))?;
        let (units, json) = match &kind {
            Kind::Single(_) => {
                let model = Model::from_bytes(path, bytes)?;
                let d = Derivation::to(model, invsim_loader::Extent::Run)
                    .map_err(invsim_inversion::Error::from)?;
                let json =
                    serde_json::to_string(&d.to_json()).map_err(|e| Failure::msg(e.to_string()));
                (column_units(&d), OnceLock::from(json))
            }
            Kind::Modal(_) => (Vec::new(), OnceLock::new()),
        };
        let kept = plant_of(&kind, &[])?;
        Ok(Loaded {
            kind,
            derive_json: json,
            units,
            kept,
        })
    }

    /// `f` of the model with `params` set: the plant kept from loading where there are none (the same
    /// parameters, so the same numbers), else a fresh copy.
    pub fn with_plant<R>(
        &self,
        params: &[(String, f64)],
        f: impl FnOnce(&Plant) -> Result<R, Failure>,
    ) -> Result<R, Failure> {
        if params.is_empty() {
            return f(&self.kept);
        }
        f(&self.plant(params)?)
    }

    /// The derivation as JSON (of every mode, for a model with modes), from the file's `bytes`.
    pub fn derive_json(&self, path: &Path, bytes: &[u8]) -> Result<&str, Failure> {
        let made = self.derive_json.get_or_init(|| {
            let Ok(ModelFile::Modal(mut m)) = ModelFile::from_bytes(path, bytes) else {
                return Err(Failure::msg("the model file changed kind"));
            };
            let modes = std::mem::take(&mut m.modes);
            let inputs: Vec<String> = m.inputs.iter().map(|i| i.name.clone()).collect();
            let run = invsim_loader::Extent::Run;
            let ds =
                invsim_loader::derive_modes(modes, &inputs, run).map_err(|e| failure(e, path))?;
            let v = invsim_loader::modal_derive_json(&m, &ds);
            serde_json::to_string(&v).map_err(|e| Failure::msg(e.to_string()))
        });
        made.as_deref().map_err(Clone::clone)
    }

    /// `"compiled"` or `"interpreted"` (the summary's `engine`).
    pub fn engine_name(&self) -> &'static str {
        self.kind.engine_name()
    }

    /// The model's declared parameters.
    pub fn parameters(&self) -> Vec<String> {
        self.kind.info().parameters.clone()
    }

    /// The names a sweep sets: the declared parameters and, for a model with a gearbox, the per-gear names
    /// of the parameters it sets per gear (`i_g[3]`).
    pub fn settable(&self) -> Vec<String> {
        let mut names = self.parameters();
        if let Kind::Modal(m) = &self.kind {
            names.extend(m.plant.gear_parameters().per_gear_names());
        }
        names
    }

    /// A fresh copy of the model with `params` set, as the runtime runs it.
    pub fn plant(&self, params: &[(String, f64)]) -> Result<Plant, Failure> {
        plant_of(&self.kind, params)
    }

    /// A fresh instance of a model without modes with `params` set (in order), each value finite.
    pub fn single(&self, params: &[(String, f64)]) -> Result<Box<dyn InverseModel>, Failure> {
        single_of(&self.kind, params)
    }
}

/// A fresh copy of the model `kind` with `params` set, as the runtime runs it.
fn plant_of(kind: &Kind, params: &[(String, f64)]) -> Result<Plant, Failure> {
    match kind {
        Kind::Single(_) => single_of(kind, params).map(Plant::Single),
        Kind::Modal(_) => modal_of(kind, params).map(Plant::Modal),
    }
}

/// A fresh instance of a model without modes with `params` set (in order), each value finite.
fn single_of(kind: &Kind, params: &[(String, f64)]) -> Result<Box<dyn InverseModel>, Failure> {
    let Kind::Single(m) = kind else {
        return Err(Failure::msg("the model has operating modes"));
    };
    let mut m = m.fresh().map_err(|e| Failure::msg(e.to_string()))?;
    set_each(params, |name, v| {
        m.set_param(name, v).map_err(|e| e.to_string())
    })?;
    Ok(m)
}

/// A fresh copy of a model with modes with `params` set (in every mode), each value finite.
fn modal_of(kind: &Kind, params: &[(String, f64)]) -> Result<ModalPlant, Failure> {
    let Kind::Modal(m) = kind else {
        return Err(Failure::msg("the model has no operating modes"));
    };
    let mut p = m.fresh().map_err(|e| Failure::msg(e.to_string()))?;
    set_each(params, |name, v| {
        p.set_param(name, v).map_err(|e| e.to_string())
    })?;
    Ok(p)
}

/// `set` each of `params` in order, each value finite; an error names the parameter.
fn set_each(
    params: &[(String, f64)],
    mut set: impl FnMut(&str, f64) -> Result<(), String>,
) -> Result<(), Failure> {
    for (name, value) in params {
        check_finite(name, *value)?;
        set(name, *value).map_err(|e| Failure::msg(format!("parameter {name}: {e}")))?;
    }
    Ok(())
}

/// A parameter value must be finite (as `--set NAME=VALUE`).
fn check_finite(name: &str, value: f64) -> Result<(), Failure> {
    if value.is_finite() {
        return Ok(());
    }
    Err(Failure::msg(format!(
        "parameter {name} = {value}: the value must be finite"
    )))
}

/// The loader's error with its position where it has one; for compiled code asked of a file that is none of
/// the built-in models, how to ask for the interpreter.
fn failure(e: LoadError, path: &Path) -> Failure {
    match e {
        LoadError::Model(e) => Failure::from(*e),
        LoadError::Mode { mode, source } => {
            let f = Failure::from(*source);
            Failure {
                message: format!("mode `{mode}`: {}", f.message),
                ..f
            }
        }
        e @ LoadError::NotBuiltIn { .. } => Failure::in_file(
            format!(
                "{e}; use engine=\"interpreted\", or engine=\"auto\" to fall back to the interpreter"
            ),
            path.display().to_string(),
        ),
        e => Failure::msg(e.to_string()),
    }
}

/// The unit of every column of `simulate`'s series (contract §3: `t`, `yd_0` … `yd_r`, the input, the states,
/// `eta1` …, the `[outputs]`): y_d^(k) has the output's unit per s^k; η has none.
fn column_units(d: &Derivation) -> Vec<(String, Option<String>)> {
    let m = &d.model;
    let out_unit = m.output.unit.clone().or_else(|| {
        m.states
            .iter()
            .find(|s| s.name == m.output.name)
            .and_then(|s| s.unit.clone())
    });
    let mut units = vec![("t".to_string(), Some("s".to_string()))];
    for k in 0..=d.relative_degree {
        let u = out_unit.as_ref().map(|u| match k {
            0 => u.clone(),
            1 => format!("{u}/s"),
            _ => format!("{u}/s^{k}"),
        });
        units.push((format!("yd_{k}"), u));
    }
    units.push((m.input.name.clone(), m.input.unit.clone()));
    units.extend(m.states.iter().map(|s| (s.name.clone(), s.unit.clone())));
    units.extend(m.outputs.iter().map(|o| (o.name.clone(), o.unit.clone())));
    units
}
