//! The model's expressions: each one parsed in file order (not empty, at most [`MAX_EXPRESSION_LEN`] bytes
//! and [`MAX_EXPRESSION_NESTING`] levels deep, valid syntax, finite number literals, known names), with the
//! role it plays in the model (a definition, a state's rhs, f or g, the output's h, an extra output); and
//! `[engine]`'s `map`, whose names are the engine's speed and torque outputs, the parameters and the maps.

use super::error::{ModelError, ModelErrorKind};
use super::names::{reserved_reason, suggestion, Names};
use super::raw::{RawEquation, RawModel};
use super::spanned::{Reader, Src};
use super::values::underflows;
use invsim_expr::{parse_with_maps, Ast, AstKind};

/// Longest expression accepted, in bytes. Real model expressions are a few hundred characters; the limit
/// keeps every recursive pass over the expression (parsing, interning, differentiation) far from the
/// stack's end.
pub const MAX_EXPRESSION_LEN: usize = 4000;

/// Deepest nesting of parentheses and function calls accepted in an expression.
pub const MAX_EXPRESSION_NESTING: usize = 64;

/// Where an expression is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Role {
    Definition(usize),
    Rhs(usize),
    F(usize),
    G(usize),
    H,
    Extra(usize),
}

impl Role {
    /// Does an expression in this role enter f, g or h?
    pub(super) fn is_smooth_root(self) -> bool {
        matches!(self, Role::Rhs(_) | Role::F(_) | Role::G(_) | Role::H)
    }
}

/// One expression of the model, parsed.
pub(super) struct Item {
    pub(super) role: Role,
    pub(super) src: Src,
    pub(super) ast: Ast,
}

/// What an expression in `role` is, for messages ("state `x1`'s rhs").
pub(super) fn describe(raw: &RawModel, role: Role) -> String {
    match role {
        Role::Definition(i) => format!("definition `{}`", raw.definitions[i].name),
        Role::Rhs(i) => format!("state `{}`'s rhs", raw.states[i].name),
        Role::F(i) => format!("state `{}`'s f", raw.states[i].name),
        Role::G(i) => format!("state `{}`'s g", raw.states[i].name),
        Role::H => "the output's h".to_string(),
        Role::Extra(i) => format!("output `{}`", raw.outputs[i].name),
    }
}

