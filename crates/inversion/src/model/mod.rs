//! Model files: read a TOML model (contract section 2), check it, and turn it into a validated [`Model`]
//! whose definitions are inlined and whose state equations are split into `f(x) + g(x) u`.
//!
//! Every error names the file, the line and the column (1-based, columns counted in characters) of the
//! offending key, value or character inside an expression, and says what was expected. The checks run in
//! this order, so a file with several problems reports the most basic one first:
//!
//! 1. the file is readable, at most [`MAX_MODEL_FILE_BYTES`] bytes (read through the cap), UTF-8 and
//!    valid TOML;
//! 2. the structure: known top-level keys and section keys, value types, required sections and keys,
//!    finite numbers, `min <= max` for the input bounds;
//! 3. declared names: identifiers, not reserved, unique across parameters, definitions, states and input;
//!    extra outputs may not take the name of a state, the input or another result column (`t`, `yd_N`,
//!    `etaN`);
//! 4. each expression (in file order): not empty, at most [`MAX_EXPRESSION_LEN`] bytes and
//!    [`MAX_EXPRESSION_NESTING`] levels deep, syntax, finite number literals, known names;
//! 5. definitions: no cycles, and only earlier definitions used;
//! 6. `abs`, `sign`, `min`, `max` only where they cannot reach f, g or h;
//! 7. no undefined part in any expression as written (`0/0`, `0*log(0)`, `(v-v)/(v-v)`, `1/m` with
//!    `m = 0`): simplification never removes one, so it is refused where it is written;
//! 8. symbolic: `h` free of the input, given `f`/`g` free of the input, each `rhs` affine in the input
//!    (∂²rhs/∂u² identically zero by [`invsim_expr::zero_test`] at the nominal parameter values).
//!
//! Besides the forms of the contract, the reader accepts: a definition as a table
//! `{ expr = "…", unit = "…", doc = "…" }`; an extra output as a plain string (`p = "u*v"`, not
//! accumulated); a plain number where an expression is expected (`g = 1`); states as `[states.NAME]`
//! tables. The model's `name` defaults to the file stem. `[output]` takes three optional numbers beyond
//! the contract: `nominal` (the output value where `invsim derive` classifies the zero dynamics),
//! `reference_offset` and `reference_scale` (the reference is y_d = offset + scale · smoothed cycle, for
//! outputs that are not a vehicle speed; the scale may not be 0). An `[outputs]` entry takes
//! `per_distance = true|false` (its integral is reported per 100 km; default: accumulated outputs of a model
//! with the identity reference map, i.e. one that tracks the cycle's speed), and an optional `[engine]` table
//! names the two outputs that are the engine's speed and torque (`engine.rs`), and an optional `[headline]`
//! table the accumulated output that is the model's answer (`headline.rs`).
//!
//! Where each step lives (one file per concept):
//!
//! | file | concept |
//! |---|---|
//! | `keys.rs` | the keys of every table of the file, the lists the reader accepts |
//! | `error.rs` | the typed [`ModelError`] and its [`ModelErrorKind`] |
//! | `spanned.rs` | positions: byte offset → line and column, the reader that reports them |
//! | `tree.rs` | the TOML tree with spans |
//! | `values.rs` | a TOML value read as the type a key expects |
//! | `names.rs` | identifiers, reserved names, collisions, "did you mean" |
//! | `signals.rs` | the optional `[signals]` table and the reserved names `S_dk` of their derivatives |
//! | `engine.rs` | the optional `[engine]` table: which outputs are the engine's speed and torque |
//! | `headline.rs` | the optional `[headline]` table: the output that is the model's answer, fuel or electricity |
//! | `map_csv.rs` | a map's grid and values from a CSV file |
//! | `maps.rs` | `[maps.NAME]` tables: grid, values, smoothing, extrapolation (contract §6) |
//! | `raw.rs` | the file as read, checked for structure (check 2) |
//! | `expressions.rs` | parsing each expression (check 4) |
//! | `definitions.rs` | definition order, cycles and inlining (check 5) |
//! | `smooth.rs` | where `abs`, `sign`, `min`, `max` may appear (check 6) |
//! | `undefined.rs` | undefined parts of the expressions as written (check 7) |
//! | `split.rs` | the affine split rhs → f + g·u and its check (check 8) |
//! | `validated.rs` | the validated [`Model`] |
//! | `reader.rs` | the pipeline from bytes to [`Model`] |
//! | `modal.rs` | the types of a model with several inputs and modes ([`ModalModel`]) |
//! | `gearbox.rs` | `[gearbox]`: gear parameters and the shift schedule |
//! | `modes.rs` | `[inputs]` and `[modes]`: one single-input tree per mode, built by the ordinary reader |
//! | `hybrid.rs` | `[hybrid]`: what an energy-management strategy weighs (fuel and battery power, the charge) |
//!
//! Imports go one way — each file imports only files listed before it: keys, error, validated, spanned, tree,
//! names, values, signals, engine, headline, map_csv, maps, raw, expressions, definitions, smooth, undefined, split,
//! reader.

mod coupling;
mod definitions;
mod engine;
mod error;
mod expressions;
pub(crate) mod finite;
mod gearbox;
mod headline;
mod hybrid;
pub mod keys;
mod map_csv;
mod maps;
mod modal;
mod modes;
mod names;
mod raw;
mod reader;
mod signals;
mod smooth;
mod spanned;
mod split;
mod tree;
mod undefined;
mod validated;
mod values;

pub use coupling::coupling_name;
pub use error::{ModelError, ModelErrorKind};
pub use expressions::{MAX_EXPRESSION_LEN, MAX_EXPRESSION_NESTING};
pub use gearbox::MAX_GEARS;
pub use hybrid::MAX_HYBRID_GRID;
pub use map_csv::{read_map_file, MapData};
pub use modal::{
    Gearbox, HybridSpec, ModalFacts, ModalInput, ModalModel, Mode, ModeHeader, ModeRole, ModelFile,
    Schedule, SequenceOptions,
};
pub use reader::{read_capped as read_model_file, MAX_MODEL_FILE_BYTES};
pub use signals::{derivative_name, MAX_SIGNAL_DERIVATIVE};
pub use validated::{
    Definition, Engine, ExtraOutput, Input, MapInfo, Model, Output, Parameter, Signal, State,
};
