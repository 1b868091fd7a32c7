//! Whether a `--cycle` argument names a built-in cycle or a cycle file, answered from the names alone.
//!
//! `Cycle::builtin` builds the cycle it finds (the NEDC from four ECE-15s and an EUDC); the checks a command
//! makes before it loads the cycle (which inputs are files, what the provenance records) need only the answer.

use invsim_runtime::Cycle;

/// Is `spec` a name `Cycle::builtin` accepts (trimmed, ASCII case ignored: it lower-cases and matches the
/// names of `Cycle::builtin_names`)?
pub fn is_builtin(spec: &str) -> bool {
    let lower = spec.trim().to_ascii_lowercase();
    Cycle::builtin_names().contains(&lower.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The answer is `Cycle::builtin(spec).is_some()` for every name, in other cases, padded, and for names
    /// that are not built in.
    #[test]
    fn agrees_with_building_the_cycle() {
        let mut specs: Vec<String> = Vec::new();
        for name in Cycle::builtin_names() {
            specs.push(name.to_string());
            specs.push(name.to_ascii_uppercase());
            specs.push(format!("  {name}\t"));
            specs.push(format!("{name}x"));
            specs.push(format!("{name}.csv"));
        }
        specs.extend(
            [
                "",
                " ",
                "nedc2",
                "wltc3",
                "wltc3b-",
                "cycles/nedc.csv",
                "ＮＥＤＣ",
                "nedc\u{0}",
            ]
            .map(String::from),
        );
        for spec in &specs {
            assert_eq!(is_builtin(spec), Cycle::builtin(spec).is_some(), "`{spec}`");
        }
        assert!(is_builtin("NEDC") && is_builtin(" wltc3b-extra-high "));
        assert!(!is_builtin("../shared/cycles/udds.csv"));
    }
}
