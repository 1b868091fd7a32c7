//! invsim's symbolic expression engine: a hash-consed DAG of canonical expressions with a parser and
//! printers for the model-file language, symbolic differentiation, substitution, a zero test, the lowering
//! plan to straight-line code (shared by the code generator) and a compiler of that plan to a flat
//! evaluation tape.
//!
//! ```
//! use invsim_expr::{Pool, Tape};
//! let mut pool = Pool::new();
//! let e = pool.parse("c1*v^2 + c3*p_i").unwrap();
//! let v = pool.symbol("v");
//! let dv = pool.diff(e, v);
//! assert_eq!(pool.display(dv), "2*c1*v");
//! ```

pub mod calculus;
pub mod func;
pub mod fxhash;
pub mod limits;
pub mod lower;
pub mod map;
pub mod number;
pub mod parse;
pub mod pool;
pub mod print;
pub mod rules;
pub mod tape;
pub mod undefined;
pub mod zero;

pub use calculus::{ExpansionTooLarge, UnboundSymbol, EXPAND_TERM_LIMIT};
pub use func::{Func, Func2, FUNCTIONS, NON_SMOOTH_FUNCTIONS};
pub use limits::{Measure, TooLarge};
pub use lower::{Lowered, Strategy};
pub use map::{MapDecl, MapId, MapOrders};
pub use number::{pow_f64, Number};
pub use parse::{parse, parse_with_maps, Ast, AstKind, BinOp, MapArity, ParseError};
pub use pool::{Id, Node, Pool, Symbol};
pub use print::latex_symbol;
pub use rules::{FunctionRule, Rewrite, FUNCTION_RULES};
pub use tape::{Instr, Tape};
pub use zero::{eval_with_error, zero_test, DecidedBy, Rng, ZeroVerdict};
