//! The affine split: each state's right-hand side becomes dx/dt = f(x) + g(x)·u with f = rhs|_{u=0} and
//! g = ∂rhs/∂u, checked affine (∂²rhs/∂u² identically zero by [`invsim_expr::zero_test`] at the nominal
//! parameter values); given f and g, and the output's h, must be free of the input (Fröberg & Nielsen
//! 2004, eq. 24: x' = f(x) + g(x)u, y = h(x)).

use super::definitions::Interned;
use super::error::{ModelError, ModelErrorKind};
use super::expressions::{Item, Role};
use super::raw::{RawEquation, RawExtra, RawOutput, RawState};
use super::spanned::Reader;
use super::validated::{ExtraOutput, Output, State};
use invsim_expr::{zero_test, Id, Pool, Symbol};
use std::collections::HashMap;

/// Does `e` really depend on the input `u` (not just syntactically): ∂e/∂u ≢ 0?
fn depends_on_input(pool: &mut Pool, e: Id, u: Symbol, nominal: &HashMap<Symbol, f64>) -> bool {
    if !pool.depends_on(e, u) {
        return false;
    }
    let d = pool.diff(e, u);
    !zero_test(pool, d, nominal).is_zero()
}

/// Where an expression depends on the input: its own use of `u`, or a definition that brings it in.
fn input_dependency(m: &Interned, item: &Item, input: &str) -> (Option<usize>, String) {
    let ids = item.ast.identifiers();
    if let Some((_, span)) = ids.iter().find(|(n, _)| *n == input) {
        return (item.src.at(span.start), String::new());
    }
    for (n, span) in &ids {
        if let Some(sym) = m.pool.find_symbol(n) {
            if let Some(&j) = m.def_symbols.get(&sym) {
                if m.pool.depends_on(m.definitions[j].inlined, m.u) {
                    return (
                        item.src.at(span.start),
                        format!(" through definition `{n}`"),
                    );
                }
            }
        }
    }
    (item.src.at(0), String::new())
}

/// Where the expression of `role` depends on the input, if it was written in the file.
fn dependency_of(m: &Interned, items: &[Item], role: Role, input: &str) -> (Option<usize>, String) {
    match items.iter().find(|it| it.role == role) {
        Some(item) => input_dependency(m, item, input),
        None => (None, String::new()),
    }
}

/// rhs → (f, g, None): f = rhs|_{u=0}, g = ∂rhs/∂u|_{u=0} when ∂²rhs/∂u² ≡ 0; a right-hand side that is
/// not affine in the input (contract §5) is kept whole: (rhs|_{u=0}, ∂rhs/∂u|_{u=0}, Some(rhs)).
fn split_rhs(i: usize, m: &mut Interned) -> (Id, Id, Option<Id>) {
    let rhs = m.pool.substitute(m.expr_of(Role::Rhs(i)), &m.inline);
    let f = m.pool.substitute(rhs, &m.u_zero);
    let g = m.pool.diff(rhs, m.u);
    let g2 = m.pool.diff(g, m.u);
    let nonaffine = !zero_test(&mut m.pool, g2, &m.nominal).is_zero();
    (f, m.pool.substitute(g, &m.u_zero), nonaffine.then_some(rhs))
}

impl Reader<'_> {
    /// States: each split into f + g u.
    pub(super) fn split_states(
        &self,
        raw_states: Vec<RawState>,
        input: &str,
        m: &mut Interned,
        items: &[Item],
    ) -> Result<Vec<State>, ModelError> {
        let mut states = Vec::with_capacity(raw_states.len());
        for (i, s) in raw_states.into_iter().enumerate() {
            let symbol = m.pool.symbol(&s.name);
            let (f, g, nonaffine) = match &s.equation {
                RawEquation::Rhs(_) => split_rhs(i, m),
                RawEquation::Fg(..) => {
                    let (f, g) = self.given_fg(&s, i, input, m, items)?;
                    (f, g, None)
                }
            };
            let affine = nonaffine.is_none();
            let rhs = match nonaffine {
                Some(rhs) => rhs,
                None => {
                    let gu = m.pool.mul2(g, m.u_var);
                    m.pool.add2(f, gu)
                }
            };
            states.push(State {
                name: s.name,
                symbol,
                unit: s.unit,
                doc: s.doc,
                rhs,
                f,
                g,
                initial: s.initial,
                affine,
            });
        }
        Ok(states)
    }

    /// Given f and g: each inlined and checked free of the input.
    fn given_fg(
        &self,
        s: &RawState,
        i: usize,
        input: &str,
        m: &mut Interned,
        items: &[Item],
    ) -> Result<(Id, Id), ModelError> {
        let mut fg = [m.zero; 2];
        for (slot, role, which) in [(0, Role::F(i), "f"), (1, Role::G(i), "g")] {
            let e = m.pool.substitute(m.expr_of(role), &m.inline);
            if depends_on_input(&mut m.pool, e, m.u, &m.nominal) {
                let (at, via) = dependency_of(m, items, role, input);
                return Err(self.err(
                    at,
                    ModelErrorKind::StateFunctionDependsOnInput,
                    format!(
                        "state `{}`'s {which} depends on the input `{}`{via}; f and g must be functions \
                         of the states (dx/dt = f(x) + g(x)·{}), or write the state as rhs = \"…\"",
                        s.name, input, input
                    ),
                ));
            }
            fg[slot] = m.pool.substitute(e, &m.u_zero);
        }
        Ok((fg[0], fg[1]))
    }

    /// The output: h(x), free of the input.
    pub(super) fn split_output(
        &self,
        output: RawOutput,
        input: &str,
        m: &mut Interned,
        items: &[Item],
    ) -> Result<Output, ModelError> {
        let h = m.pool.substitute(m.expr_of(Role::H), &m.inline);
        if depends_on_input(&mut m.pool, h, m.u, &m.nominal) {
            let (at, via) = dependency_of(m, items, Role::H, input);
            return Err(self.err(
                at,
                ModelErrorKind::OutputDependsOnInput,
                format!(
                    "the output's h depends on the input `{}`{via}; h may depend on the states only (the method \
                     needs y = h(x)); report input-dependent signals in [outputs]",
                    input
                ),
            ));
        }
        let h = m.pool.substitute(h, &m.u_zero);
        Ok(Output {
            name: output.name,
            h,
            source: output.h.text,
            unit: output.unit,
            doc: output.doc,
            nominal: output.nominal,
            reference_offset: output.reference_offset.unwrap_or(0.0),
            reference_scale: output.reference_scale.unwrap_or(1.0),
        })
    }
}

/// The extra outputs, definitions inlined (they may use the input). `per_distance` defaults to `accumulate` in
/// a model that tracks the cycle's speed itself (`tracks_speed`: the identity reference map), else to false.
pub(super) fn extra_outputs(
    outputs: Vec<RawExtra>,
    tracks_speed: bool,
    m: &mut Interned,
) -> Vec<ExtraOutput> {
    outputs
        .into_iter()
        .enumerate()
        .map(|(i, e)| ExtraOutput {
            expr: m.pool.substitute(m.expr_of(Role::Extra(i)), &m.inline),
            name: e.name,
            source: e.src.text,
            unit: e.unit,
            doc: e.doc,
            accumulate: e.accumulate,
            per_distance: e.per_distance.unwrap_or(e.accumulate && tracks_speed),
        })
        .collect()
}
