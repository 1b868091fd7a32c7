//! The engine a run asks for: compiled code where the model file is byte for byte a built-in model's, the
//! interpreter tape otherwise (`auto`), or one of them by force.

use std::str::FromStr;

use crate::LoadError;

/// The engine asked for (`--engine` on the command line, `engine=` in Python).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Default)]
pub enum EngineChoice {
    /// Compiled code when the model file matches a built-in model, else the interpreter.
    #[default]
    Auto,
    /// Compiled code; an error if the model is not built in.
    Compiled,
    /// The interpreter tape.
    Interpreted,
}

impl EngineChoice {
    /// `"auto"`, `"compiled"` or `"interpreted"`.
    pub fn as_str(self) -> &'static str {
        match self {
            EngineChoice::Auto => "auto",
            EngineChoice::Compiled => "compiled",
            EngineChoice::Interpreted => "interpreted",
        }
    }
}

impl FromStr for EngineChoice {
    type Err = LoadError;

    fn from_str(s: &str) -> Result<EngineChoice, LoadError> {
        match s {
            "auto" => Ok(EngineChoice::Auto),
            "compiled" => Ok(EngineChoice::Compiled),
            "interpreted" => Ok(EngineChoice::Interpreted),
            _ => Err(LoadError::Engine(s.to_string())),
        }
    }
}
