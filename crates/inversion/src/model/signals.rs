//! The optional `[signals]` table (contract §5): exogenous, time-varying quantities the model does not control
//! (road grade, head wind, auxiliary load), known over the whole cycle in advance.
//!
//! ```toml
//! [signals]
//! grade = { default = 0.0, column = "grade", unit = "-", doc = "road grade, rise over run" }
//! P_aux = 500.0                      # a plain number is the default
//! ```
//!
//! A signal S is a symbol like a state; its smoothed time derivatives S_d1 … S_d9 are reserved names (they
//! appear in derived expressions, never in a model file).

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::spanned::Reader;
use super::tree::{get, key_at, tv_at, Entries, Kind};

/// Highest derivative order k of a signal's reserved name `S_dk`.
pub const MAX_SIGNAL_DERIVATIVE: usize = 9;

/// The reserved name of the k-th time derivative of signal `name` (k ≥ 1): `name_dk`.
pub fn derivative_name(name: &str, k: usize) -> String {
    format!("{name}_d{k}")
}

/// If `name` is `S_dk` with 1 ≤ k ≤ 9 for one of `signals`, that signal's name.
pub(super) fn reserved_derivative<'s>(
    name: &str,
    signals: impl Iterator<Item = &'s str>,
) -> Option<&'s str> {
    let (base, k) = name.rsplit_once("_d")?;
    let k: usize = k
        .parse()
        .ok()
        .filter(|_| k.bytes().all(|b| b.is_ascii_digit()))?;
    if !(1..=MAX_SIGNAL_DERIVATIVE).contains(&k) {
        return None;
    }
    signals.into_iter().find(|s| *s == base)
}

/// A signal as written.
#[derive(Debug)]
pub(super) struct RawSignal {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    pub(super) default: Option<f64>,
    pub(super) column: Option<String>,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
}

impl Reader<'_> {
    /// `[signals]`: each entry a number (its default) or a table `{ default, column, unit, doc }`.
    pub(super) fn signals(&self, entries: &Entries) -> Result<Vec<RawSignal>, ModelError> {
        let mut out = Vec::new();
        for (k, v) in entries {
            let what = format!("signal `{}`", k.name.escape_debug());
            let at = key_at(k);
            let s = match &v.kind {
                Kind::Int(_) | Kind::Float(_) => RawSignal {
                    name: k.name.clone(),
                    at,
                    default: Some(self.number(v, &format!("the default of {what}"))?),
                    column: None,
                    unit: None,
                    doc: None,
                },
                Kind::Table(t) => {
                    self.known_keys(t, keys::SIGNAL, &what)?;
                    let column = self.optional_string(t, "column", &what)?;
                    if column.as_deref().is_some_and(|c| c.trim().is_empty()) {
                        return Err(self.err(
                            get(t, "column").and_then(tv_at),
                            ModelErrorKind::Schema,
                            format!("{what}'s `column` is empty; name the cycle file's column"),
                        ));
                    }
                    RawSignal {
                        name: k.name.clone(),
                        at,
                        default: get(t, "default")
                            .map(|d| self.number(d, &format!("the default of {what}")))
                            .transpose()?,
                        column,
                        unit: self.optional_string(t, "unit", &what)?,
                        doc: self.optional_string(t, "doc", &what)?,
                    }
                }
                other => {
                    return Err(self.err(
                        tv_at(v),
                        ModelErrorKind::Schema,
                        format!(
                            "{what} must be a number (its default) or a table {{ default = …, column = \"…\", \
                             unit = \"…\", doc = \"…\" }}; found {}",
                            other.type_name()
                        ),
                    ))
                }
            };
            out.push(s);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reserved_derivative_names() {
        let s = ["grade", "P_aux"];
        assert_eq!(
            reserved_derivative("grade_d1", s.into_iter()),
            Some("grade")
        );
        assert_eq!(
            reserved_derivative("P_aux_d9", s.into_iter()),
            Some("P_aux")
        );
        assert_eq!(reserved_derivative("grade_d10", s.into_iter()), None);
        assert_eq!(reserved_derivative("grade_d0", s.into_iter()), None);
        assert_eq!(reserved_derivative("grade_dx", s.into_iter()), None);
        assert_eq!(reserved_derivative("slope_d1", s.into_iter()), None);
    }
}
