//! FASTSim's efficiency interpolators: a 0-D constant, or a 1-D table (grid, values) interpolated linearly or
//! step-wise ("Step: Lower"), read from the vehicle file.

use crate::error::ImportError;
use crate::yaml::{as_number, kind, Doc};
use serde_yaml::Value;

/// How FASTSim interpolates between the grid points of a 1-D table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Strategy {
    /// Piecewise linear (`strategy: Linear`).
    Linear,
    /// The value of the grid point at or below the argument (`strategy: {Step: Lower}`).
    StepLower,
}

/// A 1-D efficiency table: `x[k]` at `{path}.data.grid[0][k]`, `y[k]` at `{path}.data.values[k]`.
#[derive(Debug, Clone)]
pub struct Curve {
    pub path: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub strategy: Strategy,
}

impl Curve {
    /// The YAML path of grid point k.
    pub fn x_path(&self, k: usize) -> String {
        format!("{}.data.grid[0][{k}]", self.path)
    }
    /// The YAML path of value k.
    pub fn y_path(&self, k: usize) -> String {
        format!("{}.data.values[{k}]", self.path)
    }
}

/// A 0-D efficiency at `path`: a plain number or `{Constant: x}`; the value and the path of the number.
pub fn scalar(doc: &Doc, path: &str) -> Result<(f64, String), ImportError> {
    let v = doc
        .get(path)
        .ok_or_else(|| ImportError::field(path, "missing (needed by the model)"))?;
    if let Some(x) = as_number(v) {
        return Ok((x, path.to_string()));
    }
    let inner = format!("{path}.Constant");
    match doc.get(&inner).and_then(as_number) {
        Some(x) => Ok((x, inner)),
        None => Err(ImportError::field(
            path,
            format!(
                "expected a constant efficiency (a number or `Constant: x`), found {} ({}); \
                 only constant efficiencies are imported here",
                kind(v),
                first_key(v)
            ),
        )),
    }
}

/// The first key of a mapping (the variant name of a FASTSim enum), for messages.
fn first_key(v: &Value) -> String {
    v.as_mapping()
        .and_then(|m| m.keys().next())
        .and_then(|k| k.as_str())
        .unwrap_or("?")
        .to_string()
}

/// A 1-D table at `path` (grid strictly increasing, every grid point and value in its range, `limits.rs`).
pub fn table(doc: &Doc, path: &str) -> Result<Curve, ImportError> {
    let grid_path = format!("{path}.data.grid");
    let grid = doc
        .get(&grid_path)
        .and_then(Value::as_sequence)
        .ok_or_else(|| {
            ImportError::field(
                &grid_path,
                "missing (a list holding one list of grid points)",
            )
        })?;
    if grid.len() != 1 {
        return Err(ImportError::field(
            &grid_path,
            format!("{}-D tables are not supported (only 1-D)", grid.len()),
        ));
    }
    let x = numbers(&grid[0], &format!("{grid_path}[0]"))?;
    let values_path = format!("{path}.data.values");
    let values = doc
        .get(&values_path)
        .ok_or_else(|| ImportError::field(&values_path, "missing"))?;
    let y = numbers(values, &values_path)?;
    let strategy = strategy(doc, path)?;
    doc.mark(&format!("{path}.extrapolate"));
    let curve = Curve {
        path: path.to_string(),
        x,
        y,
        strategy,
    };
    check_table(&curve)?;
    Ok(curve)
}

/// A list of numbers.
fn numbers(v: &Value, path: &str) -> Result<Vec<f64>, ImportError> {
    let seq = v.as_sequence().ok_or_else(|| {
        ImportError::field(
            path,
            format!("expected a list of numbers, found {}", kind(v)),
        )
    })?;
    seq.iter()
        .enumerate()
        .map(|(k, e)| {
            as_number(e)
                .ok_or_else(|| ImportError::field(&format!("{path}[{k}]"), "expected a number"))
        })
        .collect()
}

/// A grid read from the list at `path`: at least two numbers, each finite and in its field's range
/// (`limits.rs`), strictly increasing (a battery table's axes; a 1-D table's grid is checked by
/// [`check_table`] the same way).
pub fn grid(v: &Value, path: &str) -> Result<Vec<f64>, ImportError> {
    let x = numbers(v, path)?;
    if x.len() < 2 {
        return Err(ImportError::field(
            path,
            "expected a list of at least two numbers",
        ));
    }
    check_grid(&x, |k| format!("{path}[{k}]"))?;
    Ok(x)
}

/// Every point of `x` finite and in its range, the points strictly increasing; `path_of(k)` names point k.
fn check_grid(x: &[f64], path_of: impl Fn(usize) -> String) -> Result<(), ImportError> {
    for (k, &xk) in x.iter().enumerate() {
        let path = path_of(k);
        if !xk.is_finite() {
            return Err(ImportError::field(
                &path,
                format!("{xk} is not a finite number"),
            ));
        }
        crate::limits::check(&path, xk)?;
        if k > 0 && xk <= x[k - 1] {
            return Err(ImportError::field(
                &path,
                format!(
                    "{xk} follows {}: the grid must be strictly increasing",
                    x[k - 1]
                ),
            ));
        }
    }
    Ok(())
}

/// At least two grid points and one value each, every point and value finite and in its range (`limits.rs`:
/// load fractions in [0, 1], efficiencies in (0, 1], an engine's also 0 at zero load of a linear table), the
/// grid strictly increasing; an error names the first offending point or value.
fn check_table(c: &Curve) -> Result<(), ImportError> {
    let (x, y) = (&c.x, &c.y);
    if x.len() < 2 || x.len() != y.len() {
        return Err(ImportError::field(
            &c.path,
            format!(
                "needs at least two grid points and one value each ({} and {})",
                x.len(),
                y.len()
            ),
        ));
    }
    check_grid(x, |k| c.x_path(k))?;
    for (k, &yk) in y.iter().enumerate() {
        let path = c.y_path(k);
        if !yk.is_finite() {
            return Err(ImportError::field(
                &path,
                format!("{yk} is not a finite number"),
            ));
        }
        crate::limits::check(&path, yk)?;
        if yk == 0.0 && !(k == 0 && x[0] == 0.0 && c.strategy == Strategy::Linear) {
            return Err(ImportError::field(
                &path,
                format!(
                    "an efficiency of 0 at load {} divides the power by zero: only a linear table's \
                     value at zero load may be 0 (its quotient P/e(P) then has a finite limit there)",
                    x[k]
                ),
            ));
        }
    }
    Ok(())
}

/// True when the table's efficiency at zero load is 0 (a linear table starting at (0, 0), which
/// [`check_table`] allows): power over efficiency is then 0/0 at zero load, with the finite limit
/// P_max · x_1/e_1 from the first segment.
pub fn zero_at_zero_load(c: &Curve) -> bool {
    c.y[0] == 0.0
}

/// `Linear` or `{Step: Lower}`; anything else is refused.
fn strategy(doc: &Doc, path: &str) -> Result<Strategy, ImportError> {
    let sp = format!("{path}.strategy");
    let v = doc
        .get(&sp)
        .ok_or_else(|| ImportError::field(&sp, "missing"))?;
    if v.as_str() == Some("Linear") {
        return Ok(Strategy::Linear);
    }
    if doc.get(&format!("{sp}.Step")).and_then(Value::as_str) == Some("Lower") {
        return Ok(Strategy::StepLower);
    }
    Err(ImportError::field(
        &sp,
        "only `Linear` and `Step: Lower` interpolation are supported",
    ))
}
