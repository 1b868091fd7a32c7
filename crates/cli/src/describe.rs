//! The model's own one-line description in the summaries of `simulate` and `forward`: the first sentence of
//! the model file's `description`, right after the summary's `model:` line, so that a reader sees what the
//! numbers belong to (for `si_engine`: a one-gear car without brake or idle).

use invsim_inversion::model::Model;
use std::path::Path;

/// The first sentence of `description` (up to the first ". "), or all of it.
fn first_sentence(description: &str) -> &str {
    let d = description.trim();
    match d.find(". ") {
        Some(i) => &d[..i],
        None => d.trim_end_matches('.'),
    }
}

/// `summary` with a `description:` line after its first line (`model: NAME`) when the model file has a
/// description; `summary` unchanged otherwise. The file was read and derived before the run, so reading it
/// again does not fail in practice; if it does, the summary is printed without the line.
pub fn with_description(summary: &str, model: &Path) -> String {
    let description = Model::from_path(model).ok().and_then(|m| m.description);
    let Some(description) = description.filter(|d| !d.trim().is_empty()) else {
        return summary.to_string();
    };
    let line = format!("description: {}\n", first_sentence(&description));
    match summary.split_once('\n') {
        Some((first, rest)) if first.starts_with("model:") => format!("{first}\n{line}{rest}"),
        _ => format!("{line}{summary}"),
    }
}
