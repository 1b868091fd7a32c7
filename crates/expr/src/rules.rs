//! The functions of the expression language and their simplification rules, kept as data.
//!
//! Each [`FunctionRule`] is one identity applied when a call is constructed. They are exact identities on
//! the function's real domain (Abramowitz & Stegun §4): `exp(log x) = x` holds wherever `log x` is defined,
//! `log(exp x) = x` everywhere, odd functions pull out a sign, even functions drop it.

use crate::number::Number;
use crate::pool::{Id, Node, Pool};

/// One-argument functions.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, PartialOrd, Ord)]
pub enum Func {
    Exp,
    Log,
    Sin,
    Cos,
    Tan,
    Sinh,
    Cosh,
    Tanh,
    Atan,
    /// Not smooth: allowed only in a model's `[outputs]`.
    Abs,
    /// Not smooth: allowed only in a model's `[outputs]`.
    Sign,
}

/// Two-argument functions (`pow` is not one: it is the power node).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, PartialOrd, Ord)]
pub enum Func2 {
    Min,
    Max,
}

impl Func {
    pub const ALL: [Func; 11] = [
        Func::Exp,
        Func::Log,
        Func::Sin,
        Func::Cos,
        Func::Tan,
        Func::Sinh,
        Func::Cosh,
        Func::Tanh,
        Func::Atan,
        Func::Abs,
        Func::Sign,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Func::Exp => "exp",
            Func::Log => "log",
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Sinh => "sinh",
            Func::Cosh => "cosh",
            Func::Tanh => "tanh",
            Func::Atan => "atan",
            Func::Abs => "abs",
            Func::Sign => "sign",
        }
    }
    pub fn from_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }
    /// Smooth functions may enter f, g and h; `abs` and `sign` may not.
    pub fn is_smooth(self) -> bool {
        !matches!(self, Func::Abs | Func::Sign)
    }
    /// Evaluate in f64.
    pub fn eval(self, x: f64) -> f64 {
        match self {
            Func::Exp => x.exp(),
            Func::Log => x.ln(),
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Tan => x.tan(),
            Func::Sinh => x.sinh(),
            Func::Cosh => x.cosh(),
            Func::Tanh => x.tanh(),
            Func::Atan => x.atan(),
            Func::Abs => x.abs(),
            Func::Sign => {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else if x == 0.0 {
                    0.0
                } else {
                    f64::NAN
                }
            }
        }
    }
}

impl Func2 {
    pub fn name(self) -> &'static str {
        match self {
            Func2::Min => "min",
            Func2::Max => "max",
        }
    }
    pub fn from_name(name: &str) -> Option<Func2> {
        match name {
            "min" => Some(Func2::Min),
            "max" => Some(Func2::Max),
            _ => None,
        }
    }
    pub fn eval(self, a: f64, b: f64) -> f64 {
        match self {
            Func2::Min => a.min(b),
            Func2::Max => a.max(b),
        }
    }
}

/// What a rule does with `f(arg)`.
#[derive(Clone, Copy, Debug)]
pub enum Rewrite {
    /// f(g(x)) = x: `f` undoes the inner function `g`.
    Inverse(Func),
    /// f(0) = value.
    AtZero(i128),
    /// f(1) = value.
    AtOne(i128),
    /// f(−x) = −f(x).
    Odd,
    /// f(−x) = f(x).
    Even,
    /// f(c) for a numeric c: |c|, sign(c).
    Numeric,
}

/// An identity applied when `func(·)` is constructed.
#[derive(Clone, Copy, Debug)]
pub struct FunctionRule {
    pub name: &'static str,
    pub func: Func,
    pub rewrite: Rewrite,
}

macro_rules! rule {
    ($name:literal, $f:ident, $rw:expr) => {
        FunctionRule {
            name: $name,
            func: Func::$f,
            rewrite: $rw,
        }
    };
}

/// Every function identity the canonicaliser applies.
pub const FUNCTION_RULES: &[FunctionRule] = &[
    rule!("exp-log", Exp, Rewrite::Inverse(Func::Log)),
    rule!("log-exp", Log, Rewrite::Inverse(Func::Exp)),
    rule!("atan-0", Atan, Rewrite::AtZero(0)),
    rule!("exp-0", Exp, Rewrite::AtZero(1)),
    rule!("log-1", Log, Rewrite::AtOne(0)),
    rule!("sin-0", Sin, Rewrite::AtZero(0)),
    rule!("cos-0", Cos, Rewrite::AtZero(1)),
    rule!("tan-0", Tan, Rewrite::AtZero(0)),
    rule!("sinh-0", Sinh, Rewrite::AtZero(0)),
    rule!("cosh-0", Cosh, Rewrite::AtZero(1)),
    rule!("tanh-0", Tanh, Rewrite::AtZero(0)),
    rule!("sin-odd", Sin, Rewrite::Odd),
    rule!("tan-odd", Tan, Rewrite::Odd),
    rule!("sinh-odd", Sinh, Rewrite::Odd),
    rule!("tanh-odd", Tanh, Rewrite::Odd),
    rule!("atan-odd", Atan, Rewrite::Odd),
    rule!("sign-odd", Sign, Rewrite::Odd),
    rule!("cos-even", Cos, Rewrite::Even),
    rule!("cosh-even", Cosh, Rewrite::Even),
    rule!("abs-even", Abs, Rewrite::Even),
    rule!("abs-number", Abs, Rewrite::Numeric),
    rule!("sign-number", Sign, Rewrite::Numeric),
];

/// If `arg` is written with a negative numeric coefficient, return −arg.
fn negated(pool: &mut Pool, arg: Id) -> Option<Id> {
    let (c, _) = pool.split_coefficient(arg);
    let leading_negative = match pool.node(arg) {
        Node::Add(ts) => {
            let first = ts.iter().find(|&&t| pool.as_number(t).is_none()).copied();
            first
                .map(|t| pool.split_coefficient(t).0.is_negative())
                .unwrap_or(false)
        }
        _ => c.is_negative(),
    };
    if leading_negative {
        Some(pool.neg(arg))
    } else {
        None
    }
}

/// Apply the first matching rule of [`FUNCTION_RULES`] to `f(arg)`; `None` when none applies.
pub fn apply_function_rules(pool: &mut Pool, f: Func, arg: Id) -> Option<Id> {
    for rule in FUNCTION_RULES.iter().filter(|r| r.func == f) {
        match rule.rewrite {
            Rewrite::Inverse(g) => {
                if let Node::Call(h, inner) = pool.node(arg) {
                    if *h == g {
                        return Some(*inner);
                    }
                }
            }
            Rewrite::AtZero(v) => {
                if pool.is_zero(arg) {
                    return Some(pool.int(v));
                }
            }
            Rewrite::AtOne(v) => {
                if pool.is_one(arg) {
                    return Some(pool.int(v));
                }
            }
            Rewrite::Odd => {
                if let Some(m) = negated(pool, arg) {
                    let inner = pool.call(f, m);
                    return Some(pool.neg(inner));
                }
            }
            Rewrite::Even => {
                if let Some(m) = negated(pool, arg) {
                    return Some(pool.call(f, m));
                }
            }
            Rewrite::Numeric => {
                if let Some(n) = pool.as_number(arg) {
                    let v = match f {
                        Func::Abs if n.is_negative() => n.neg(),
                        Func::Abs => n,
                        Func::Sign if n.is_zero() => Number::ZERO,
                        Func::Sign if n.is_negative() => Number::MINUS_ONE,
                        _ => Number::ONE,
                    };
                    return Some(pool.num(v));
                }
            }
        }
    }
    None
}
