//! Copying a model's parameter values onto a fresh instance of the same model.

use invsim_model_api::InverseModel;

use crate::LoadError;

/// Set on `to` every parameter value of `from` (the same model, the same parameter order) that differs from
/// `to`'s own: setting one recomputes every constant the parameters make, and a value set to itself would give
/// the same bits at that cost.
pub(crate) fn copy_parameters(
    from: &dyn InverseModel,
    to: &mut dyn InverseModel,
) -> Result<(), LoadError> {
    let made: Vec<f64> = to.params().to_vec();
    for ((name, &v), was) in from.info().parameters.iter().zip(from.params()).zip(made) {
        if v.to_bits() == was.to_bits() {
            continue;
        }
        to.set_param(name, v).map_err(|e| LoadError::Parameter {
            name: name.clone(),
            reason: e.to_string(),
        })?;
    }
    Ok(())
}
