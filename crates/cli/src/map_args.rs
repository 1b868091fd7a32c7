//! `--map NAME=FILE.csv` (contract §6): replace a lookup map's grid and values at run time, without
//! regenerating code; the map keeps its settings (smooth, extrapolate, interp) and its arity. The file's
//! errors name FILE:LINE:COLUMN (the model file's CSV format).

use crate::error::Failure;
use std::fmt::Display;
use std::path::Path;

/// A map's new data: its x grid, its y grid (2-D maps), its values.
pub type MapData<'a> = (&'a [f64], Option<&'a [f64]>, &'a [f64]);

/// The name and the file of a `--map NAME=FILE.csv` argument (`None` if it is not of that form).
pub fn split(arg: &str) -> Option<(&str, &str)> {
    arg.split_once('=')
        .filter(|(n, f)| !n.trim().is_empty() && !f.is_empty())
        .map(|(n, f)| (n.trim(), f))
}

/// Read every `--map` argument's file and hand it to `set_map` (the model's), in order.
pub fn apply<E: Display>(
    args: &[String],
    mut set_map: impl FnMut(&str, MapData<'_>) -> Result<(), E>,
) -> Result<(), Failure> {
    for arg in args {
        let Some((name, file)) = split(arg) else {
            return Err(Failure::user(format!(
                "--map `{arg}`: expected NAME=FILE.csv, e.g. --map eta_vol=eta_vol.csv"
            )));
        };
        let (x, y, values) = invsim_inversion::read_map_file(Path::new(file))
            .map_err(|e| Failure::user(format!("--map {name}: {e}")))?;
        set_map(name, (&x, y.as_deref(), &values))
            .map_err(|e| Failure::user(format!("--map {name}: {e}")))?;
    }
    Ok(())
}
