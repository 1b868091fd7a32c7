//! Printing expressions: back to the contract's expression language (parseable again) and to LaTeX.
//!
//! Both printers work from the canonical form: a sum prints its terms in canonical order with `-` for
//! negative coefficients, a product splits into numerator and denominator (factors with negative numeric
//! exponents), `x^(1/2)` prints as `sqrt(x)`. Parentheses are emitted only where precedence needs them, so
//! `parse(print(e)) == e` for every canonical `e`.

use crate::func::Func;
use crate::limits::{Measure, TooLarge, MAX_PRINT_DEPTH, MAX_PRINT_SIZE};
use crate::number::Number;
use crate::pool::{Id, Node, Pool};

const P_ADD: u8 = 1;
const P_MUL: u8 = 2;
const P_NEG: u8 = 3;
const P_POW: u8 = 4;
const P_ATOM: u8 = 5;

/// Output syntax.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Style {
    Text,
    Latex,
}

/// A product split for printing: sign, numeric numerator/denominator, and factor lists.
struct Fraction {
    negative: bool,
    num_coeff: Option<Number>,
    den_coeff: Option<Number>,
    num: Vec<Factor>,
    den: Vec<Factor>,
}

/// A factor b^e with the exponent's sign already taken into the numerator/denominator choice.
struct Factor {
    base: Id,
    /// `None` for exponent 1.
    exp: Option<Number>,
    /// A symbolic exponent (never in the denominator).
    sym_exp: Option<Id>,
}

impl Pool {
    /// The expression in the contract's language, e.g. `c3*c7 - x^2/2`; an expression over the printing
    /// budget of [`crate::limits`] prints as a placeholder that says how large it is (see
    /// [`Pool::try_display`]).
    pub fn display(&self, e: Id) -> String {
        self.try_display(e)
            .unwrap_or_else(|t| placeholder(self, e, t))
    }

    /// The expression in LaTeX (for `$…$` in Markdown), or a placeholder as [`Pool::display`].
    pub fn latex(&self, e: Id) -> String {
        self.try_latex(e)
            .unwrap_or_else(|t| placeholder(self, e, t))
    }

    /// The expression in the contract's language, or why it is too large to print.
    pub fn try_display(&self, e: Id) -> Result<String, TooLarge> {
        self.printable(e)?;
        Ok(Printer {
            pool: self,
            style: Style::Text,
        }
        .expr(e, 0))
    }

    /// The expression in LaTeX, or why it is too large to print.
    pub fn try_latex(&self, e: Id) -> Result<String, TooLarge> {
        self.printable(e)?;
        Ok(Printer {
            pool: self,
            style: Style::Latex,
        }
        .expr(e, 0))
    }

    /// Is `e` within the printing budget ([`MAX_PRINT_DEPTH`], [`MAX_PRINT_SIZE`])? O(1).
    pub fn printable(&self, e: Id) -> Result<(), TooLarge> {
        let depth = self.depth(e);
        if depth > MAX_PRINT_DEPTH {
            return Err(TooLarge {
                measure: Measure::Depth,
                size: u64::from(depth),
                limit: u64::from(MAX_PRINT_DEPTH),
            });
        }
        let written = self.written_size(e);
        if written > MAX_PRINT_SIZE {
            return Err(TooLarge {
                measure: Measure::Written,
                size: written,
                limit: MAX_PRINT_SIZE,
            });
        }
        Ok(())
    }
}

/// What prints in place of an expression over the budget (never parsed back: `<` is not in the language).
fn placeholder(pool: &Pool, e: Id, t: TooLarge) -> String {
    format!(
        "<expression too large to print: {} distinct nodes; {t}>",
        pool.dag_size(&[e])
    )
}

