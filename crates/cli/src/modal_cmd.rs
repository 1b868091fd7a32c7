//! What `derive`, `simulate` and `forward` do beside the single-mode path for a model with operating modes
//! (README "Modes"): the derivation of every mode, and the runtime's view of a loaded model with modes with
//! the gear schedule resolved for the cycle.

use std::path::Path;

use invsim_inversion::{ModalModel, ModelFile};
use invsim_loader::LoadedModal;
use invsim_runtime::modes::ModalSpec;
use invsim_runtime::Cycle;

use crate::error::Failure;
use crate::files::print_stdout;

/// The file read as a model with modes, or `None` for an ordinary model (then read as before).
pub fn read_modal(path: &Path) -> Result<Option<ModalModel>, Failure> {
    match ModelFile::from_path(path) {
        Ok(ModelFile::Modal(m)) => Ok(Some(*m)),
        Ok(ModelFile::Single(_)) => Ok(None),
        Err(e) => Err(Failure::user(e.to_string())),
    }
}

/// The runtime's view of `model` (loaded from `path`) for a run on `cycle` (`cycle_spec` as given: a
/// built-in name or the cycle file's path), its gear schedule resolved for that cycle.
pub fn spec<'m>(
    path: &Path,
    model: &'m LoadedModal,
    cycle: &Cycle,
    cycle_spec: &str,
) -> Result<ModalSpec<'m>, Failure> {
    let file = (!crate::cycle_spec::is_builtin(cycle_spec)).then(|| Path::new(cycle_spec));
    let gears = model
        .plant
        .gear_source(cycle, file)
        .map_err(|e| Failure::user(format!("{}: {e}", path.display())))?;
    Ok(model.plant.spec(gears))
}

/// `invsim derive` of a model with modes.
pub fn derive(mut m: ModalModel, format: crate::derive_format::Format) -> Result<(), Failure> {
    let ds = invsim_loader::derive_modes(std::mem::take(&mut m.modes))
        .map_err(|e| Failure::user(e.to_string()))?;
    let text = match format {
        crate::derive_format::Format::Json => {
            let v = invsim_loader::modal_derive_json(&m, &ds);
            let mut s = serde_json::to_string_pretty(&v).map_err(|e| Failure::io(e.to_string()))?;
            s.push('\n');
            s
        }
        f => {
            let mut s = invsim_inversion::render::modal_title(&m.name, ds.len());
            for mode in &ds {
                let (d, mode) = (&mode.d, &mode.header);
                let fixed: Vec<String> = mode
                    .fixed
                    .iter()
                    .map(|(i, e)| format!("{} = {e}", m.inputs[*i].name))
                    .chain(mode.coupled.iter().map(|(s, e)| {
                        invsim_inversion::render::coupling_text(&d.model.states[*s].name, e)
                    }))
                    .collect();
                s.push_str(&invsim_inversion::render::mode_heading(
                    &mode.name,
                    mode.role.as_str(),
                    &m.inputs[mode.free].name,
                    &fixed,
                ));
                s.push_str(&if f == crate::derive_format::Format::Markdown {
                    d.to_markdown()
                } else {
                    d.to_text()
                });
            }
            s
        }
    };
    print_stdout(&text)
}
