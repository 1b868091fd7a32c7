//! Definitions: the graph of which definition uses which (no cycles, only earlier definitions used), and
//! their inlining into one expression pool — symbols in a fixed order (parameters, definitions, states,
//! input), each definition replaced by its expression with every earlier definition already inlined.

use super::error::{ModelError, ModelErrorKind};
use super::expressions::{Item, Role};
use super::maps::RawMap;
use super::names::{NameRef, Names};
use super::raw::{RawDefinition, RawInput, RawModel, RawParameter, RawState};
use super::signals::RawSignal;
use super::spanned::Reader;
use super::validated::{Definition, Parameter};
use invsim_expr::limits::{MAX_DEPTH, MAX_POOL_NODES};
use invsim_expr::{Id, MapDecl, Pool, Symbol};
use std::collections::HashMap;

/// For each definition, the definitions its expression uses, with the offset of each use.
pub(super) type Uses = Vec<Vec<(usize, Option<usize>)>>;

/// The definitions `item` uses, with the offset of each use.
pub(super) fn def_uses(item: &Item, names: &Names<'_>) -> Vec<(usize, Option<usize>)> {
    item.ast
        .identifiers()
        .into_iter()
        .filter_map(|(name, span)| match names.get(name) {
            Some(&(_, NameRef::Definition(j))) => Some((j, item.src.at(span.start))),
            _ => None,
        })
        .collect()
}

impl Reader<'_> {
    /// The graph of definition uses, checked: no cycles, and only earlier definitions used.
    pub(super) fn definition_graph(
        &self,
        raw: &RawModel,
        names: &Names<'_>,
        items: &[Item],
    ) -> Result<Uses, ModelError> {
        let ndef = raw.definitions.len();
        let mut uses: Vec<Vec<(usize, Option<usize>)>> = vec![Vec::new(); ndef];
        let def_item: HashMap<usize, usize> = items
            .iter()
            .enumerate()
            .filter_map(|(k, it)| match it.role {
                Role::Definition(i) => Some((i, k)),
                _ => None,
            })
            .collect();
        for (i, u) in uses.iter_mut().enumerate() {
            if let Some(&k) = def_item.get(&i) {
                *u = def_uses(&items[k], names);
            }
        }
        if let Some(cycle) = find_cycle(&uses) {
            let path: Vec<&str> = cycle
                .iter()
                .map(|&i| raw.definitions[i].name.as_str())
                .collect();
            let at = uses[cycle[0]]
                .iter()
                .find(|(j, _)| *j == cycle[1])
                .and_then(|&(_, at)| at);
            return Err(self.err(
                at,
                ModelErrorKind::CircularDefinition,
                format!("circular definition: {}", path.join(" -> ")),
            ));
        }
        for (i, u) in uses.iter().enumerate() {
            if let Some(&(j, at)) = u.iter().find(|&&(j, _)| j > i) {
                let (a, b) = (&raw.definitions[i].name, &raw.definitions[j].name);
                return Err(self.err(
                    at,
                    ModelErrorKind::DefinitionOrder,
                    format!(
                        "definition `{a}` uses `{b}`, which is defined later ({}); definitions may use only \
                         earlier ones, so move `{b}` above `{a}`",
                        self.line(raw.definitions[j].at)
                    ),
                ));
            }
        }
        Ok(uses)
    }
}

/// The model's expressions in one pool, with every definition inlined.
pub(super) struct Interned {
    pub(super) pool: Pool,
    pub(super) parameters: Vec<Parameter>,
    /// The parameters' default values.
    pub(super) nominal: HashMap<Symbol, f64>,
    /// The input's symbol, its variable, and the substitution u → 0.
    pub(super) u: Symbol,
    pub(super) u_var: Id,
    pub(super) u_zero: HashMap<Symbol, Id>,
    pub(super) zero: Id,
    /// Each expression as written, by role.
    by_role: HashMap<Role, Id>,
    /// Each definition's symbol → its inlined expression.
    pub(super) inline: HashMap<Symbol, Id>,
    pub(super) definitions: Vec<Definition>,
    /// Each definition's symbol → its index in `definitions`.
    pub(super) def_symbols: HashMap<Symbol, usize>,
}

impl Interned {
    /// The expression as written for `role` (0 if there is none).
    pub(super) fn expr_of(&self, role: Role) -> Id {
        self.by_role.get(&role).copied().unwrap_or(self.zero)
    }

