//! Constant parts of the model that are not finite at the parameters' values: a literal `1/0`, `m = -0.0`
//! under a division (β = 1/m = −inf), `sqrt(-1)`, `log(0)`. Such a subexpression — free of states and of
//! the input — makes f, g or h (and so α, β or the zero dynamics) infinite or NaN at every point, so the
//! derivation is refused with an error naming it, instead of printing `β = -inf`.
//!
//! For a state whose right-hand side is not affine in the input (contract §5), f = rhs|_{u=0} and
//! g = ∂rhs/∂u|_{u=0} are not what the method evaluates (it solves rhs(x, u) for u numerically or by
//! isolation), and they may be undefined where the rhs is not: thrust k_T·sqrt(P) has g = k_T/(2 sqrt(P))
//! = 1/0 at P = 0. There the whole rhs is checked, with the input left a symbol.
//!
//! One walk over the DAG in post-order (iterative, each node once): a node whose children are all finite
//! constants and whose own value is not finite is reported, with the parameters it holds.

use super::error::{ModelError, ModelErrorKind};
use super::expressions::{Item, Role};
use super::spanned::Reader;
use super::validated::{Output, State};
use invsim_expr::{pow_f64, Id, Node, Pool, Symbol};
use std::collections::HashMap;

impl Reader<'_> {
    /// Refuse the model, at the position of the expression that holds it, if a constant part of a state's f
    /// or g or of the output's h is not finite at the parameters' values.
    pub(super) fn check_finite(
        &self,
        pool: &Pool,
        nominal: &HashMap<Symbol, f64>,
        (states, output): (&[State], &Output),
        items: &[Item],
    ) -> Result<(), ModelError> {
        let position = |roles: &[Role]| {
            items
                .iter()
                .find(|it| roles.contains(&it.role))
                .and_then(|it| it.src.at(0))
        };
        let mut roots = Vec::with_capacity(2 * states.len() + 1);
        let mut at = Vec::with_capacity(roots.capacity());
        for (i, s) in states.iter().enumerate() {
            if !s.affine {
                roots.push((format!("the right-hand side of state `{}`", s.name), s.rhs));
                at.push(position(&[Role::Rhs(i)]));
                continue;
            }
            roots.push((format!("f of state `{}`", s.name), s.f));
            at.push(position(&[Role::Rhs(i), Role::F(i)]));
            roots.push((format!("g of state `{}`", s.name), s.g));
            at.push(position(&[Role::Rhs(i), Role::G(i)]));
        }
        roots.push((format!("the output `{}`", output.name), output.h));
        at.push(position(&[Role::H]));
        let Some((k, (what, expr, value, params))) =
            roots.iter().enumerate().find_map(|(k, root)| {
                non_finite_constant(pool, std::slice::from_ref(root), nominal)
                    .map(|found| (k, found))
            })
        else {
            return Ok(());
        };
        Err(self.err(
            at[k],
            ModelErrorKind::NonFinite,
            format!(
                "{what} holds `{expr}` = {value} at the parameters' values ({params}): it is not finite, so α, \
                 β or the zero dynamics would be infinite or NaN everywhere; correct the expression or the \
                 parameter values"
            ),
        ))
    }
}

/// Longest printed subexpression in the message, in characters.
const SHOWN_CHARS: usize = 200;

/// The first constant subexpression of the `roots` (named, in order) that is not finite at `nominal`:
/// (root name, the subexpression printed, its value, the parameters in it with their values).
pub(crate) fn non_finite_constant(
    pool: &Pool,
    roots: &[(String, Id)],
    nominal: &HashMap<Symbol, f64>,
) -> Option<(String, String, f64, String)> {
    let mut memo: HashMap<Id, Option<f64>> = HashMap::new();
    for (name, root) in roots {
        for id in pool.topological(&[*root]) {
            if memo.contains_key(&id) {
                continue;
            }
            let value = constant_value(pool, id, nominal, &memo);
            let children_finite = pool
                .children(id)
                .iter()
                .all(|c| memo.get(c).copied().flatten().is_some_and(f64::is_finite));
            memo.insert(id, value);
            if let Some(v) = value.filter(|v| !v.is_finite()) {
                if children_finite {
                    return Some((
                        name.clone(),
                        shown(pool, id),
                        v,
                        parameters(pool, id, nominal),
                    ));
                }
            }
        }
    }
    None
}

/// The value of `id` if it is free of states and the input (every child's value in `memo`).
fn constant_value(
    pool: &Pool,
    id: Id,
    nominal: &HashMap<Symbol, f64>,
    memo: &HashMap<Id, Option<f64>>,
) -> Option<f64> {
    let get = |c: &Id| memo.get(c).copied().flatten();
    Some(match pool.node(id) {
        Node::Num(n) => n.to_f64(),
        Node::Pi => std::f64::consts::PI,
        Node::Sym(s) => *nominal.get(s)?,
        Node::Add(ts) => ts.iter().map(get).sum::<Option<f64>>()?,
        Node::Mul(fs) => fs.iter().map(get).product::<Option<f64>>()?,
        Node::Pow(b, p) => pow_f64(get(b)?, pool.as_number(*p), get(p)?),
        Node::Call(f, a) => f.eval(get(a)?),
        Node::Call2(f, a, b) => f.eval(get(a)?, get(b)?),
        // A map's data are finite by construction (and may be replaced at run time): never reported.
        Node::Map(..) | Node::Map2(..) => return None,
    })
}

fn shown(pool: &Pool, id: Id) -> String {
    let text = pool.display(id);
    if text.chars().count() <= SHOWN_CHARS {
        text
    } else {
        let cut: String = text.chars().take(SHOWN_CHARS).collect();
        format!("{cut}…")
    }
}

/// `m = -0, k = 2` for the parameters in `id`, or `no parameters`.
fn parameters(pool: &Pool, id: Id, nominal: &HashMap<Symbol, f64>) -> String {
    let list: Vec<String> = pool
        .free_symbols(id)
        .iter()
        .filter_map(|s| {
            nominal
                .get(s)
                .map(|v| format!("{} = {v:?}", pool.symbol_name(*s)))
        })
        .collect();
    if list.is_empty() {
        "no parameters: a literal".to_string()
    } else {
        format!("parameters {}", list.join(", "))
    }
}
