//! `invsim derive`: a model's relative degree, normal form, ψ⁻¹, α, β and zero dynamics.

use std::path::Path;

use crate::error::Failure;
use crate::files::print_stdout;

pub use crate::derive_format::Format;

pub fn run(path: &Path, format: Format) -> Result<(), Failure> {
    if let Some(m) = crate::modal_cmd::read_modal(path)? {
        return crate::modal_cmd::derive(m, format);
    }
    let d = invsim_inversion::derive_file(path).map_err(|e| Failure::user(e.to_string()))?;
    d.check_printable()
        .map_err(|e| Failure::user(e.to_string()))?;
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
