//! An efficiency table as model text: its grid points and values become parameters (docs naming their FASTSim
//! fields) and the interpolation an exact expression in `[outputs]`-only definitions — piecewise linear as a
//! hinge sum, e(X) = e_0 + s_0 (X − x_0) + Σ_k (s_k − s_{k−1}) max(X − x_k, 0) with s_k the slope of segment k,
//! step-wise ("Step: Lower") as e(X) = e_0 + Σ_k (e_k − e_{k−1}) (1 − max(sign(x_k − X), 0)), which takes the
//! value e_k on [x_k, x_{k+1}) exactly as FASTSim does; X is the load clamped to the grid.

use crate::curve::{Curve, Strategy};
use crate::error::ImportError;
use crate::model::Model;

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
    let terms = match curve.strategy {
        Strategy::Linear => linear_terms(model, prefix, n, &x),
        Strategy::StepLower => step_terms(prefix, n, &x),
    };
    let eff = format!("eff_{prefix}");
    let sum = chunked_sum(model, prefix, terms);
    let kind = match curve.strategy {
        Strategy::Linear => "linear interpolation",
        Strategy::StepLower => "step-wise interpolation (the grid point at or below the load)",
    };
    model.def(
        &eff,
        &sum,
        "-",
        &format!("{what}: efficiency, FASTSim's {kind} of the table"),
    );
    Ok(eff)
}

/// Slopes s_k as definitions and the hinge terms of the linear interpolant.
fn linear_terms(model: &mut Model, prefix: &str, n: usize, x: &str) -> Vec<String> {
    for k in 0..n - 1 {
        model.def(
            &format!("{prefix}_s{k}"),
            &format!(
                "({p}_e{k1} - {p}_e{k})/({p}_x{k1} - {p}_x{k})",
                p = prefix,
                k1 = k + 1
            ),
            "-",
            &format!("slope of segment {k} of the efficiency table"),
        );
    }
    let mut terms = vec![format!("{prefix}_e0 + {prefix}_s0*({x} - {prefix}_x0)")];
    for k in 1..n - 1 {
        terms.push(format!(
            "({p}_s{k} - {p}_s{km})*max({x} - {p}_x{k}, 0)",
            p = prefix,
            km = k - 1
        ));
    }
    terms
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
