//! Names in a model file: identifiers `[A-Za-z_][A-Za-z0-9_]*`, reserved names (`t`, `pi`, `yr`, `xi<N>`,
//! `eta<N>`, the functions of the expression language), collisions between declarations and with the
//! result columns (`t`, `yd_N`, `etaN`), and "did you mean" hints by Levenshtein distance.

use super::error::{ModelError, ModelErrorKind};
use super::signals::reserved_derivative;
use super::spanned::Reader;
use invsim_expr::FUNCTIONS;
use std::collections::HashMap;

pub(super) fn is_identifier(s: &str) -> bool {
    let mut cs = s.chars();
    matches!(cs.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && cs.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `prefix` followed by one or more digits.
pub(super) fn is_indexed(s: &str, prefix: &str) -> bool {
    s.strip_prefix(prefix)
        .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Why a name is reserved, if it is.
pub(super) fn reserved_reason(name: &str) -> Option<String> {
    if name == "t" {
        return Some("`t` is reserved for time".into());
    }
    if name == "pi" {
        return Some("`pi` is the constant π".into());
    }
    if name == "yr" {
        return Some("`yr` is reserved for the r-th derivative of the output, y^(r)".into());
    }
    if is_indexed(name, "xi") || is_indexed(name, "eta") {
        return Some(format!(
            "`{name}` is reserved for the normal-form coordinates xi1 … xiN, eta1 … etaN"
        ));
    }
    if FUNCTIONS.iter().any(|(f, _)| *f == name) {
        return Some(format!("`{name}` is a function of the expression language"));
    }
    None
}

/// Optimal-string-alignment distance (Damerau–Levenshtein without repeated edits of one substring): the
/// fewest insertions, deletions, substitutions and swaps of two neighbouring characters that turn `a` into
/// `b` (Wagner & Fischer 1974 with Damerau's 1964 transposition), for "did you mean" hints.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    // d[i][j]: distance between a[..i] and b[..j]; two rows back are kept for the swap.
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let sub = d[i - 1][j - 1] + usize::from(a[i - 1] != b[j - 1]);
            let mut best = sub.min(d[i - 1][j] + 1).min(d[i][j - 1] + 1);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = best;
        }
    }
    d[a.len()][b.len()]
}

/// Whether `declared` is close enough to `unknown` to be suggested for it: the same name in another case,
/// or at most one edit ([`edit_distance`], case ignored) per four characters of the longer name. A short
/// name's letters carry its meaning (`Q_b` and `I_b` are a charge and a current, `C_d` and `C_r` two
/// coefficients), so names of three characters or fewer are suggested only for a case difference; names
/// of 4–7 characters for one edit, 8–11 for two.
fn close_enough(unknown: &str, declared: &str) -> bool {
    let longer = unknown.chars().count().max(declared.chars().count());
    edit_distance(&unknown.to_lowercase(), &declared.to_lowercase()) * 4 <= longer
}

/// What a declared name is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum NameRef {
    Parameter(usize),
    Definition(usize),
    State(usize),
    Input,
    /// A lookup map of `[maps]` (contract §6).
    Map(usize),
    Signal(usize),
}

impl NameRef {
    pub(super) fn describe(self) -> &'static str {
        match self {
            NameRef::Parameter(_) => "a parameter",
            NameRef::Definition(_) => "a definition",
            NameRef::State(_) => "a state",
            NameRef::Input => "the input",
            NameRef::Map(_) => "a map",
            NameRef::Signal(_) => "a signal",
        }
    }
}

/// A declared name close to an unknown one ([`close_enough`]), if exactly one is closest.
pub(super) fn suggestion<'n>(
    unknown: &str,
    names: impl Iterator<Item = &'n str>,
) -> Option<&'n str> {
    let mut best: Vec<(usize, &str)> = names
        .filter(|n| close_enough(unknown, n))
        .map(|n| (edit_distance(unknown, n), n))
        .collect();
    best.sort();
    match best.as_slice() {
        [(d, n)] => Some(*n).filter(|_| *d > 0),
        [(d1, n), (d2, _), ..] if d1 < d2 => Some(*n),
        _ => None,
    }
}

/// A declared name: the name, the offset of its declaration, and what it declares.
pub(super) type Declaration<'r> = (&'r str, Option<usize>, NameRef);

/// The declared names, each with the offset of its declaration and what it declares.
pub(super) type Names<'r> = HashMap<&'r str, (Option<usize>, NameRef)>;