    /// Intern every expression and inline the definitions in order (each uses only earlier ones); a
    /// definition that after inlining nests deeper than [`MAX_DEPTH`] levels, or that takes the model's
    /// expressions past [`MAX_POOL_NODES`] distinct nodes, is an error.
    pub(super) fn new(
        raw_parameters: Vec<RawParameter>,
        raw_definitions: Vec<RawDefinition>,
        states: &[RawState],
        (input, signals): (&RawInput, &[RawSignal]),
        maps: &[RawMap],
        items: &[Item],
    ) -> Result<Interned, TooLargeDefinition> {
        // Symbols in a fixed order: parameters, definitions, states, input, signals; maps declared before any
        // call.
        let mut pool = Pool::new();
        for m in maps {
            pool.declare_map(MapDecl::new(&m.name, m.data.clone()));
        }
        let parameters: Vec<Parameter> = raw_parameters
            .into_iter()
            .map(|p| Parameter {
                symbol: pool.symbol(&p.name),
                name: p.name,
                value: p.value,
                unit: p.unit,
                doc: p.doc,
            })
            .collect();
        let nominal: HashMap<Symbol, f64> =
            parameters.iter().map(|p| (p.symbol, p.value)).collect();
        for d in &raw_definitions {
            pool.symbol(&d.name);
        }
        for s in states {
            pool.symbol(&s.name);
        }
        let u = pool.symbol(&input.name);
        for s in signals {
            pool.symbol(&s.name);
        }
        let u_var = pool.var(u);
        let zero = pool.zero();
        let u_zero: HashMap<Symbol, Id> = HashMap::from([(u, zero)]);

        let mut by_role: HashMap<Role, Id> = HashMap::new();
        for item in items {
            let id = pool.from_ast(&item.ast);
            by_role.insert(item.role, id);
        }
        let mut interned = Interned {
            pool,
            parameters,
            nominal,
            u,
            u_var,
            u_zero,
            zero,
            by_role,
            inline: HashMap::new(),
            definitions: Vec::with_capacity(raw_definitions.len()),
            def_symbols: HashMap::new(),
        };
        interned.inline_definitions(raw_definitions)?;
        Ok(interned)
    }

    /// Inline definitions in order (each uses only earlier ones).
    fn inline_definitions(
        &mut self,
        raw_definitions: Vec<RawDefinition>,
    ) -> Result<(), TooLargeDefinition> {
        for (i, d) in raw_definitions.into_iter().enumerate() {
            let symbol = self.pool.symbol(&d.name);
            let expr = self.expr_of(Role::Definition(i));
            let inlined = self.pool.substitute(expr, &self.inline);
            let depth = self.pool.depth(inlined);
            let nodes = self.pool.len();
            if depth > MAX_DEPTH || nodes > MAX_POOL_NODES {
                return Err(TooLargeDefinition {
                    name: d.name,
                    at: d.at,
                    depth,
                    nodes,
                });
            }
            self.inline.insert(symbol, inlined);
            self.definitions.push(Definition {
                name: d.name,
                symbol,
                source: d.src.text,
                expr,
                inlined,
                unit: d.unit,
                doc: d.doc,
            });
        }
        self.def_symbols = self
            .definitions
            .iter()
            .enumerate()
            .map(|(i, d)| (d.symbol, i))
            .collect();
        Ok(())
    }
}

/// A definition that is too large once every earlier definition is inlined into it.
#[derive(Debug)]
pub(super) struct TooLargeDefinition {
    name: String,
    at: Option<usize>,
    /// Its nesting depth after inlining.
    depth: u32,
    /// Distinct nodes of the model's expressions so far.
    nodes: usize,
}

impl Reader<'_> {
    /// The model error for a definition over a size budget, naming it, its size and the limit.
    pub(super) fn too_large_definition(&self, t: TooLargeDefinition) -> ModelError {
        let what = if t.depth > MAX_DEPTH {
            format!(
                "nests {} levels deep once the definitions it uses are inlined (limit {MAX_DEPTH})",
                t.depth
            )
        } else {
            format!(
                "takes the model's expressions to {} distinct nodes once the definitions it uses are \
                 inlined (limit {MAX_POOL_NODES})",
                t.nodes
            )
        };
        self.err(
            t.at,
            ModelErrorKind::Expression,
            format!(
                "definition `{}` {what}; a chain of definitions each built on the previous one is too \
                 long: write the model with fewer nested definitions",
                t.name
            ),
        )
    }
}

/// A cycle in the definition graph, rotated to start at its earliest definition and closed
/// (`[a, b, a]`), or `None`.
fn find_cycle(uses: &[Vec<(usize, Option<usize>)>]) -> Option<Vec<usize>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    let n = uses.len();
    let mut mark = vec![Mark::New; n];
    for root in 0..n {
        if mark[root] != Mark::New {
            continue;
        }
        // Iterative depth-first search: (node, next edge index), with the open path on the stack.
        let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
        mark[root] = Mark::Open;
        while let Some(&mut (v, ref mut next)) = stack.last_mut() {
            if let Some(&(w, _)) = uses[v].get(*next) {
                *next += 1;
                match mark.get(w).copied() {
                    Some(Mark::New) => {
                        mark[w] = Mark::Open;
                        stack.push((w, 0));
                    }
                    Some(Mark::Open) => {
                        let from = stack.iter().position(|&(x, _)| x == w).unwrap_or(0);
                        let mut cycle: Vec<usize> = stack[from..].iter().map(|&(x, _)| x).collect();
                        let first = cycle
                            .iter()
                            .enumerate()
                            .min_by_key(|&(_, &x)| x)
                            .map_or(0, |(k, _)| k);
                        cycle.rotate_left(first);
                        cycle.push(cycle[0]);
                        return Some(cycle);
                    }
                    _ => {}
                }
            } else {
                mark[v] = Mark::Done;
                stack.pop();
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cycles() {
        let uses = vec![vec![(1, None)], vec![(2, None)], vec![(1, None)]];
        assert_eq!(find_cycle(&uses), Some(vec![1, 2, 1]));
        let uses = vec![vec![(0, None)]];
        assert_eq!(find_cycle(&uses), Some(vec![0, 0]));
        let uses = vec![vec![], vec![(0, None)], vec![(0, None), (1, None)]];
        assert_eq!(find_cycle(&uses), None);
    }
}
