//! `invsim derive`: a model's relative degree, normal form, ψ⁻¹, α, β and zero dynamics (of every mode, for a
//! model with operating modes).

use std::path::Path;

use invsim_inversion::{ModalModel, ModelFile};

use crate::error::{Failure, Warnings};
use crate::files::print_stdout;

pub use crate::derive_format::Format;

pub fn run(path: &Path, format: Format, warnings: Warnings) -> Result<(), Failure> {
    if let Some(m) = read_modal(path)? {
        return derive_modal(m, format, warnings);
    }
    let d = invsim_inversion::derive_file(path).map_err(|e| Failure::user(e.to_string()))?;
    d.check_printable()
        .map_err(|e| Failure::user(e.to_string()))?;
    warnings.check(&d.warnings)?;
    let text = match format {
        Format::Text => d.to_text(),
        Format::Json => {
            let mut s = serde_json::to_string_pretty(&d.to_json())
                .map_err(|e| Failure::io(e.to_string()))?;
            s.push('\n');
            s
        }
        Format::Markdown => d.to_markdown(),
    };
    print_stdout(&text)
}

/// The file read as a model with modes, or `None` for an ordinary model (then read as before).
fn read_modal(path: &Path) -> Result<Option<ModalModel>, Failure> {
    match ModelFile::from_path(path) {
        Ok(ModelFile::Modal(m)) => Ok(Some(*m)),
        Ok(ModelFile::Single(_)) => Ok(None),
        Err(e) => Err(Failure::user(e.to_string())),
    }
}

/// `invsim derive` of a model with modes.
fn derive_modal(
    mut m: ModalModel,
    format: crate::derive_format::Format,
    warnings: Warnings,
) -> Result<(), Failure> {
    let inputs: Vec<String> = m.inputs.iter().map(|i| i.name.clone()).collect();
    // What `derive` prints does not include the gradient's normal-form Jacobians.
    let modes = std::mem::take(&mut m.modes);
    let ds = invsim_loader::derive_modes(modes, &inputs, invsim_loader::Extent::Run)
        .map_err(|e| Failure::user(e.to_string()))?;
    let each: Vec<String> = ds
        .iter()
        .flat_map(|mode| {
            let name = &mode.header.name;
            mode.d
                .warnings
                .iter()
                .map(move |w| format!("mode `{name}`: {w}"))
        })
        .collect();
    warnings.check(&each)?;
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
                    .chain(
                        mode.decided
                            .iter()
                            .map(|i| format!("{} decided by the strategy", m.inputs[*i].name)),
                    )
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
