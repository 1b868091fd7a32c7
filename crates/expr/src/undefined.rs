//! Undefined parts of an expression, kept through simplification.
//!
//! A node free of symbols whose value is not finite — a division by zero (`1/0`, `0^(-1)`, `(v - v)^(-1)`
//! once `v - v` is 0), a logarithm of zero or of a negative number, an even root of a negative number
//! (`sqrt(-1)`), an overflow (`exp(1000)`) — is *undefined*, and so is every node built on one
//! ([`Pool::is_undefined`]). The canonical identities `0·x = 0`, `x − x = 0`, `x^0 = 1`, `1^x = 1`,
//! `(x^a)^n = x^(a n)`, `exp(log x) = x` hold only where x is defined (Cohen, *Computer Algebra and
//! Symbolic Computation: Mathematical Methods*, 2003, §3.2: automatic simplification must not enlarge the
//! domain of an expression). So the constructors never apply them to an undefined operand: `0·(1/0)`,
//! `0·log(0)`, `sqrt(-1)·0` and `(v − v)/(v − v)` stay undefined, and a model's reader reports them instead
//! of running with 0 in their place.
//!
//! In a sum or product, the defined operands are combined as usual and the undefined ones are kept beside
//! them, unmerged: `2·v·(1/0)·3 = 6·v·(1/0)`, `0·(1/0)` (what `0/0` becomes), `1/0 − 1/0` stays a sum.

use crate::pool::{Id, Node, Pool};

impl Pool {
    /// The product of `factors`, at least one undefined: the defined factors multiplied canonically, the
    /// undefined ones kept as they are (a zero coefficient included: 0·(1/0) is not 0).
    pub(crate) fn mul_keeping_undefined(&mut self, factors: &[Id]) -> Id {
        let flat = self.flattened(factors, |n| match n {
            Node::Mul(fs) => Some(fs),
            _ => None,
        });
        let (undefined, defined): (Vec<Id>, Vec<Id>) =
            flat.into_iter().partition(|&f| self.is_undefined(f));
        let d = self.mul(&defined);
        let lead = match self.node(d) {
            Node::Mul(fs) => fs.to_vec(),
            _ if self.is_one(d) => Vec::new(),
            _ => vec![d],
        };
        self.keep_beside(lead, undefined, Node::Mul)
    }

    /// The sum of `terms`, at least one undefined: the defined terms added canonically, the undefined ones
    /// kept as they are (1/0 − 1/0 is not 0).
    pub(crate) fn add_keeping_undefined(&mut self, terms: &[Id]) -> Id {
        let flat = self.flattened(terms, |n| match n {
            Node::Add(ts) => Some(ts),
            _ => None,
        });
        let (undefined, defined): (Vec<Id>, Vec<Id>) =
            flat.into_iter().partition(|&t| self.is_undefined(t));
        let d = self.add(&defined);
        let lead = match self.node(d) {
            Node::Add(ts) => ts.to_vec(),
            _ if self.is_zero(d) => Vec::new(),
            _ => vec![d],
        };
        self.keep_beside(lead, undefined, Node::Add)
    }

    /// The operands of nested nodes of one kind (`inner` gives a node's operands if it is of that kind).
    fn flattened(&self, ops: &[Id], inner: impl Fn(&Node) -> Option<&Box<[Id]>>) -> Vec<Id> {
        let mut flat = Vec::with_capacity(ops.len());
        let mut stack: Vec<Id> = ops.iter().rev().copied().collect();
        while let Some(x) = stack.pop() {
            match inner(self.node(x)) {
                Some(xs) => stack.extend(xs.iter().rev().copied()),
                None => flat.push(x),
            }
        }
        flat
    }

    /// The node of `lead` (the defined part's operands, its number first) followed by the `undefined`
    /// operands in canonical order; a single operand is itself.
    fn keep_beside(
        &mut self,
        lead: Vec<Id>,
        mut undefined: Vec<Id>,
        node: impl Fn(Box<[Id]>) -> Node,
    ) -> Id {
        undefined.sort_by(|a, b| self.cmp_expr(*a, *b));
        let mut out = lead;
        out.extend(undefined);
        if out.len() == 1 {
            return out[0];
        }
        self.intern(node(out.into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shown(src: &str) -> (String, bool) {
        let mut p = Pool::new();
        let e = p.parse(src).unwrap();
        (p.display(e), p.is_undefined(e))
    }

    #[test]
    fn undefined_parts_are_never_simplified_away() {
        for src in [
            "0/0",
            "0*(1/0)",
            "0*log(0)",
            "sqrt(-1)*0",
            "(v-v)/(v-v)",
            "0^(-1)*0",
            "1/0 - 1/0",
            "(1/0)^0",
            "1^(1/0)",
            "1/(1/0)",
            "exp(log(0))",
            "sign(0/0)",
            "abs(sqrt(-2))",
            "min(1/0, 1)",
            "0*exp(1000)",
            "x*0 + log(-1)*0",
            "(v - v)^(-2)*(v-v)",
            "(2 - sqrt(4))^(-1)*0",
        ] {
            let (text, undefined) = shown(src);
            assert!(undefined, "`{src}` became `{text}`, which is defined");
            assert_ne!(text, "0", "`{src}`");
        }
    }

    #[test]
    fn defined_expressions_simplify_as_before() {
        for (src, expected) in [
            ("0*x", "0"),
            ("x - x", "0"),
            ("x/x", "1"),
            ("0*log(2)", "0"),
            ("0*sqrt(2)", "0"),
            ("(v - v)*w", "0"),
            ("exp(log(x))", "x"),
            ("1/(1/x)", "x"),
        ] {
            assert_eq!(shown(src), (expected.to_string(), false), "`{src}`");
        }
    }

    #[test]
    fn the_defined_part_is_combined_beside_the_undefined_one() {
        let mut p = Pool::new();
        let e = p.parse("2*v*(1/0)*3").unwrap();
        let Node::Mul(fs) = p.node(e).clone() else {
            panic!("not a product: {}", p.display(e));
        };
        assert_eq!(p.as_number(fs[0]).map(|n| n.to_f64()), Some(6.0));
        assert_eq!(fs.len(), 3);
        let zero_over_zero = p.parse("0/0").unwrap();
        let again = p.parse("(v - v)/(w - w)").unwrap();
        assert_eq!(zero_over_zero, again);
        // The derivative of an expression with an undefined part keeps it.
        let e = p.parse("x + log(0)").unwrap();
        let x = p.symbol("x");
        let d = p.diff(e, x);
        assert!(p.is_undefined(d), "{}", p.display(d));
        // The printed form reads back to itself.
        let text = p.display(zero_over_zero);
        assert_eq!(p.parse(&text).unwrap(), zero_over_zero, "{text}");
    }
}
