//! Typed values of the model file: a TOML value read as the table, string, finite number, boolean or
//! expression that a key expects, and unknown keys rejected, each error at the value's position.

use super::error::{ModelError, ModelErrorKind};
use super::spanned::{string_content, Reader, Src};
use super::tree::{get, key_at, Entries, Kind, Tv};

/// Is the decimal literal `text` (`1e-400`, `-0.5E-330`, `1_0e-999`) nonzero in its digits? Such a literal
/// that parses to 0 has underflowed.
pub(super) fn underflows(text: &str) -> bool {
    let mantissa = text.split(['e', 'E']).next().unwrap_or("");
    mantissa.chars().any(|c| matches!(c, '1'..='9'))
}

impl Reader<'_> {
    pub(super) fn table<'t>(&self, v: &'t Tv, what: &str) -> Result<&'t Entries, ModelError> {
        match &v.kind {
            Kind::Table(entries) => Ok(entries),
            k => Err(self.err(
                v.span.as_ref().map(|s| s.start),
                ModelErrorKind::Schema,
                format!("{what} must be a table, found {}", k.type_name()),
            )),
        }
    }

    pub(super) fn string(&self, v: &Tv, what: &str) -> Result<String, ModelError> {
        match &v.kind {
            Kind::Str(s) => Ok(s.clone()),
            k => Err(self.err(
                v.span.as_ref().map(|s| s.start),
                ModelErrorKind::Schema,
                format!("{what} must be a string, found {}", k.type_name()),
            )),
        }
    }

    pub(super) fn number(&self, v: &Tv, what: &str) -> Result<f64, ModelError> {
        let at = v.span.as_ref().map(|s| s.start);
        let x = match &v.kind {
            Kind::Int(i) => *i as f64,
            Kind::Float(x) => *x,
            k => {
                return Err(self.err(
                    at,
                    ModelErrorKind::Schema,
                    format!("{what} must be a number, found {}", k.type_name()),
                ))
            }
        };
        if !x.is_finite() {
            return Err(self.err(
                at,
                ModelErrorKind::NonFinite,
                format!("{what} must be finite, found {x}"),
            ));
        }
        let literal = v
            .span
            .as_ref()
            .and_then(|s| self.text.get(s.clone()))
            .unwrap_or("");
        if x == 0.0 && matches!(v.kind, Kind::Float(_)) && underflows(literal) {
            return Err(self.err(
                at,
                ModelErrorKind::NonFinite,
                format!(
                    "{what} `{literal}` is not zero but below the smallest floating-point number (about \
                     4.9e-324), so it would be read as 0; write 0 or a representable value"
                ),
            ));
        }
        Ok(x)
    }

    pub(super) fn boolean(&self, v: &Tv, what: &str) -> Result<bool, ModelError> {
        match &v.kind {
            Kind::Bool(b) => Ok(*b),
            k => Err(self.err(
                v.span.as_ref().map(|s| s.start),
                ModelErrorKind::Schema,
                format!("{what} must be true or false, found {}", k.type_name()),
            )),
        }
    }

    /// An expression value: a string (or, for convenience, a plain number).
    pub(super) fn expression(&self, v: &Tv, what: &str) -> Result<Src, ModelError> {
        let at = v.span.as_ref().map(|s| s.start);
        let text = match &v.kind {
            Kind::Str(s) => {
                let content = v
                    .span
                    .as_ref()
                    .and_then(|span| string_content(self.text, span, s));
                return Ok(Src {
                    text: s.clone(),
                    span: v.span.clone(),
                    content,
                });
            }
            Kind::Int(i) => i.to_string(),
            Kind::Float(x)
                if *x == 0.0
                    && underflows(
                        v.span
                            .as_ref()
                            .and_then(|s| self.text.get(s.clone()))
                            .unwrap_or(""),
                    ) =>
            {
                return Err(self.err(
                    at,
                    ModelErrorKind::NonFinite,
                    format!(
                        "{what} is not zero but below the smallest floating-point number (about \
                         4.9e-324), so it would be read as 0"
                    ),
                ));
            }
            Kind::Float(x) if x.is_finite() => format!("{x:?}"),
            Kind::Float(x) => {
                return Err(self.err(
                    at,
                    ModelErrorKind::NonFinite,
                    format!("{what} must be finite, found {x}"),
                ));
            }
            k => {
                return Err(self.err(
                    at,
                    ModelErrorKind::Schema,
                    format!(
                        "{what} must be an expression in a string, e.g. \"-k*x1 + u\"; found {}",
                        k.type_name()
                    ),
                ))
            }
        };
        Ok(Src {
            text,
            span: v.span.clone(),
            content: None,
        })
    }

    pub(super) fn optional_string(
        &self,
        entries: &Entries,
        key: &str,
        what: &str,
    ) -> Result<Option<String>, ModelError> {
        get(entries, key)
            .map(|v| self.string(v, &format!("{what}'s `{key}`")))
            .transpose()
    }

    /// Reject keys not in `allowed`.
    pub(super) fn known_keys(
        &self,
        entries: &Entries,
        allowed: &[&str],
        what: &str,
    ) -> Result<(), ModelError> {
        for (k, _) in entries {
            if !allowed.contains(&k.name.as_str()) {
                let list: Vec<String> = allowed.iter().map(|a| format!("`{a}`")).collect();
                return Err(self.err(
                    key_at(k),
                    ModelErrorKind::Schema,
                    format!(
                        "unknown key `{}` in {what}; expected {}",
                        k.name.escape_debug(),
                        list.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }
}
