//! The engine map under the operating points (the model file's `[engine] map`, docs/reference.md §2.1): its
//! expression in the engine's speed and torque compiled to a tape over those two, with the model's current
//! parameters (`--set`) and maps (`--map`), and sampled at the centres of a grid of cells over the panel's area
//! where the torque is positive.
//! Both engines give the same layer: it is built from the model's [`ModelInfo`](invsim_model_api::ModelInfo),
//! parameters and maps, not from either engine's code.

use std::fmt;
use std::sync::Arc;

use invsim_expr::{MapDecl, Pool, Symbol, Tape};
use invsim_model_api::InverseModel;

use super::error::PlotError;

/// Cells of the sampled map along the speed and the torque axis.
pub(super) const CELLS: [usize; 2] = [72, 48];

/// The engine map of a model: what it shows and how to evaluate it at an operating point.
#[derive(Clone)]
pub struct MapLayer {
    /// The colour bar's label: the expression and its unit.
    pub label: String,
    /// The colour scale's ends, if the model file gives them (`map_range`).
    pub range: Option<[f64; 2]>,
    /// (speed, torque) → the map's value, specialised to the model's parameters.
    tape: Arc<Tape>,
}

impl fmt::Debug for MapLayer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MapLayer")
            .field("label", &self.label)
            .finish_non_exhaustive()
    }
}

impl PartialEq for MapLayer {
    fn eq(&self, other: &MapLayer) -> bool {
        self.label == other.label && Arc::ptr_eq(&self.tape, &other.tape)
    }
}

impl MapLayer {
    /// The layer of `model`'s `[engine] map`, `None` for a model without one.
    pub fn of(model: &dyn InverseModel) -> Result<Option<MapLayer>, PlotError> {
        let info = model.info();
        let Some(engine) = &info.engine else {
            return Ok(None);
        };
        let Some(map) = &engine.map else {
            return Ok(None);
        };
        let name = |i: usize| info.outputs.get(i).map(|o| o.name.as_str());
        let (Some(speed), Some(torque)) = (name(engine.speed), name(engine.torque)) else {
            return Err(PlotError::EngineMap(
                "the engine's speed or torque is not among the model's outputs".to_string(),
            ));
        };
        let mut pool = Pool::new();
        for m in model.maps() {
            pool.declare_map(MapDecl::new(m.name(), Arc::new(m.clone())));
        }
        let mut inputs: Vec<Symbol> = vec![pool.symbol(speed), pool.symbol(torque)];
        inputs.extend(info.parameters.iter().map(|p| pool.symbol(p)));
        let id = pool
            .parse(&map.expr)
            .map_err(|e| PlotError::EngineMap(format!("`{}`: {}", map.expr, e.message)))?;
        let tape = Tape::compile(&pool, &[id], &inputs)
            .map_err(|e| PlotError::EngineMap(format!("`{}`: {e}", map.expr)))?
            .specialize(model.params());
        let label = match &map.unit {
            Some(u) => format!("{} ({u})", map.expr),
            None => map.expr.clone(),
        };
        Ok(Some(MapLayer {
            label,
            range: map.range,
            tape: Arc::new(tape),
        }))
    }

    /// The map's value at engine speed `speed` and torque `torque` (in the units of the two outputs).
    pub fn eval(&self, speed: f64, torque: f64) -> f64 {
        let mut out = [0.0];
        self.tape.eval_parts(&[&[speed, torque]], &mut out);
        out[0]
    }

    /// The map sampled at the centres of [`CELLS`] cells over [x0, x1] × [y0, y1], row by row from the lowest
    /// torque: NaN where the expression is not finite and at zero or negative torque, where an engine map
    /// (fuel flow, BSFC, efficiency of the engine delivering power) has no meaning — a motored engine with its
    /// fuel cut off. A map with `extrapolate = "error"` evaluated outside its grid leaves no violation behind:
    /// the plot is no run.
    pub(super) fn sample(&self, (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Vec<f64> {
        let [nx, ny] = CELLS;
        let mut values = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            let y = y0 + (j as f64 + 0.5) / ny as f64 * (y1 - y0);
            for i in 0..nx {
                let x = x0 + (i as f64 + 0.5) / nx as f64 * (x1 - x0);
                values.push(if y > 0.0 { self.eval(x, y) } else { f64::NAN });
            }
        }
        let _ = invsim_model_api::map::take_violation();
        values
    }
}
