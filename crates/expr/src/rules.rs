//! The simplification rules of the expression language's functions, kept as data.
//!
//! Each [`FunctionRule`] is one identity applied when a call is constructed. They are exact identities on
//! the function's real domain (Abramowitz & Stegun §4): `exp(log x) = x` holds wherever `log x` is defined,
//! `log(exp x) = x` everywhere, odd functions pull out a sign, even functions drop it, and the
//! trigonometric functions of `atan x` are algebraic in `x`.

use crate::func::Func;

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
    /// f(atan x) without the angle: cos(atan x) = (1 + x²)^(−1/2), sin(atan x) = x (1 + x²)^(−1/2),
    /// tan(atan x) = x (the right triangle with legs 1 and x; A&S 4.4.35, every real x). A road load's
    /// cos(atan(grade)) becomes one square root instead of two library calls.
    OfAtan,
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
    rule!("cos-atan", Cos, Rewrite::OfAtan),
    rule!("sin-atan", Sin, Rewrite::OfAtan),
    rule!("tan-atan", Tan, Rewrite::OfAtan),
    rule!("abs-number", Abs, Rewrite::Numeric),
    rule!("sign-number", Sign, Rewrite::Numeric),
];
