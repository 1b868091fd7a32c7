//! An efficiency table as model text, exact in `[outputs]`-only definitions: piecewise linear as a map with
//! `interp = "linear"` (contract §6; the grid and values are the FASTSim table, held at the end values outside
//! it), step-wise ("Step: Lower") with its grid points and values as parameters (docs naming their FASTSim
//! fields) and e(X) = e_0 + Σ_k (e_k − e_{k−1}) (1 − max(sign(x_k − X), 0)), which takes the value e_k on
//! [x_k, x_{k+1}) exactly as FASTSim does; X is the load clamped to the grid.

use crate::curve::{Curve, Strategy};
use crate::error::ImportError;
use crate::model::{LinearMap, Model};

/// Terms per partial-sum definition (keeps every expression far below the 4000-byte limit).
const CHUNK: usize = 12;

/// Emit `curve` under `prefix` (`fc` → `fc_x0…`, `fc_e0…`, `fc_X`, `eff_fc`) as a function of the load
/// `load` (an expression); returns the name of the efficiency definition.
pub fn emit(
    model: &mut Model,
    prefix: &str,
    curve: &Curve,
    load: &str,
    what: &str,
) -> Result<String, ImportError> {
    if curve.strategy == Strategy::Linear {
        return Ok(emit_map(model, prefix, curve, load, what));
    }
    let n = curve.x.len();
    for k in 0..n {
        model.field(
            &format!("{prefix}_x{k}"),
            curve.x[k],
            "-",
            &format!("{what}: load grid point {k}"),
            &curve.x_path(k),
        )?;
    }
    for k in 0..n {
        model.field(
            &format!("{prefix}_e{k}"),
            curve.y[k],
            "-",
            &format!("{what}: efficiency at grid point {k}"),
            &curve.y_path(k),
        )?;
    }
    let x = format!("{prefix}_X");
    model.def(
        &x,
        &format!("min(max({load}, {prefix}_x0), {prefix}_x{})", n - 1),
        "-",
        &format!("{what}: load as the fraction FASTSim looks up, clamped to the grid"),
    );
    let eff = format!("eff_{prefix}");
    let sum = chunked_sum(model, prefix, step_terms(prefix, n, &x));
    let doc = format!(
        "{what}, FASTSim's step-wise interpolation of its table (the grid point at or below the load)"
    );
    model.def(&eff, &sum, "-", &doc);
    Ok(eff)
}

/// A linear table as the map `{prefix}_map` (its doc names the FASTSim field) and `eff_{prefix}` calling it.
fn emit_map(model: &mut Model, prefix: &str, curve: &Curve, load: &str, what: &str) -> String {
    let name = format!("{prefix}_map");
    model.maps.push(LinearMap {
        name: name.clone(),
        args: vec!["load".to_string()],
        x: curve.x.clone(),
        y: Vec::new(),
        values: curve.y.clone(),
        unit: "-".to_string(),
        doc: format!(
            "{what} over the load fraction, linear between the points as FASTSim interpolates it; FASTSim `{}` \
             (x: `data.grid[0]`, values: `data.values`)",
            curve.path
        ),
    });
    let eff = format!("eff_{prefix}");
    let doc = format!(
        "{what}, FASTSim's linear interpolation of its table (held at the end values outside it)"
    );
    model.def(&eff, &format!("{name}({load})"), "-", &doc);
    eff
}

/// The table's efficiency at zero load as an expression of what [`emit`] wrote under `prefix`: the map at 0
/// (linear) or the first value (step-wise, whose grid starts at zero load).
pub fn at_zero_load(prefix: &str, curve: &Curve) -> String {
    match curve.strategy {
        Strategy::Linear => format!("{prefix}_map(0)"),
        Strategy::StepLower => format!("{prefix}_e0"),
    }
}

/// The steps of the step-wise interpolant.
fn step_terms(prefix: &str, n: usize, x: &str) -> Vec<String> {
    let mut terms = vec![format!("{prefix}_e0")];
    for k in 1..n {
        terms.push(format!(
            "({p}_e{k} - {p}_e{km})*(1 - max(sign({p}_x{k} - {x}), 0))",
            p = prefix,
            km = k - 1
        ));
    }
    terms
}

/// The sum of `terms`, split into partial-sum definitions of at most CHUNK terms when long.
fn chunked_sum(model: &mut Model, prefix: &str, terms: Vec<String>) -> String {
    if terms.len() <= CHUNK {
        return terms.join(" + ");
    }
    let mut parts = Vec::new();
    for (j, chunk) in terms.chunks(CHUNK).enumerate() {
        let name = format!("{prefix}_sum{j}");
        model.def(
            &name,
            &chunk.join(" + "),
            "-",
            "partial sum of the efficiency interpolant",
        );
        parts.push(name);
    }
    parts.join(" + ")
}
