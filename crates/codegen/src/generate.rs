//! One derived model to one formatted Rust file: the generated module with its `@generated` header.

use crate::error::{CodegenError, Error};
use crate::format::{self, header};
use crate::model;
use invsim_inversion::Derivation;
use std::path::Path;

/// Formatted Rust source for one derived model: a header line and `pub mod <name> { … }`.
///
/// `source_name` names the model file in the header and the docs (a file name, so the output does not depend
/// on where the file was read from).
pub fn generate(d: &Derivation, source_name: &str) -> Result<String, CodegenError> {
    let out = model::module(d, source_name)?;
    format::format_file(
        out.tokens,
        &header(source_name, &d.model.source_hash),
        &out.comments,
        &d.model.name,
    )
}

/// Load and derive a model file; return its Rust source and its Markdown derivation
/// ([`Derivation::to_markdown`]; for a model with operating modes every mode's, see
/// [`crate::ModalDerivation::to_markdown`]).
pub fn generate_file(path: &Path) -> Result<(String, String), Error> {
    let file =
        invsim_inversion::ModelFile::from_path(path).map_err(invsim_inversion::Error::from)?;
    let name = source_name(path);
    let model = match file {
        invsim_inversion::ModelFile::Single(model) => model,
        invsim_inversion::ModelFile::Modal(m) => {
            let md = crate::modal::ModalDerivation::new(*m)?;
            return Ok((crate::modal::generate_modal(&md, &name)?, md.to_markdown()));
        }
    };
    let d = Derivation::new(*model).map_err(invsim_inversion::Error::from)?;
    let rust = generate(&d, &name)?;
    Ok((rust, d.to_markdown()))
}

/// The file name of a model path, for headers and docs.
pub(crate) fn source_name(path: &Path) -> String {
    path.file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}