impl Reader<'_> {
    /// Check the declared names (identifiers, not reserved, unique), in file order.
    pub(super) fn declare<'r>(
        &self,
        mut decls: Vec<Declaration<'r>>,
    ) -> Result<Names<'r>, ModelError> {
        decls.sort_by_key(|&(_, at, _)| at.unwrap_or(usize::MAX));
        let mut names: HashMap<&str, (Option<usize>, NameRef)> = HashMap::new();
        for &(name, at, what) in &decls {
            if !is_identifier(name) {
                return Err(self.err(
                    at,
                    ModelErrorKind::InvalidName,
                    format!(
                        "invalid name `{}` for {}: names are identifiers [A-Za-z_][A-Za-z0-9_]*",
                        name.escape_debug(),
                        what.describe()
                    ),
                ));
            }
            if let Some(why) = reserved_reason(name) {
                return Err(self.err(
                    at,
                    ModelErrorKind::ReservedName,
                    format!(
                        "reserved name `{name}` cannot be declared as {}: {why}",
                        what.describe()
                    ),
                ));
            }
            if let Some(&(first_at, first)) = names.get(name) {
                return Err(self.err(
                    at,
                    ModelErrorKind::DuplicateName,
                    format!(
                        "duplicate name `{name}`: declared as {} at {} and again here as {}",
                        first.describe(),
                        self.place(first_at),
                        what.describe()
                    ),
                ));
            }
            names.insert(name, (at, what));
        }
        self.check_signal_derivatives(&decls)?;
        Ok(names)
    }

    /// The names `S_d1` … `S_d9` of a signal S are reserved for its derivatives: no declaration may take one.
    fn check_signal_derivatives(&self, decls: &[Declaration<'_>]) -> Result<(), ModelError> {
        let signals: Vec<&str> = decls
            .iter()
            .filter(|(_, _, w)| matches!(w, NameRef::Signal(_)))
            .map(|(n, _, _)| *n)
            .collect();
        for &(name, at, what) in decls {
            if let Some(s) = reserved_derivative(name, signals.iter().copied()) {
                return Err(self.err(
                    at,
                    ModelErrorKind::ReservedName,
                    format!(
                        "reserved name `{name}` cannot be declared as {}: the names {s}_d1 … {s}_d9 are \
                         reserved for the time derivatives of the signal `{s}`",
                        what.describe()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Extra outputs become CSV columns next to the states and the input: their names may not take a
    /// state's, the input's or another result column's.
    pub(super) fn check_columns<'e>(
        &self,
        names: &Names<'_>,
        outputs: impl Iterator<Item = (&'e str, Option<usize>)>,
    ) -> Result<(), ModelError> {
        for (name, at) in outputs {
            let clash = match names.get(name) {
                Some((_, NameRef::State(_))) => Some("a state"),
                Some((_, NameRef::Input)) => Some("the input"),
                Some((_, NameRef::Signal(_))) => Some("a signal"),
                _ if names.iter().any(|(s, (_, w))| {
                    matches!(w, NameRef::Signal(_))
                        && reserved_derivative(name, std::iter::once(*s)).is_some()
                }) =>
                {
                    Some("a column of signal derivatives (S_d1, S_d2, …)")
                }
                _ if name == "t" => Some("the time column `t`"),
                _ if is_indexed(name, "yd_") => {
                    Some("a column of output derivatives (yd_0, yd_1, …)")
                }
                _ if is_indexed(name, "eta") => Some("a column of internal states (eta1, eta2, …)"),
                _ => None,
            };
            if let Some(clash) = clash {
                return Err(self.err(
                    at,
                    ModelErrorKind::DuplicateName,
                    format!(
                        "output `{}` has the same name as {clash}; results are reported in columns by name, \
                         so choose another name",
                        name
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions() {
        let names = [
            "c1", "x1", "u", "I_b", "C_d", "m_veh", "eta_gear", "T_regen",
        ];
        let suggest = |n| suggestion(n, names.iter().copied());
        // Short names: another letter is another quantity, not a typo.
        assert_eq!(suggest("Q_b"), None);
        assert_eq!(suggest("C_r"), None);
        assert_eq!(suggest("c9"), None);
        assert_eq!(suggest("zz"), None);
        // A case difference is always a typo.
        assert_eq!(suggest("i_b"), Some("I_b"));
        assert_eq!(suggest("U"), Some("u"));
        // One edit in 4–7 characters, two in 8 or more; a swap of neighbours is one edit.
        assert_eq!(suggest("m_vej"), Some("m_veh"));
        assert_eq!(suggest("m_ehv"), None);
        assert_eq!(suggest("T_rgeen"), Some("T_regen"));
        assert_eq!(suggest("eta_ger"), Some("eta_gear"));
        assert_eq!(suggest("eta_gr"), Some("eta_gear"));
        assert_eq!(suggest("eta_g"), None);
        // Two names equally close: no suggestion.
        assert_eq!(suggestion("mass", ["mas", "masss"].into_iter()), None);
    }

    #[test]
    fn edit_distances() {
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("ab", "ba"), 1);
        assert_eq!(edit_distance("Q_b", "I_b"), 1);
        assert_eq!(edit_distance("ca", "abc"), 3);
    }
}
