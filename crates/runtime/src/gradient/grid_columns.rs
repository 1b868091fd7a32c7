//! A grid value's column of the partial derivatives at a point: the derivatives of ψ's ξ rows, of φ, of the
//! internal states' right-hand sides and of the outputs with respect to one grid value v_ij of a map, which the
//! chain rule ([`super::point`]) then treats exactly as a parameter's column ∂/∂p.
//!
//! A map's value is linear in its grid values: M_dIJ(a, b) = Σ_ij v_ij Φ_i^(I)(a) Ψ_j^(J)(b) (the tensor
//! product of the smoothed hat functions, `invsim_kernel::map`; plain (bi)linear interpolation and the
//! `linear`/`clamp` continuations are linear in the values too). So for a row E with the map calls
//! c = M_dIJ(a_c, b_c) (the model's `ModelInfo::map_calls`, `invsim_model_api::sensitivity`):
//!
//! ```text
//! ∂E/∂v_ij = Σ_c ∂E/∂[c] · Φ_i^(I_c)(a_c) Ψ_j^(J_c)(b_c)
//! ```
//!
//! ∂E/∂[c] and (a_c, b_c) come from the model's `sensitivity`; the weights Φ_i^(I)(a) Ψ_j^(J)(b) from the map
//! in use (`Map::weights`, nonzero for the few grid values around the point), so a point costs one basis per
//! call and one product per row and weight, whatever the number of grid values asked for.

use invsim_model_api::map::Map;
use invsim_model_api::{MapCall, SensitivityLayout};

use super::grid_values::GridValue;

/// The grid values of one model (one mode of a model with modes) that a run is differentiated by: for each
/// of the model's maps, the column of each of its values (`None`: not asked for).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GridColumns {
    count: usize,
    slots: Vec<Vec<Option<usize>>>,
}

impl GridColumns {
    /// The columns 0 … `values.len()` − 1 of `values` among the model's `maps` (by name; a value of a map the
    /// model does not have has no column here: its derivatives are 0 in this model).
    pub fn new(maps: &[Map], values: &[GridValue]) -> GridColumns {
        let mut slots: Vec<Vec<Option<usize>>> = maps.iter().map(|_| Vec::new()).collect();
        for (g, v) in values.iter().enumerate() {
            if let Some(m) = maps.iter().position(|m| m.name() == v.map) {
                let s = &mut slots[m];
                s.resize(maps[m].values().len(), None);
                s[v.index] = Some(g);
            }
        }
        GridColumns {
            count: values.len(),
            slots,
        }
    }

    /// The number of columns.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True without grid values.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// `out[row · len + g]` = ∂row/∂v_g (the module documentation) from the model's partial derivatives
    /// `sens` (laid out as `layout`) with the calls `calls` of the maps `maps`; `weights` is scratch.
    pub(crate) fn fill(
        &self,
        (maps, calls): (&[Map], &[MapCall]),
        (layout, sens): (&SensitivityLayout, &[f64]),
        weights: &mut Vec<(usize, f64)>,
        out: &mut Vec<f64>,
    ) {
        let (rows, g) = (layout.rows(), self.count);
        out.clear();
        out.resize(rows * g, 0.0);
        for (c, call) in calls.iter().enumerate() {
            let Some(slots) = self.slots.get(call.map).filter(|s| !s.is_empty()) else {
                continue;
            };
            let at = layout.arguments(c);
            maps[call.map].weights(&sens[at..at + 2], call.orders, weights);
            for &(k, w) in weights.iter() {
                let Some(col) = slots[k] else {
                    continue;
                };
                for row in 0..rows {
                    out[row * g + col] += sens[layout.at(row, layout.call(c))] * w;
                }
            }
        }
    }
}
