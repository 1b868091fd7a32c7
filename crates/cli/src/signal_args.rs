//! `--signal NAME=FILE.csv|VALUE` (contract §5): a constant when VALUE is a number, else the path of a signal
//! file read for the column NAME (`invsim_runtime::signal_file`).

use invsim_runtime::{SignalInput, SignalValue};

use crate::error::Failure;

/// Parse every `--signal` argument (the file's errors name FILE:LINE:COLUMN).
pub fn parse_signals(args: &[String]) -> Result<Vec<SignalInput>, Failure> {
    args.iter().map(|a| parse_one(a)).collect()
}

/// The file a `--signal NAME=FILE.csv|VALUE` argument reads: its value when that is not a number (`None`
/// for a constant or a malformed argument).
pub fn file_of(arg: &str) -> Option<&str> {
    let (name, value) = arg.split_once('=')?;
    let (name, value) = (name.trim(), value.trim());
    (!name.is_empty() && !value.is_empty() && value.parse::<f64>().is_err()).then_some(value)
}

fn parse_one(arg: &str) -> Result<SignalInput, Failure> {
    let Some((name, value)) = arg.split_once('=') else {
        return Err(Failure::user(format!(
            "--signal `{}`: expected NAME=FILE.csv or NAME=VALUE, e.g. --signal grade=0.02",
            arg.escape_debug()
        )));
    };
    let (name, value) = (name.trim(), value.trim());
    if name.is_empty() || value.is_empty() {
        return Err(Failure::user(format!(
            "--signal `{}`: expected NAME=FILE.csv or NAME=VALUE with both parts given",
            arg.escape_debug()
        )));
    }
    let value = match value.parse::<f64>() {
        Ok(v) if v.is_finite() => SignalValue::Constant(v),
        Ok(_) => {
            return Err(Failure::user(format!(
                "--signal `{}`: the value must be finite",
                arg.escape_debug()
            )))
        }
        Err(_) => invsim_runtime::signal_file::read_signal_file(value.as_ref(), name)
            .map_err(|e| Failure::user(format!("--signal {name}: {e}")))?,
    };
    Ok(SignalInput {
        name: name.to_string(),
        value,
    })
}
