//! The title and the per-mode headings of a model with operating modes in `derive`'s text and Markdown, the
//! same lines in the generated documents (`docs/models/`), so the two renderings cannot drift apart.

/// `model NAME with N modes` (the first line).
pub fn modal_title(model: &str, modes: usize) -> String {
    format!("model {model} with {modes} modes\n")
}

/// A coupling in a mode heading: `w_e coupled to w_c`.
pub fn coupling_text(state: &str, coupling: &str) -> String {
    format!("{state} coupled to {coupling}")
}

/// `== mode NAME (role R, free input U, V = e, …) ==` before each mode's derivation; `fixed` are the other
/// inputs with the values the mode gives them.
pub fn mode_heading(mode: &str, role: &str, free_input: &str, fixed: &[String]) -> String {
    format!(
        "\n== mode {mode} (role {role}, free input {free_input}, {}) ==\n",
        fixed.join(", ")
    )
}
