//! Turning generated tokens into a source file: parsed with `syn`, formatted with `prettyplease`, headed with
//! the `@generated` line, and with explanatory comments placed above the lines they explain.

use crate::error::CodegenError;
use proc_macro2::TokenStream;

/// Parse `tokens` as a Rust file and format it.
///
/// `comments` are (line, comment) pairs: `// comment` is inserted, with the line's indentation, above every
/// formatted line equal to `line` after trimming (prettyplease drops ordinary comments, so they are added to
/// the text afterwards). The result is parsed once more to make sure it is still Rust.
pub(crate) fn format_file(
    tokens: TokenStream,
    header: &str,
    comments: &[(String, String)],
    what: &str,
) -> Result<String, CodegenError> {
    let file: syn::File = syn::parse2(tokens).map_err(|e| CodegenError::Syntax {
        what: what.to_string(),
        message: e.to_string(),
    })?;
    let text = prettyplease::unparse(&file);
    let mut out = String::with_capacity(text.len() + header.len() + 256);
    out.push_str(header);
    if !header.ends_with('\n') {
        out.push('\n');
    }
    for line in text.lines() {
        let trimmed = line.trim_start();
        for (at, comment) in comments {
            if trimmed == at {
                let indent = &line[..line.len() - trimmed.len()];
                out.push_str(indent);
                out.push_str("// ");
                out.push_str(comment);
                out.push('\n');
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    syn::parse_file(&out).map_err(|e| CodegenError::Syntax {
        what: what.to_string(),
        message: e.to_string(),
    })?;
    Ok(out)
}
