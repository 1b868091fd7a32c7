//! What a run is differentiated by: model parameters and grid values of its maps, and the columns they take
//! in the chain rule.

use invsim_model_api::ModelInfo;

use super::grid_values::GridValue;

/// What a run is differentiated by: model parameters (indices, in the model's order) and grid values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Derivatives {
    pub params: Vec<usize>,
    pub grid: Vec<GridValue>,
}

impl Derivatives {
    /// Every derivative's column in the chain rule ([`super::point`]): the parameters', then grid value g's at
    /// P + g (P the model's number of parameters).
    pub(crate) fn columns(&self, n_params: usize) -> Vec<usize> {
        let grid = (0..self.grid.len()).map(|g| n_params + g);
        self.params.iter().copied().chain(grid).collect()
    }

    /// Every derivative's name, in [`Derivatives::columns`]' order.
    pub(crate) fn names(&self, info: &ModelInfo) -> Vec<String> {
        let params = self.params.iter().map(|&k| info.parameters[k].clone());
        params
            .chain(self.grid.iter().map(|g| g.name.clone()))
            .collect()
    }
}
