//! Decided inputs (docs/hybrids.md): a mode may leave an input to a strategy (`decided = ["T_m"]`). The mode's
//! model carries it as a signal whose value the strategy supplies per sample, so the inversion solves the free
//! input from y^(r) = y_d^(r) for every value of it with no other change. That holds only where the decided
//! input enters D^r h and no lower derivative: in D^k h with k < r the inverse would need its time
//! derivatives, which a per-sample choice does not have. This module checks it on a mode's derivation.

use crate::model::{ModelError, ModelErrorKind};
use crate::Derivation;

/// Refuse a decided input that enters D^k h for some k < r (the error at the mode's `decided` entry).
/// `decided` holds the decided inputs' names with where each is written (1-based line and column).
pub fn check_decided(
    mode: &str,
    decided: &[(String, Option<(usize, usize)>)],
    d: &Derivation,
) -> Result<(), ModelError> {
    let pool = &d.model.pool;
    for (name, at) in decided {
        let uses = |e: invsim_expr::Id| {
            pool.free_symbols(e).iter().any(|&s| {
                let n = pool.symbol_name(s);
                n == name
                    || n.strip_prefix(name.as_str())
                        .and_then(|rest| rest.strip_prefix("_d"))
                        .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
            })
        };
        if let Some(k) = (0..d.relative_degree).find(|&k| uses(d.lie[k])) {
            return Err(ModelError {
                file: d.model.file.clone(),
                line: at.map(|a| a.0),
                column: at.map(|a| a.1),
                message: format!(
                    "mode `{}` decides `{}`, which enters D^{k} h below the relative degree r = {}: the inverse \
                     would need its time derivatives, which a strategy's per-sample choice does not have; a \
                     decided input may enter only y^(r) (let it act through the r-th derivative, or make it \
                     the free input)",
                    mode.escape_debug(),
                    name.escape_debug(),
                    d.relative_degree
                ),
                kind: ModelErrorKind::Schema,
            });
        }
    }
    Ok(())
}