pub fn latex_symbol(name: &str) -> String {
    const GREEK: &[&str] = &[
        "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa",
        "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi",
        "omega", "Gamma", "Delta", "Theta", "Lambda", "Xi", "Pi", "Sigma", "Phi", "Psi", "Omega",
    ];
    if name == "yr" {
        return "y^{(r)}".into();
    }
    let base_latex = |b: &str| -> String {
        if GREEK.contains(&b) {
            format!("\\{b}")
        } else if b == "om" {
            "\\omega".into()
        } else if b.chars().count() == 1 {
            b.to_string()
        } else {
            format!("\\mathrm{{{b}}}")
        }
    };
    if let Some((base, sub)) = name.split_once('_') {
        if !base.is_empty() && !sub.is_empty() {
            let sub = sub.replace('_', ",");
            let sub = if sub.chars().count() == 1 || sub.chars().all(|c| c.is_ascii_digit()) {
                sub
            } else {
                format!("\\mathrm{{{sub}}}")
            };
            return format!("{}_{{{}}}", base_latex(base), sub);
        }
    }
    // Trailing digits become a subscript: xi1, eta2, c3.
    let split = name.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    if split > 0 && split < name.len() {
        return format!("{}_{{{}}}", base_latex(&name[..split]), &name[split..]);
    }
    base_latex(&name.replace('_', "\\_"))
}

struct Printer<'p> {
    pool: &'p Pool,
    style: Style,
}

