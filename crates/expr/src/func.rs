//! The function vocabulary of the expression language: the one- and two-argument functions, their names,
//! number of arguments and numeric evaluation, and the table the parser checks calls against.
//!
//! This is the language alone (egg's habit: the language is defined apart from its rewrite rules); the
//! identities applied when a call is constructed are data in [`crate::rules`].

/// Every function name of the language with its number of arguments.
pub const FUNCTIONS: &[(&str, usize)] = &[
    ("exp", 1),
    ("log", 1),
    ("sqrt", 1),
    ("sin", 1),
    ("cos", 1),
    ("tan", 1),
    ("sinh", 1),
    ("cosh", 1),
    ("tanh", 1),
    ("atan", 1),
    ("pow", 2),
    ("abs", 1),
    ("sign", 1),
    ("min", 2),
    ("max", 2),
];

/// Functions that are not smooth and may appear only in `[outputs]`.
pub const NON_SMOOTH_FUNCTIONS: &[&str] = &["abs", "sign", "min", "max"];

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parsing_table_names_every_function_with_its_arity() {
        for f in Func::ALL {
            assert!(FUNCTIONS.contains(&(f.name(), 1)), "{}", f.name());
            assert_eq!(Func::from_name(f.name()), Some(f));
            assert_eq!(
                NON_SMOOTH_FUNCTIONS.contains(&f.name()),
                !f.is_smooth(),
                "{}",
                f.name()
            );
        }
        for f in [Func2::Min, Func2::Max] {
            assert!(FUNCTIONS.contains(&(f.name(), 2)), "{}", f.name());
            assert_eq!(Func2::from_name(f.name()), Some(f));
        }
        // The rest are spelled as power nodes.
        let others: Vec<&str> = FUNCTIONS
            .iter()
            .map(|(n, _)| *n)
            .filter(|n| Func::from_name(n).is_none() && Func2::from_name(n).is_none())
            .collect();
        assert_eq!(others, ["sqrt", "pow"]);
    }
}
