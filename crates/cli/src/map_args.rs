//! `--map NAME=FILE.csv` (contract §6): replace a lookup map's grid and values at run time, without
//! regenerating code; the map keeps its settings (smooth, extrapolate, interp) and its arity. The file's
//! errors name FILE:LINE:COLUMN (the model file's CSV format).

use crate::engine::LoadedModel;
use crate::error::Failure;
use std::path::Path;

/// Apply every `--map` argument to `model`.
pub fn apply(model: &mut LoadedModel, args: &[String]) -> Result<(), Failure> {
    for arg in args {
        let Some((name, file)) = arg
            .split_once('=')
            .filter(|(n, f)| !n.trim().is_empty() && !f.is_empty())
        else {
            return Err(Failure::user(format!(
                "--map `{arg}`: expected NAME=FILE.csv, e.g. --map eta_vol=eta_vol.csv"
            )));
        };
        let name = name.trim();
        let (x, y, values) = invsim_inversion::read_map_file(Path::new(file))
            .map_err(|e| Failure::user(format!("--map {name}: {e}")))?;
        model
            .set_map(name, (&x, y.as_deref(), &values))
            .map_err(|e| Failure::user(format!("--map {name}: {e}")))?;
    }
    Ok(())
}
