//! Undefined parts of the model's expressions as written: every expression (definitions, right-hand sides,
//! f, g, h, extra outputs) is walked bottom-up, and the first sub-expression that is undefined is reported
//! at its line and column, as the user wrote it, before any simplification could multiply it away:
//!
//! * a constant part (numbers, π, parameters at their values, constant definitions) whose value is not
//!   finite: `0/0`, `1/0`, `0^(-1)`, `log(0)`, `sqrt(-1)`, `1/m` with `m = 0`, `1e300*1e300`; the
//!   innermost such part is named, so `0*(1/0)` reports `1/0`;
//! * a part that simplifies to an undefined expression (`invsim_expr::undefined`): `(v-v)/(v-v)` is `0/0`
//!   for every v, `u/(1-1)` divides by zero.
//!
//! Values are computed as every evaluator in invsim computes them (`pow_f64`, `Func::eval`), so what is
//! refused here is what would be infinite or NaN at run time.

use super::error::{ModelError, ModelErrorKind};
use super::expressions::Item;
use super::spanned::Reader;
use invsim_expr::{pow_f64, Ast, AstKind, BinOp, Func, Func2, Id, Pool, Symbol};
use std::collections::HashMap;

/// An undefined sub-expression found in one expression: its byte range in the expression and why.
struct Found {
    span: std::ops::Range<usize>,
    why: String,
}

/// What an expression's names stand for: parameters at their values, constant definitions at theirs, and
/// every definition for its inlined expression (`0/d` with `d = v - v` is 0/0, not 0·d⁻¹ = 0).
struct Values<'a> {
    nominal: &'a HashMap<Symbol, f64>,
    definitions: HashMap<Symbol, f64>,
    inline: &'a HashMap<Symbol, Id>,
}

impl Values<'_> {
    fn of(&self, pool: &Pool, name: &str) -> Option<f64> {
        if name == "pi" {
            return Some(std::f64::consts::PI);
        }
        let s = pool.find_symbol(name)?;
        self.nominal
            .get(&s)
            .or_else(|| self.definitions.get(&s))
            .copied()
    }
}

impl Reader<'_> {
    /// Refuse the model at the first undefined sub-expression of any expression as written (file order);
    /// `what[k]` names `items[k]` ("state `v`'s rhs"), `definitions` gives each definition item's symbol.
    pub(super) fn check_defined(
        &self,
        pool: &mut Pool,
        (nominal, inline): (&HashMap<Symbol, f64>, &HashMap<Symbol, Id>),
        items: &[Item],
        (what, definitions): (&[String], &[Option<Symbol>]),
    ) -> Result<(), ModelError> {
        let mut values = Values {
            nominal,
            definitions: HashMap::new(),
            inline,
        };
        // Definitions first, in order (each uses only earlier ones), so that their values are known.
        let mut order: Vec<usize> = (0..items.len()).collect();
        order.sort_by_key(|&k| definitions[k].is_none());
        let mut first: Option<(Option<usize>, ModelError)> = None;
        for k in order {
            let item = &items[k];
            match walk(pool, &values, &item.ast) {
                Ok((_, value)) => {
                    if let (Some(s), Some(v)) = (definitions[k], value) {
                        values.definitions.insert(s, v);
                    }
                }
                Err(found) => {
                    let at = item.src.at(found.span.start);
                    let text = item.src.text.get(found.span.clone()).unwrap_or("");
                    let err = self.err(
                        at,
                        ModelErrorKind::NonFinite,
                        format!(
                            "{}: `{text}` {}; an undefined part is never simplified away (`0*(1/0)` is \
                             not 0), so correct the expression or the parameter values",
                            what[k], found.why
                        ),
                    );
                    if first.as_ref().is_none_or(|(a, _)| at < *a) {
                        first = Some((at, err));
                    }
                }
            }
        }
        match first {
            Some((_, err)) => Err(err),
            None => Ok(()),
        }
    }
}

/// The kinds of undefined value, for messages.
const CAUSES: &str =
    "a division by zero, a logarithm of zero or of a negative number, an even root of \
                      a negative number, or an overflow";