impl Reader<'_> {
    /// Parse every expression of the model, in file order, and check that it uses only declared names.
    pub(super) fn parse_all(
        &self,
        raw: &RawModel,
        names: &Names<'_>,
    ) -> Result<Vec<Item>, ModelError> {
        let mut pending: Vec<(Role, &Src)> = Vec::new();
        pending.extend(
            raw.definitions
                .iter()
                .enumerate()
                .map(|(i, d)| (Role::Definition(i), &d.src)),
        );
        for (i, s) in raw.states.iter().enumerate() {
            match &s.equation {
                RawEquation::Rhs(r) => pending.push((Role::Rhs(i), r)),
                RawEquation::Fg(f, g) => {
                    pending.push((Role::F(i), f));
                    pending.push((Role::G(i), g));
                }
            }
        }
        pending.push((Role::H, &raw.output.h));
        pending.extend(
            raw.outputs
                .iter()
                .enumerate()
                .map(|(i, e)| (Role::Extra(i), &e.src)),
        );
        pending.sort_by_key(|(_, src)| src.span.as_ref().map_or(usize::MAX, |s| s.start));

        let mut items: Vec<Item> = Vec::with_capacity(pending.len());
        for (role, src) in pending {
            let ast = self.parse_expression(src, &describe(raw, role), raw)?;
            for (name, span) in ast.identifiers() {
                if name == "pi" || names.contains_key(name) {
                    continue;
                }
                let mut message =
                    format!("unknown name `{name}`: not a parameter, definition, state or input");
                if let Some(why) = reserved_reason(name) {
                    message.push_str(&format!(" ({why}; it may not appear in a model)"));
                } else if let Some(close) = suggestion(name, names.keys().copied()) {
                    message.push_str(&format!("; did you mean `{close}`?"));
                }
                return Err(self.err(src.at(span.start), ModelErrorKind::UnknownName, message));
            }
            items.push(Item {
                role,
                src: src.clone(),
                ast,
            });
        }
        Ok(items)
    }

    /// `[engine]`'s `map` parses and uses only the speed and torque outputs' names, parameters, maps and `pi`.
    pub(super) fn check_engine_map(&self, raw: &RawModel) -> Result<(), ModelError> {
        let Some(engine) = &raw.engine else {
            return Ok(());
        };
        let Some(src) = &engine.map else {
            return Ok(());
        };
        let ast = self.parse_expression(src, "[engine]'s `map`", raw)?;
        let allowed: Vec<&str> = [engine.speed.0.as_str(), engine.torque.0.as_str(), "pi"]
            .into_iter()
            .chain(raw.parameters.iter().map(|p| p.name.as_str()))
            .collect();
        for (name, span) in ast.identifiers() {
            if allowed.contains(&name) {
                continue;
            }
            let mut message = format!(
                "unknown name `{name}` in [engine]'s `map`: it may use the engine's speed `{}` and torque \
                 `{}`, the parameters and the maps, nothing else (the map is a function of the operating point)",
                engine.speed.0, engine.torque.0
            );
            if let Some(close) = suggestion(name, allowed.iter().copied()) {
                message.push_str(&format!("; did you mean `{close}`?"));
            }
            return Err(self.err(src.at(span.start), ModelErrorKind::UnknownName, message));
        }
        Ok(())
    }

    /// Parse one expression: not empty, not too large, valid syntax, finite number literals.
    fn parse_expression(&self, src: &Src, what: &str, raw: &RawModel) -> Result<Ast, ModelError> {
        if src.text.trim().is_empty() {
            return Err(self.err(
                src.value_start(),
                ModelErrorKind::Expression,
                format!("empty expression for {what}: expected an expression, e.g. \"-k*x1 + u\""),
            ));
        }
        if src.text.len() > MAX_EXPRESSION_LEN {
            return Err(self.err(
                src.value_start(),
                ModelErrorKind::Expression,
                format!(
                    "the expression for {what} is too long ({} bytes; at most {MAX_EXPRESSION_LEN}): split it into \
                     [definitions]",
                    src.text.len()
                ),
            ));
        }
        if let Some(i) = too_deep(&src.text) {
            return Err(self.err(
                src.at(i),
                ModelErrorKind::Expression,
                format!(
                    "the expression for {what} is nested too deeply (more than \
                     {MAX_EXPRESSION_NESTING} levels of parentheses, powers and signs)"
                ),
            ));
        }
        // Maps (contract §6) are called like functions: `eta_vol(w_e, p_i)`, `eta_vol_d10(w_e, p_i)`.
        let arity = |n: &str| raw.maps.iter().find(|m| m.name == n).map(|m| m.args.len());
        let ast = parse_with_maps(&src.text, &arity).map_err(|e| {
            let message = match &e.opened {
                Some(open) if src.content.is_some() => {
                    format!(
                        "{} (opened at {})",
                        e.message,
                        self.place(src.at(open.start))
                    )
                }
                _ => e.message.clone(),
            };
            self.err(
                src.at(e.span.start),
                ModelErrorKind::Expression,
                format!("{what}: {message}"),
            )
        })?;
        let mut stack = vec![&ast];
        while let Some(a) = stack.pop() {
            match &a.kind {
                AstKind::Num(n) => {
                    if !n.to_f64().is_finite() {
                        return Err(self.err(
                            src.at(a.span.start),
                            ModelErrorKind::NonFinite,
                            format!("number out of range in {what}: it must be finite"),
                        ));
                    }
                    let literal = src.text.get(a.span.clone()).unwrap_or("");
                    if n.to_f64() == 0.0 && underflows(literal) {
                        return Err(self.err(
                            src.at(a.span.start),
                            ModelErrorKind::NonFinite,
                            format!(
                                "number out of range in {what}: `{literal}` is not zero but below the \
                                 smallest floating-point number (about 4.9e-324), so it would be read as 0"
                            ),
                        ));
                    }
                }
                AstKind::Ident(_) => {}
                AstKind::Neg(x) => stack.push(x),
                AstKind::Binary(_, x, y) => {
                    stack.push(x);
                    stack.push(y);
                }
                AstKind::Call(_, args) => stack.extend(args.iter()),
            }
        }
        Ok(ast)
    }
}

/// Where an expression's nesting first exceeds [`MAX_EXPRESSION_NESTING`], if it does. Nesting counts
/// what the parser and every later pass handle recursively: parentheses (function calls included), and
/// within them chains of powers (`a^b^c`, right-associative) and prefix signs (`- -x`).
fn too_deep(text: &str) -> Option<usize> {
    // Chain length per open parenthesis level; `operand` is whether the previous token ends an operand.
    let mut chains: Vec<usize> = vec![0];
    let mut operand = false;
    for (i, c) in text.char_indices() {
        match c {
            '(' => {
                chains.push(0);
                operand = false;
            }
            ')' => {
                if chains.len() > 1 {
                    chains.pop();
                }
                operand = true;
            }
            '^' => {
                if let Some(k) = chains.last_mut() {
                    *k += 1;
                }
                operand = false;
            }
            '+' | '-' if !operand => {
                if let Some(k) = chains.last_mut() {
                    *k += 1;
                }
            }
            '+' | '-' | '*' | '/' | ',' => {
                if let Some(k) = chains.last_mut() {
                    *k = 0;
                }
                operand = false;
            }
            c if c.is_whitespace() => {}
            _ => operand = true,
        }
        if chains.len() + chains.iter().sum::<usize>() > MAX_EXPRESSION_NESTING + 1 {
            return Some(i);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nesting() {
        assert_eq!(too_deep("sin(x)^2 + (a*(b + c))^-2"), None);
        let ok = format!(
            "{}x{}",
            "(".repeat(MAX_EXPRESSION_NESTING),
            ")".repeat(MAX_EXPRESSION_NESTING)
        );
        assert_eq!(too_deep(&ok), None);
        let deep = format!(
            "{}x{}",
            "(".repeat(MAX_EXPRESSION_NESTING + 1),
            ")".repeat(65)
        );
        assert_eq!(too_deep(&deep), Some(MAX_EXPRESSION_NESTING));
        assert!(too_deep(&vec!["x"; 100].join("^")).is_some());
        assert!(too_deep(&vec!["x^2"; 1000].join(" + ")).is_none());
        assert!(too_deep(&format!("{}x", "- ".repeat(100))).is_some());
        assert!(too_deep(&vec!["-x"; 1000].join(" - ")).is_none());
    }
}
