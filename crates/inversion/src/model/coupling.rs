//! States a mode couples to the others (docs/reference.md §2.5, `couple = { s = "c(x)" }`): a clutch closed ties the
//! engine speed to the gearbox input speed, w_e = i_g i_f v / r_w, while with the clutch open w_e is a state of
//! its own, J_e dw_e/dt = T_e − T_load.
//!
//! Every mode keeps the model's whole state vector, so that a switch never changes its size and every state
//! stays continuous. In a mode that couples s to c(x) (c free of s, of the input and of the signals):
//! - every other expression takes c for s: rhs_j(x) ↦ rhs_j(x)|_{s = c(x)}, h, the definitions and the
//!   `[outputs]` likewise; the mode's physics sees s only through c;
//! - s itself follows the total derivative of its coupling along the mode's dynamics,
//!   ds/dt = Σ_{j uncoupled} ∂c/∂x_j · dx_j/dt, so s − c(x) is constant along the mode (zero where the mode is
//!   entered with s = c(x), which the run makes sure of: entering a coupling mode sets s to c(x), and reports
//!   the jump where there is one — the clutch closing with slip).
//!
//! In the normal form s is then an internal state η (nothing else depends on it) whose zero dynamics integrate
//! ċ; the coupling is also an extra output of the mode (`coupling_s`, after the fixed inputs), so that the
//! runtime can evaluate c(x) with either engine.

use super::error::ModelErrorKind;
use super::validated::Model;
use invsim_expr::{Id, Symbol};
use std::collections::HashMap;

/// The name of the definition and extra output that hold the coupling of state `state` in a mode.
pub fn coupling_name(state: &str) -> String {
    format!("coupling_{state}")
}

/// Why a coupling cannot be applied (the caller adds the file position).
pub(super) struct CouplingError {
    pub(super) kind: ModelErrorKind,
    pub(super) message: String,
}

/// Apply the couplings (state index, c) to the mode's model, c in the model's pool with definitions inlined.
pub(super) fn couple(
    model: &mut Model,
    couplings: &[(usize, Id)],
) -> Result<(), (usize, CouplingError)> {
    let coupled: Vec<Symbol> = couplings
        .iter()
        .map(|&(i, _)| model.states[i].symbol)
        .collect();
    let signals: Vec<Symbol> = model.signals.iter().map(|s| s.symbol).collect();
    let u = model.input.symbol;
    for (k, &(i, c)) in couplings.iter().enumerate() {
        let pool = &model.pool;
        let bad = |m: String| {
            (
                k,
                CouplingError {
                    kind: ModelErrorKind::Schema,
                    message: m,
                },
            )
        };
        let name = &model.states[i].name;
        if pool.depends_on_any(c, &coupled) {
            return Err(bad(format!(
                "the coupling of state `{name}` depends on a state the mode couples (`{name}` itself or another \
                 one); write it in the uncoupled states"
            )));
        }
        if pool.depends_on(c, u) {
            return Err(bad(format!(
                "the coupling of state `{name}` depends on the input `{}`; a state can be coupled to the other \
                 states only",
                model.input.name
            )));
        }
        if pool.depends_on_any(c, &signals) {
            return Err(bad(format!(
                "the coupling of state `{name}` depends on a signal; couplings may use the states and the \
                 parameters only"
            )));
        }
    }
    let map: HashMap<Symbol, Id> = couplings
        .iter()
        .map(|&(i, c)| (model.states[i].symbol, c))
        .collect();
    substitute_everywhere(model, &map);
    for &(i, c) in couplings {
        follow_coupling(model, i, c);
    }
    Ok(())
}

/// s ↦ c(x) in every uncoupled state's equation, the output, the definitions and the extra outputs.
fn substitute_everywhere(model: &mut Model, map: &HashMap<Symbol, Id>) {
    let Model {
        pool,
        states,
        output,
        outputs,
        definitions,
        ..
    } = model;
    for s in states.iter_mut().filter(|s| !map.contains_key(&s.symbol)) {
        s.rhs = pool.substitute(s.rhs, map);
        s.f = pool.substitute(s.f, map);
        s.g = pool.substitute(s.g, map);
    }
    output.h = pool.substitute(output.h, map);
    for o in outputs.iter_mut() {
        o.expr = pool.substitute(o.expr, map);
    }
    for d in definitions.iter_mut() {
        d.inlined = pool.substitute(d.inlined, map);
    }
}

/// State `i` follows its coupling: ds/dt = Σ_j ∂c/∂x_j · dx_j/dt over the uncoupled states (whose
/// equations no longer contain a coupled state), split into f + g·u like any right-hand side.
fn follow_coupling(model: &mut Model, i: usize, c: Id) {
    let Model {
        pool,
        states,
        input,
        ..
    } = model;
    let (mut f_terms, mut g_terms, mut rhs_terms) = (Vec::new(), Vec::new(), Vec::new());
    let mut affine = true;
    for (j, s) in states.iter().enumerate() {
        if j == i || !pool.depends_on(c, s.symbol) {
            continue;
        }
        let dc = pool.diff(c, s.symbol);
        f_terms.push(pool.mul2(dc, s.f));
        g_terms.push(pool.mul2(dc, s.g));
        rhs_terms.push(pool.mul2(dc, s.rhs));
        affine &= s.affine;
    }
    let (f, g) = (pool.add(&f_terms), pool.add(&g_terms));
    let rhs = if affine {
        let u = pool.var(input.symbol);
        let gu = pool.mul2(g, u);
        pool.add2(f, gu)
    } else {
        pool.add(&rhs_terms)
    };
    let s = &mut states[i];
    (s.f, s.g, s.rhs, s.affine) = (f, g, rhs, affine);
}
