//! Loading a model and choosing the engine that runs it: compiled code for a built-in model whose file's
//! SHA-256 matches one the extension was built with (`invsim_models::by_hash`), the interpreter tape
//! otherwise. This is the rule of the command line's `--engine auto|compiled|interpreted`
//! (crates/cli/src/engine.rs), repeated here in a few lines because it lives in the command-line crate.

use std::path::Path;

use invsim_inversion::{Derivation, Interpreter, Model};
use invsim_model_api::InverseModel;

use crate::error::Failure;

/// The engine asked for.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum EngineChoice {
    Auto,
    Compiled,
    Interpreted,
}

impl EngineChoice {
    /// `"auto"`, `"compiled"` or `"interpreted"`.
    pub fn parse(s: &str) -> Result<EngineChoice, Failure> {
        match s {
            "auto" => Ok(EngineChoice::Auto),
            "compiled" => Ok(EngineChoice::Compiled),
            "interpreted" => Ok(EngineChoice::Interpreted),
            _ => Err(Failure::msg(format!(
                "engine `{s}`: expected \"auto\", \"compiled\" or \"interpreted\""
            ))),
        }
    }
}

/// How the model runs.
enum Kind {
    /// Generated code of the built-in model with this file hash.
    Compiled(String),
    /// The interpreter, a prototype cloned for each run.
    Interpreted(Box<Interpreter>),
}

/// A loaded model: what `derive` prints, the units of its result columns and a factory of runnable
/// instances.
pub struct Loaded {
    kind: Kind,
    /// The derivation as the command line's `derive --format json` prints it (compact).
    pub derive_json: String,
    /// Unit of each column of a run's series, by column name (`None`: not declared).
    pub units: Vec<(String, Option<String>)>,
}

impl Loaded {
    /// Load and derive the model file `path` given as `bytes`, with the requested engine. The model is always
    /// derived first, so a bad file gives the same error whichever engine was asked for.
    pub fn new(path: &Path, bytes: &[u8], choice: EngineChoice) -> Result<Loaded, Failure> {
        let model = Model::from_bytes(path, bytes)?;
        let d = Derivation::new(model).map_err(invsim_inversion::Error::from)?;
        let derive_json =
            serde_json::to_string(&d.to_json()).map_err(|e| Failure::msg(e.to_string()))?;
        let units = column_units(&d);
        let hash = d.model.source_hash.clone();
        let builtin = invsim_models::by_hash(&hash).is_some();
        let kind = match choice {
            EngineChoice::Auto | EngineChoice::Compiled if builtin => Kind::Compiled(hash),
            EngineChoice::Compiled => return Err(not_builtin(path, &hash)),
            _ => Kind::Interpreted(Box::new(
                Interpreter::new(&d).map_err(invsim_inversion::Error::from)?,
            )),
        };
        Ok(Loaded {
            kind,
            derive_json,
            units,
        })
    }

    /// `"compiled"` or `"interpreted"` (the summary's `engine`).
    pub fn engine_name(&self) -> &'static str {
        match self.kind {
            Kind::Compiled(_) => "compiled",
            Kind::Interpreted(_) => "interpreted",
        }
    }

    /// A fresh instance with the file's parameter values, for one run.
    pub fn instance(&self) -> Result<Box<dyn InverseModel>, Failure> {
        match &self.kind {
            Kind::Compiled(hash) => invsim_models::by_hash(hash)
                .ok_or_else(|| Failure::msg(format!("no compiled model with hash {hash}"))),
            Kind::Interpreted(p) => Ok(Box::new(p.as_ref().clone())),
        }
    }

    /// A fresh instance with `params` set (in order), each value finite.
    pub fn with_params(&self, params: &[(String, f64)]) -> Result<Box<dyn InverseModel>, Failure> {
        let mut m = self.instance()?;
        for (name, value) in params {
            set_param(m.as_mut(), name, *value)?;
        }
        Ok(m)
    }
}

/// Set one parameter, as `--set NAME=VALUE` does (the value must be finite).
pub fn set_param(m: &mut dyn InverseModel, name: &str, value: f64) -> Result<(), Failure> {
    if !value.is_finite() {
        return Err(Failure::msg(format!(
            "parameter {name} = {value}: the value must be finite"
        )));
    }
    m.set_param(name, value)
        .map_err(|e| Failure::msg(format!("parameter {name}: {e}")))
}

fn not_builtin(path: &Path, hash: &str) -> Failure {
    Failure::in_file(
        format!(
            "no compiled code for `{}`: the file (sha256 {hash}) matches none of the built-in models this \
             extension was built with ({}; a built-in model must be byte-for-byte the file in models/); use \
             engine=\"interpreted\", or engine=\"auto\" to fall back to the interpreter",
            path.display(),
            invsim_models::names().join(", ")
        ),
        path.display().to_string(),
    )
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
