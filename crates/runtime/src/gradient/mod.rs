//! Exact parameter gradients of a run's summary figures (`invsim simulate --gradient`): the derivative of
//! each number the summary prints — every accumulated output's integral, its per-100-km figure and the
//! headline's figures — with respect to the model's parameters and to the grid values of its maps
//! ([`grid_values`]: `bsfc[3,4]`; a map is linear in its values, so each one's column of the partial
//! derivatives is built at every point from the map calls' columns, [`grid_columns`], and is then a
//! parameter like the others).
//!
//! For r = n the input and the states are closed-form (or implicitly defined) functions of the smoothed cycle
//! and the parameters, so their derivatives follow from the model's symbolic partial derivatives by the chain
//! rule at every sample ([`point`]; each of the run's blocks as the run solves it where there are no internal
//! states, [`direct`]); for r < n the internal states' sensitivities ∂η/∂p are advanced over
//! each of the run's integrator steps of η as the run takes them, by the Gauss–Legendre method ([`pass`],
//! [`gauss`]), or, where
//! unstable zero dynamics are inverted stably (non-causally), the bounded solution of the collocation
//! equations is differentiated by the implicit function theorem ([`stable`]); the figures are differentiated
//! through the run's own quadrature and formulas ([`figures`]). [`GradientError`] says why a run is not
//! differentiated.

mod closed_jacobian;
mod derivatives;
mod direct;
pub mod error;
mod figures;
mod gauss;
pub mod grid_columns;
pub mod grid_values;
pub mod modal;
mod pass;
mod point;
mod sample;
mod stable;

use std::fmt::Write as _;

use invsim_model_api::map::Map;
use invsim_model_api::{InverseModel, ModelInfo};
use serde::Serialize;

pub(crate) use closed_jacobian::{ClosedJacobian, Rows as ClosedRows};
pub use derivatives::Derivatives;
pub(crate) use direct::DirectSensitivities;
pub use error::GradientError;
pub use figures::Figures;
pub(crate) use figures::{figures, Integrals, Wrt};
pub(crate) use gauss::{Gauss, Singular};
pub use grid_columns::GridColumns;
pub use grid_values::{GridValue, MAX_GRID_VALUES};
pub use modal::{resolve_modal, resolve_modal_with_maps, GearParameters, ModalParam, ModalWrt};
pub(crate) use pass::{Along, Sensitivities, Wanted};
pub(crate) use point::{Buffers, Direction, Point};
pub(crate) use stable::StableFigures;

use crate::report::fmt_sig;

/// The derivatives `names` asks for: `all` parameters, or those named (in the model's order, each once), and
/// the grid values of `maps` named ([`grid_values`]; `all` does not include them).
pub fn resolve(
    info: &ModelInfo,
    maps: &[&Map],
    names: &[String],
) -> Result<Derivatives, GradientError> {
    let (grid, names) = grid_values::split(maps, names)?;
    let params = resolve_params(info, &names).map_err(|e| grid_values::with_maps(e, maps))?;
    Ok(Derivatives { params, grid })
}

/// The parameters `names` asks for: `all` of them, or those named (in the model's order, each once).
fn resolve_params(info: &ModelInfo, names: &[String]) -> Result<Vec<usize>, GradientError> {
    if names.len() == 1 && names[0] == "all" && !info.parameters.iter().any(|p| p == "all") {
        return Ok((0..info.parameters.len()).collect());
    }
    let mut out: Vec<usize> = Vec::with_capacity(names.len());
    for name in names {
        let Some(i) = info.parameters.iter().position(|p| p == name) else {
            return Err(GradientError::UnknownParameter {
                name: name.clone(),
                known: info.parameters.join(", "),
            });
        };
        if out.contains(&i) {
            return Err(GradientError::Duplicate { name: name.clone() });
        }
        out.push(i);
    }
    out.sort_unstable();
    Ok(out)
}

/// The summary's `gradient` block: d figure/d parameter, `{"FIGURE": {"PARAM": value}}`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Gradient {
    pub figures: Figures,
}

impl Gradient {
    /// Summary text: one row per parameter, one column per figure.
    pub fn write_text(&self, s: &mut String) {
        let Some(first) = self.figures.values().next() else {
            return;
        };
        let params: Vec<&String> = first.keys().collect();
        let names: Vec<&String> = self.figures.keys().collect();
        let cell = |f: &String, p: &String| {
            self.figures[f]
                .get(p)
                .map_or("-".to_string(), |v| fmt_sig(*v, 4))
        };
        let pw = params.iter().map(|p| p.len()).max().unwrap_or(0).max(9);
        let widths: Vec<usize> = names
            .iter()
            .map(|f| {
                params
                    .iter()
                    .map(|p| cell(f, p).len())
                    .max()
                    .unwrap_or(0)
                    .max(f.len())
            })
            .collect();
        let _ = writeln!(s, "gradient (d figure / d parameter):");
        let _ = write!(s, "  {:pw$}", "parameter");
        for (f, w) in names.iter().zip(&widths) {
            let _ = write!(s, "  {f:>w$}");
        }
        s.push('\n');
        for p in &params {
            let _ = write!(s, "  {p:pw$}");
            for (f, w) in names.iter().zip(&widths) {
                let _ = write!(s, "  {:>w$}", cell(f, p));
            }
            s.push('\n');
        }
    }
}

/// Everything the gradient of a finished run needs besides the model and the reference.
pub(crate) struct RunFigures<'a> {
    pub accumulate: &'a [usize],
    pub integrals: &'a [f64],
    pub distance_m: f64,
    /// The integrals' derivatives the run summed as it went ([`Sensitivities`] of a causal run,
    /// [`DirectSensitivities`] of one without internal states).
    pub along_run: Option<Vec<Vec<f64>>>,
    /// The stable inversion of a non-causal run and its reported samples.
    pub stable: Option<StableFigures<'a>>,
}

/// The gradient of a finished run (causal, r = n or stable) with respect to `wrt`.
pub(crate) fn of_run<M: InverseModel + ?Sized>(
    model: &M,
    wrt: &Derivatives,
    along: &Along<'_>,
    run: RunFigures<'_>,
    opts: &crate::inverse::SimulationOptions,
) -> Result<Gradient, crate::inverse::SimulateError> {
    let info = model.info();
    let params = wrt.columns(info.parameters.len());
    let grid = GridColumns::new(model.maps(), &wrt.grid);
    let wanted = Wanted {
        model,
        params: &params,
        grid: &grid,
        accumulate: run.accumulate,
    };
    let derivatives = match (run.stable, run.along_run) {
        (Some(st), _) => stable::integral_gradients(&wanted, along, st)?,
        (None, Some(summed)) => summed,
        // Grid values of a run without internal states, whose columns are built from the map calls at every
        // point: point by point.
        (None, None) => pass::pointwise_integrals(model, (wrt, along), opts)?,
    };
    let integrals = Integrals {
        accumulate: run.accumulate,
        values: run.integrals,
        derivatives: &derivatives,
    };
    let names = wrt.names(info);
    let by = Wrt {
        names: &names,
        params: &params,
        values: model.params(),
    };
    Ok(Gradient {
        figures: figures(info, &by, &integrals, run.distance_m),
    })
}