impl Printer<'_> {
    fn latex(&self) -> bool {
        self.style == Style::Latex
    }

    fn wrap(&self, s: String, own: u8, ctx: u8) -> String {
        if own < ctx {
            if self.latex() {
                format!("\\left({s}\\right)")
            } else {
                format!("({s})")
            }
        } else {
            s
        }
    }

    fn number(&self, n: Number, ctx: u8) -> String {
        let s = n.to_string();
        let own = if n.is_negative() {
            P_NEG
        } else if s.contains('/') {
            P_MUL
        } else {
            P_ATOM
        };
        let s = if self.latex() {
            if let Some((a, b)) = s.split_once('/') {
                let (neg, a) = a.strip_prefix('-').map(|a| (true, a)).unwrap_or((false, a));
                format!("{}\\frac{{{a}}}{{{b}}}", if neg { "-" } else { "" })
            } else if let Some((m, e)) = s.split_once('e') {
                format!("{m} \\cdot 10^{{{e}}}")
            } else {
                s
            }
        } else {
            s
        };
        self.wrap(s, own, ctx)
    }

    fn expr(&self, e: Id, ctx: u8) -> String {
        match self.pool.node(e) {
            Node::Num(n) => self.number(*n, ctx),
            Node::Pi => (if self.latex() { "\\pi" } else { "pi" }).to_string(),
            Node::Sym(s) => {
                let name = self.pool.symbol_name(*s);
                if self.latex() {
                    latex_symbol(name)
                } else {
                    name.to_string()
                }
            }
            Node::Add(ts) => {
                let mut out = String::new();
                for (i, &t) in ts.iter().enumerate() {
                    if i == 0 {
                        // The leading term keeps its own sign (a unary minus), printed like a lone product.
                        out.push_str(&self.expr(t, P_ADD + 1));
                        continue;
                    }
                    let (neg, body) = self.signed_term(t);
                    out.push_str(if neg { " - " } else { " + " });
                    out.push_str(&body);
                }
                self.wrap(out, P_ADD, ctx)
            }
            Node::Mul(_) | Node::Pow(..) => {
                let frac = self.fraction(e);
                let (own, s) = self.print_fraction(&frac);
                self.wrap(s, own, ctx)
            }
            Node::Call(f, a) => self.call(*f, *a),
            Node::Map(m, o, a) => self.map_call(*m, *o, &[*a]),
            Node::Map2(m, o, a, b) => self.map_call(*m, *o, &[*a, *b]),
            Node::Call2(f, a, b) => {
                let (a, b) = (self.expr(*a, 0), self.expr(*b, 0));
                if self.latex() {
                    format!("\\{}\\left({a}, {b}\\right)", f.name())
                } else {
                    format!("{}({a}, {b})", f.name())
                }
            }
        }
    }

    /// `M_dIJ(a, b)` (contract §6); in LaTeX `\mathrm{M}^{(1,0)}\left(a, b\right)`.
    fn map_call(&self, m: crate::map::MapId, o: crate::map::MapOrders, args: &[Id]) -> String {
        let decl = self.pool.map_decl(m);
        let args: Vec<String> = args.iter().map(|&a| self.expr(a, 0)).collect();
        if self.latex() {
            let orders = match (args.len(), o) {
                (_, [0, 0]) => String::new(),
                (1, [k, _]) => format!("^{{({k})}}"),
                (_, [i, j]) => format!("^{{({i},{j})}}"),
            };
            let name = decl.name.replace('_', "\\_");
            format!(
                "\\mathrm{{{name}}}{orders}\\left({}\\right)",
                args.join(", ")
            )
        } else {
            let name = crate::map::call_name(&decl.name, args.len(), o);
            format!("{name}({})", args.join(", "))
        }
    }

    fn call(&self, f: Func, a: Id) -> String {
        let arg = self.expr(a, 0);
        if !self.latex() {
            return format!("{}({arg})", f.name());
        }
        match f {
            Func::Abs => format!("\\left|{arg}\\right|"),
            Func::Sign => format!("\\operatorname{{sign}}\\left({arg}\\right)"),
            Func::Atan => format!("\\arctan\\left({arg}\\right)"),
            Func::Exp => format!("\\exp\\left({arg}\\right)"),
            _ => format!("\\{}\\left({arg}\\right)", f.name()),
        }
    }

    /// A sum's term as (is it negative, printed magnitude at multiplicative precedence).
    fn signed_term(&self, t: Id) -> (bool, String) {
        match self.pool.node(t) {
            Node::Num(n) if n.is_negative() => (true, self.number(n.neg(), P_ADD + 1)),
            Node::Mul(_) => {
                let mut frac = self.fraction(t);
                let neg = frac.negative;
                frac.negative = false;
                let (own, s) = self.print_fraction(&frac);
                (neg, self.wrap(s, own, P_ADD + 1))
            }
            _ => (false, self.expr(t, P_ADD + 1)),
        }
    }

    fn fraction(&self, e: Id) -> Fraction {
        let mut frac = Fraction {
            negative: false,
            num_coeff: None,
            den_coeff: None,
            num: vec![],
            den: vec![],
        };
        let factors: Vec<Id> = match self.pool.node(e) {
            Node::Mul(fs) => fs.to_vec(),
            _ => vec![e],
        };
        for f in factors {
            match self.pool.node(f) {
                Node::Num(n) => {
                    let n = if n.is_negative() {
                        frac.negative = true;
                        n.neg()
                    } else {
                        *n
                    };
                    match n {
                        Number::Rational(p, q) => {
                            if p != 1 {
                                frac.num_coeff = Some(Number::int(p));
                            }
                            if q != 1 {
                                frac.den_coeff = Some(Number::int(q));
                            }
                        }
                        Number::Float(_) => frac.num_coeff = Some(n),
                    }
                }
                Node::Pow(b, x) => match self.pool.node(*x) {
                    Node::Num(k) if k.is_negative() => {
                        let k = k.neg();
                        frac.den.push(Factor {
                            base: *b,
                            exp: (!k.is_one()).then_some(k),
                            sym_exp: None,
                        })
                    }
                    Node::Num(k) => frac.num.push(Factor {
                        base: *b,
                        exp: Some(*k),
                        sym_exp: None,
                    }),
                    _ => frac.num.push(Factor {
                        base: *b,
                        exp: None,
                        sym_exp: Some(*x),
                    }),
                },
                _ => frac.num.push(Factor {
                    base: f,
                    exp: None,
                    sym_exp: None,
                }),
            }
        }
        frac
    }

    fn factor(&self, f: &Factor, ctx: u8) -> (u8, String) {
        if let Some(x) = f.sym_exp {
            let b = self.expr(f.base, P_POW + 1);
            let e = self.expr(x, P_POW);
            return if self.latex() {
                (P_POW, format!("{b}^{{{}}}", self.expr(x, 0)))
            } else {
                (P_POW, format!("{b}^{e}"))
            };
        }
        match f.exp {
            None => {
                let s = self.expr(f.base, ctx);
                (P_ATOM, s)
            }
            Some(k) if k == Number::ratio(1, 2) => {
                let a = self.expr(f.base, 0);
                if self.latex() {
                    (P_ATOM, format!("\\sqrt{{{a}}}"))
                } else {
                    (P_ATOM, format!("sqrt({a})"))
                }
            }
            Some(k) => {
                let b = self.expr(f.base, P_POW + 1);
                if self.latex() {
                    (P_POW, format!("{b}^{{{}}}", self.number(k, 0)))
                } else {
                    (P_POW, format!("{b}^{}", self.number(k, P_ATOM)))
                }
            }
        }
    }

    fn product(&self, coeff: Option<Number>, factors: &[Factor]) -> (usize, String) {
        let mut parts: Vec<String> = Vec::new();
        if let Some(c) = coeff {
            parts.push(self.number(c, P_MUL + 1));
        }
        for f in factors {
            let (_, s) = self.factor(f, P_MUL + 1);
            parts.push(s);
        }
        let sep = if self.latex() { " \\, " } else { "*" };
        (parts.len(), parts.join(sep))
    }

    /// The numeric coefficient of a term, and the term's fraction with that coefficient replaced by `k`.
    fn scaled_fraction(&self, t: Id, k: Number) -> Fraction {
        let mut frac = self.fraction(t);
        let (neg, mag) = if k.is_negative() {
            (true, k.neg())
        } else {
            (false, k)
        };
        frac.negative = neg;
        frac.num_coeff = None;
        frac.den_coeff = None;
        match mag {
            // A terminating decimal prints as one number (0.2*c4, not c4/5).
            Number::Rational(_, q) if q != 1 && !mag.to_string().contains('/') => {
                frac.num_coeff = Some(mag)
            }
            Number::Rational(p, q) => {
                if p != 1 {
                    frac.num_coeff = Some(Number::int(p));
                }
                if q != 1 {
                    frac.den_coeff = Some(Number::int(q));
                }
            }
            Number::Float(_) => frac.num_coeff = Some(mag),
        }
        frac
    }

    fn coefficient(&self, t: Id) -> Number {
        match self.pool.node(t) {
            Node::Num(n) => *n,
            Node::Mul(fs) => self.pool.as_number(fs[0]).unwrap_or(Number::ONE),
            _ => Number::ONE,
        }
    }

    /// Display only: a product c·(s1 + s2 + …)·rest with a non-integer rational c prints with c multiplied
    /// into the sum when every coefficient then is a terminating decimal, so `(580 + 9*x^1.8)/1250` reads
    /// `(0.464 + 0.0072*x^1.8)`. (The canonical form is independent of such grouping, so it parses back.)
    fn scaled_sum(&self, frac: &Fraction) -> Option<(u8, String)> {
        let den = frac.den_coeff?;
        let mut c = frac.num_coeff.unwrap_or(Number::ONE).mul(den.recip()?);
        if frac.negative {
            c = c.neg();
        }
        // The sum factor whose scaled coefficients print shortest (all must be terminating decimals).
        let mut best: Option<(usize, usize, Vec<Number>)> = None;
        for (i, f) in frac.num.iter().enumerate() {
            if f.exp.is_some() || f.sym_exp.is_some() {
                continue;
            }
            let Node::Add(ts) = self.pool.node(f.base) else {
                continue;
            };
            let scaled: Vec<Number> = ts.iter().map(|&t| self.coefficient(t).mul(c)).collect();
            let texts: Vec<String> = scaled.iter().map(|k| k.to_string()).collect();
            if scaled.iter().any(|k| !k.is_exact()) || texts.iter().any(|t| t.contains('/')) {
                continue;
            }
            let score: usize = texts.iter().map(|t| t.len()).sum();
            if best.as_ref().is_none_or(|b| score < b.1) {
                best = Some((i, score, scaled));
            }
        }
        let (index, _, scaled) = best?;
        let Node::Add(ts) = self.pool.node(frac.num[index].base) else {
            return None;
        };
        let mut sum = String::new();
        for (i, (&t, &k)) in ts.iter().zip(&scaled).enumerate() {
            let body = if self.pool.as_number(t).is_some() {
                let mag = if k.is_negative() { k.neg() } else { k };
                (k.is_negative(), self.number(mag, P_ADD + 1))
            } else {
                let mut f = self.scaled_fraction(t, k);
                let neg = f.negative;
                f.negative = false;
                let (own, s) = self.print_fraction(&f);
                (neg, self.wrap(s, own, P_ADD + 1))
            };
            match (i, body.0) {
                (0, true) => sum.push('-'),
                (0, false) => {}
                (_, true) => sum.push_str(" - "),
                (_, false) => sum.push_str(" + "),
            }
            sum.push_str(&body.1);
        }
        let sum = if self.latex() {
            format!("\\left({sum}\\right)")
        } else {
            format!("({sum})")
        };
        let others: Vec<Factor> = frac
            .num
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != index)
            .map(|(_, f)| Factor {
                base: f.base,
                exp: f.exp,
                sym_exp: f.sym_exp,
            })
            .collect();
        let (nn, rest) = self.product(None, &others);
        let (nd, den) = self.product(None, &frac.den);
        let sep = if self.latex() { " \\, " } else { "*" };
        let num = if nn == 0 {
            sum
        } else {
            format!("{sum}{sep}{rest}")
        };
        Some(match nd {
            0 => (if nn == 0 { P_ATOM } else { P_MUL }, num),
            _ if self.latex() => (P_ATOM, format!("\\frac{{{num}}}{{{den}}}")),
            1 => (P_MUL, format!("{num}/{den}")),
            _ => (P_MUL, format!("{num}/({den})")),
        })
    }

    fn print_fraction(&self, frac: &Fraction) -> (u8, String) {
        if let Some(scaled) = self.scaled_sum(frac) {
            return scaled;
        }
        let (nn, num) = self.product(frac.num_coeff, &frac.num);
        let (nd, den) = self.product(frac.den_coeff, &frac.den);
        let num = if nn == 0 { "1".to_string() } else { num };
        let sign = if frac.negative { "-" } else { "" };
        if nd == 0 {
            let own = if frac.negative {
                P_NEG
            } else if nn == 1
                && frac.num.len() == 1
                && frac.num[0].exp.is_some_and(|k| k != Number::ratio(1, 2))
                || frac.num.len() == 1 && frac.num[0].sym_exp.is_some()
            {
                P_POW
            } else if nn <= 1 {
                P_ATOM
            } else {
                P_MUL
            };
            return (own, format!("{sign}{num}"));
        }
        if self.latex() {
            return (
                if frac.negative { P_NEG } else { P_ATOM },
                format!("{sign}\\frac{{{num}}}{{{den}}}"),
            );
        }
        // A single denominator factor binds tighter than `/` (atoms and `^`); a product needs parentheses.
        let den = if nd > 1 { format!("({den})") } else { den };
        (
            if frac.negative { P_NEG } else { P_MUL },
            format!("{sign}{num}/{den}"),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(src: &str) -> String {
        let mut p = Pool::new();
        let e = p.parse(src).unwrap();
        let s = p.display(e);
        let back = p
            .parse(&s)
            .unwrap_or_else(|err| panic!("`{s}` does not parse: {err}"));
        assert_eq!(back, e, "{src} printed as {s}");
        s
    }

    #[test]
    fn prints_canonical_forms() {
        assert_eq!(round_trip("x*x"), "x^2");
        assert_eq!(round_trip("2*(x + y)"), "2*x + 2*y");
        assert_eq!(round_trip("a/(b*c)"), "a/(b*c)");
        assert_eq!(round_trip("-x^2"), "-x^2");
        assert_eq!(round_trip("x^0.5"), "sqrt(x)");
        assert_eq!(round_trip("1/sqrt(x)"), "1/sqrt(x)");
        assert_eq!(round_trip("x/3"), "x/3");
        assert_eq!(round_trip("x - y"), "x - y");
        assert_eq!(round_trip("v^1.8*v"), "v^2.8");
        assert_eq!(round_trip("(a+b)^(1/3)"), "(a + b)^(1/3)");
        assert_eq!(round_trip("x^-2"), "1/x^2");
        assert_eq!(round_trip("(x^y)^z"), "(x^y)^z");
        assert_eq!(round_trip("-(a+b)*c"), "-c*(a + b)");
        round_trip("exp(-x)*sin(2*pi*t)/(1 + x^2)^1.5");
        round_trip("min(a, b) + max(-a, 3)");
        round_trip("1e-300*x + 2.5E+4");
    }

    #[test]
    fn latex_names() {
        assert_eq!(latex_symbol("p_i"), "p_{i}");
        assert_eq!(latex_symbol("xi1"), "\\xi_{1}");
        assert_eq!(latex_symbol("eta_trm"), "\\eta_{\\mathrm{trm}}");
        assert_eq!(latex_symbol("m_at"), "m_{\\mathrm{at}}");
        let mut p = Pool::new();
        let e = p.parse("sqrt(x)/(2*y)").unwrap();
        assert_eq!(p.latex(e), "\\frac{\\sqrt{x}}{2 \\, y}");
    }
}