/// The node of `ast` interned in `pool` with its value if constant, or the first undefined part below it
/// (post-order, so the innermost). Recursion is bounded by the reader's nesting limit.
fn walk(pool: &mut Pool, values: &Values, ast: &Ast) -> Result<(Id, Option<f64>), Found> {
    let operands: Vec<&Ast> = match &ast.kind {
        AstKind::Num(_) | AstKind::Ident(_) => Vec::new(),
        AstKind::Neg(a) => vec![a],
        AstKind::Binary(_, a, b) => vec![a, b],
        AstKind::Call(_, args) => args.iter().collect(),
    };
    let mut ids = Vec::with_capacity(operands.len());
    let mut vals = Vec::with_capacity(operands.len());
    for a in operands {
        let (id, v) = walk(pool, values, a)?;
        ids.push(id);
        vals.push(v);
    }
    let mut id = pool.from_ast_node(ast, &ids);
    if let Some(&inlined) = pool.as_symbol(id).and_then(|s| values.inline.get(&s)) {
        id = inlined;
    }
    let value = value_of(pool, values, ast, &ids, &vals);
    if let Some(v) = value.filter(|v| !v.is_finite()) {
        return Err(Found {
            span: ast.span.clone(),
            why: format!(
                "= {v} at the parameters' values ({}): it is not finite ({CAUSES})",
                parameters(pool, values, ast)
            ),
        });
    }
    if pool.is_undefined(id) {
        return Err(Found {
            span: ast.span.clone(),
            why: format!(
                "is undefined: it simplifies to `{}`{}, which is not finite ({CAUSES})",
                shown(pool.display(id)),
                innermost(pool, id)
            ),
        });
    }
    Ok((id, value))
}

/// The value of a node whose operands have values `vals` (interned as `ids`), or `None` if it is not
/// constant.
fn value_of(
    pool: &Pool,
    values: &Values,
    ast: &Ast,
    ids: &[Id],
    vals: &[Option<f64>],
) -> Option<f64> {
    let all: Vec<f64> = vals.iter().copied().collect::<Option<Vec<f64>>>()?;
    Some(match &ast.kind {
        AstKind::Num(n) => n.to_f64(),
        AstKind::Ident(name) => values.of(pool, name)?,
        AstKind::Neg(_) => -all[0],
        AstKind::Binary(op, ..) => {
            let (a, b) = (all[0], all[1]);
            match op {
                BinOp::Add => a + b,
                BinOp::Sub => a - b,
                BinOp::Mul => a * b,
                BinOp::Div => a / b,
                BinOp::Pow => pow_f64(a, pool.as_number(ids[1]), b),
            }
        }
        AstKind::Call(name, _) => match name.as_str() {
            "sqrt" => all[0].sqrt(),
            "pow" => pow_f64(all[0], pool.as_number(ids[1]), all[1]),
            n => match (Func::from_name(n), Func2::from_name(n)) {
                (Some(f), _) => f.eval(all[0]),
                (None, Some(f)) => f.eval(all[0], all[1]),
                // A map's data are finite by construction (and may be replaced at run time).
                (None, None) => return None,
            },
        },
    })
}

/// ` (it holds `1/0` = inf)`: the innermost undefined part of `id` with its value, if it has one.
fn innermost(pool: &Pool, id: Id) -> String {
    let found = pool.topological(&[id]).into_iter().find_map(|n| {
        let v = pool.constant(n).filter(|v| !v.is_finite())?;
        let mut children_defined = true;
        pool.for_each_child(n, |c| children_defined &= !pool.is_undefined(c));
        children_defined.then_some((n, v))
    });
    match found {
        Some((n, v)) if n != id => format!(" (it holds `{}` = {v})", shown(pool.display(n))),
        _ => String::new(),
    }
}

/// At most 200 characters of a printed expression.
fn shown(text: String) -> String {
    const SHOWN_CHARS: usize = 200;
    if text.chars().count() <= SHOWN_CHARS {
        text
    } else {
        let cut: String = text.chars().take(SHOWN_CHARS).collect();
        format!("{cut}…")
    }
}

/// `parameters m = 0` for the parameters named in `ast`, or `no parameters: a literal`.
fn parameters(pool: &Pool, values: &Values, ast: &Ast) -> String {
    let mut list: Vec<String> = Vec::new();
    for (name, _) in ast.identifiers() {
        let Some(v) = pool.find_symbol(name).and_then(|s| values.nominal.get(&s)) else {
            continue;
        };
        let entry = format!("{name} = {v:?}");
        if !list.contains(&entry) {
            list.push(entry);
        }
    }
    if list.is_empty() {
        "no parameters: a literal".to_string()
    } else {
        format!("parameters {}", list.join(", "))
    }
}
