//! `--initial NAME=VALUE` (contract §5): the start value of an internal state, over the model file's
//! `initial = VALUE` on that state.

use crate::error::Failure;

/// Parse every `--initial` argument as (state name, finite value).
pub fn parse_initial(args: &[String]) -> Result<Vec<(String, f64)>, Failure> {
    args.iter()
        .map(|a| {
            let (name, value) = a.split_once('=').ok_or_else(|| {
                Failure::user(format!(
                    "--initial `{}`: expected NAME=VALUE, e.g. --initial soc=0.9",
                    a.escape_debug()
                ))
            })?;
            let v: f64 = value.trim().parse().map_err(|_| {
                Failure::user(format!(
                    "--initial `{}`: `{}` is not a number",
                    a.escape_debug(),
                    value.trim().escape_debug()
                ))
            })?;
            if !v.is_finite() {
                return Err(Failure::user(format!(
                    "--initial `{}`: the value must be finite",
                    a.escape_debug()
                )));
            }
            Ok((name.trim().to_string(), v))
        })
        .collect()
}
