//! Model files: read a TOML model (contract section 2), check it, and turn it into a validated [`Model`]
//! whose definitions are inlined and whose state equations are split into `f(x) + g(x) u`.
//!
//! Every error names the file, the line and the column (1-based, columns counted in characters) of the
//! offending key, value or character inside an expression, and says what was expected. The checks run in
//! this order, so a file with several problems reports the most basic one first:
//!
//! 1. the file is readable UTF-8 and valid TOML;
//! 2. the structure: known top-level keys and section keys, value types, required sections and keys,
//!    finite numbers, `min <= max` for the input bounds;
//! 3. declared names: identifiers, not reserved, unique across parameters, definitions, states and input;
//!    extra outputs may not take the name of a state, the input or another result column (`t`, `yd_N`,
//!    `etaN`);
//! 4. each expression (in file order): not empty, at most [`MAX_EXPRESSION_LEN`] bytes and
//!    [`MAX_EXPRESSION_NESTING`] levels deep, syntax, finite number literals, known names;
//! 5. definitions: no cycles, and only earlier definitions used;
//! 6. `abs`, `sign`, `min`, `max` only where they cannot reach f, g or h;
//! 7. symbolic: `h` free of the input, given `f`/`g` free of the input, each `rhs` affine in the input
//!    (∂²rhs/∂u² identically zero by [`invsim_expr::zero_test`] at the nominal parameter values).
//!
//! Besides the forms of the contract, the reader accepts: a definition as a table
//! `{ expr = "…", unit = "…", doc = "…" }`; an extra output as a plain string (`p = "u*v"`, not
//! accumulated); a plain number where an expression is expected (`g = 1`); states as `[states.NAME]`
//! tables. The model's `name` defaults to the file stem. `[output]` takes three optional numbers beyond
//! the contract: `nominal` (the output value where `invsim derive` classifies the zero dynamics),
//! `reference_offset` and `reference_scale` (the reference is y_d = offset + scale · smoothed cycle, for
//! outputs that are not a vehicle speed; the scale may not be 0).

use invsim_expr::{
    parse, zero_test, Ast, AstKind, Id, Pool, Symbol, FUNCTIONS, NON_SMOOTH_FUNCTIONS,
};
use serde::de::{self, Deserialize, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use sha2::{Digest, Sha256};
use std::collections::{HashMap, HashSet};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Longest expression accepted, in bytes. Real model expressions are a few hundred characters; the limit
/// keeps every recursive pass over the expression (parsing, interning, differentiation) far from the
/// stack's end.
pub const MAX_EXPRESSION_LEN: usize = 4000;

/// Deepest nesting of parentheses and function calls accepted in an expression.
pub const MAX_EXPRESSION_NESTING: usize = 64;

// ----- the validated model -----------------------------------------------------------------------------

/// A validated model: every name checked, definitions inlined, each state's right-hand side split into
/// `f + g·u`. All expressions live in [`Model::pool`]; parameters stay symbols (their values are the
/// defaults, see [`Model::nominal`]).
#[derive(Debug, Clone)]
pub struct Model {
    pub name: String,
    pub description: Option<String>,
    /// The model file (for messages).
    pub file: PathBuf,
    /// SHA-256 of the file's bytes, lowercase hex.
    pub source_hash: String,
    pub pool: Pool,
    /// In file order.
    pub parameters: Vec<Parameter>,
    /// In file order.
    pub definitions: Vec<Definition>,
    /// In file order.
    pub states: Vec<State>,
    pub input: Input,
    pub output: Output,
    /// The extra outputs of `[outputs]`, in file order.
    pub outputs: Vec<ExtraOutput>,
}

/// A named numeric parameter (kept symbolic in derivations; `value` is its default).
#[derive(Debug, Clone)]
pub struct Parameter {
    pub name: String,
    pub symbol: Symbol,
    pub value: f64,
    pub unit: Option<String>,
    pub doc: Option<String>,
}

/// A named intermediate quantity.
#[derive(Debug, Clone)]
pub struct Definition {
    pub name: String,
    pub symbol: Symbol,
    /// The expression as written in the file.
    pub source: String,
    /// The expression as written, parsed (it may refer to earlier definitions).
    pub expr: Id,
    /// The expression with all definitions inlined.
    pub inlined: Id,
    pub unit: Option<String>,
    pub doc: Option<String>,
}

/// A state `x` with `dx/dt = f(x) + g(x) u` (definitions inlined everywhere).
#[derive(Debug, Clone)]
pub struct State {
    pub name: String,
    pub symbol: Symbol,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// `f + g·u`.
    pub rhs: Id,
    /// The drift, free of the input.
    pub f: Id,
    /// The input gain, free of the input.
    pub g: Id,
}

/// The model's single input `u`.
#[derive(Debug, Clone)]
pub struct Input {
    pub name: String,
    pub symbol: Symbol,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// Optional bounds; violations are reported, not clipped.
    pub min: Option<f64>,
    pub max: Option<f64>,
}

/// The tracked output `y = h(x)`.
#[derive(Debug, Clone)]
pub struct Output {
    pub name: String,
    /// `h` with definitions inlined; free of the input.
    pub h: Id,
    /// `h` as written in the file.
    pub source: String,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// The output's nominal value y0 (`nominal`, optional): where `invsim derive` linearises the zero dynamics
    /// (ξ = (y0, 0, …, 0), y^(r) = 0, η at the equilibrium). `None`: [`Output::reference_offset`].
    pub nominal: Option<f64>,
    /// The reference the drive cycle defines for this output: y_d = `reference_offset` +
    /// `reference_scale` · (smoothed cycle), so that every derivative of y_d stays exact (defaults 0 and 1:
    /// y_d is the smoothed cycle itself, a vehicle speed in m/s).
    pub reference_offset: f64,
    pub reference_scale: f64,
}

impl Output {
    /// The nominal output value y0: `nominal`, or else `reference_offset` (the reference at a standstill).
    pub fn nominal_value(&self) -> f64 {
        self.nominal.unwrap_or(self.reference_offset)
    }
}

/// An extra signal of `[outputs]`, reported per sample (and integrated over the run if `accumulate`).
#[derive(Debug, Clone)]
pub struct ExtraOutput {
    pub name: String,
    /// The expression with definitions inlined (it may use the input).
    pub expr: Id,
    /// The expression as written in the file.
    pub source: String,
    pub unit: Option<String>,
    pub doc: Option<String>,
    pub accumulate: bool,
}

impl Model {
    /// Read and validate a model file.
    pub fn from_path(path: &Path) -> Result<Model, ModelError> {
        let bytes = std::fs::read(path).map_err(|e| ModelError {
            file: path.to_path_buf(),
            line: None,
            column: None,
            message: format!("cannot read the model file: {e}"),
            kind: ModelErrorKind::Io,
        })?;
        Model::from_bytes(path, &bytes)
    }

    /// Validate a model given as bytes (which must be UTF-8); `file` is used in messages and for the
    /// default name.
    pub fn from_bytes(file: &Path, bytes: &[u8]) -> Result<Model, ModelError> {
        match std::str::from_utf8(bytes) {
            Ok(text) => Model::from_str(file, text),
            Err(e) => {
                let valid = &bytes[..e.valid_up_to()];
                // The prefix is valid UTF-8 by construction.
                let prefix = std::str::from_utf8(valid).unwrap_or("");
                let reader = Reader { file, text: prefix };
                Err(reader.err(
                    Some(prefix.len()),
                    ModelErrorKind::Io,
                    "the file is not valid UTF-8 (model files must be UTF-8 text)",
                ))
            }
        }
    }

    /// Validate a model given as text; `file` is used in messages and for the default name.
    pub fn from_str(file: &Path, text: &str) -> Result<Model, ModelError> {
        let reader = Reader { file, text };
        reader.read()
    }

    /// The parameters' default values, by symbol.
    pub fn nominal(&self) -> HashMap<Symbol, f64> {
        self.parameters
            .iter()
            .map(|p| (p.symbol, p.value))
            .collect()
    }

    /// The states' symbols, in file order.
    pub fn state_symbols(&self) -> Vec<Symbol> {
        self.states.iter().map(|s| s.symbol).collect()
    }
}

// ----- errors ------------------------------------------------------------------------------------------

/// A model-file error: where it is and what was expected.
///
/// Displays as `FILE:LINE:COLUMN: MESSAGE`, or `FILE: MESSAGE` when the error has no single position
/// (an unreadable file, a missing section).
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}", self.render())]
pub struct ModelError {
    pub file: PathBuf,
    /// 1-based.
    pub line: Option<usize>,
    /// 1-based, counted in characters.
    pub column: Option<usize>,
    pub message: String,
    pub kind: ModelErrorKind,
}

impl ModelError {
    fn render(&self) -> String {
        match (self.line, self.column) {
            (Some(l), Some(c)) => format!("{}:{l}:{c}: {}", self.file.display(), self.message),
            (Some(l), None) => format!("{}:{l}: {}", self.file.display(), self.message),
            _ => format!("{}: {}", self.file.display(), self.message),
        }
    }
}

/// What kind of problem a [`ModelError`] reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ModelErrorKind {
    /// The file cannot be read, or is not UTF-8.
    Io,
    /// TOML syntax error.
    Toml,
    /// Wrong structure: unknown or missing keys and sections, wrong value types, empty `[states]`, input
    /// bounds out of order.
    Schema,
    /// An expression does not parse (including empty and overlong expressions).
    Expression,
    /// A declared name is not an identifier.
    InvalidName,
    /// An expression uses a name that is not declared.
    UnknownName,
    /// A declared name is reserved (`t`, `pi`, `yr`, `xi<N>`, `eta<N>`, function names).
    ReservedName,
    /// A name is declared twice.
    DuplicateName,
    /// Definitions refer to each other in a cycle.
    CircularDefinition,
    /// A definition uses a definition that comes later in the file.
    DefinitionOrder,
    /// A parameter, bound or number literal is NaN or infinite.
    NonFinite,
    /// `abs`, `sign`, `min` or `max` where it would enter f, g or h.
    NonSmooth,
    /// A state's `rhs` is not affine in the input.
    NotAffine,
    /// The output's `h` depends on the input.
    OutputDependsOnInput,
    /// A state's given `f` or `g` depends on the input.
    StateFunctionDependsOnInput,
}

// ----- positions ---------------------------------------------------------------------------------------

/// 1-based line and column (in characters) of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut o = offset.min(text.len());
    while !text.is_char_boundary(o) {
        o -= 1;
    }
    let before = &text[..o];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    // A byte-order mark is invisible in editors, so it does not count as a column.
    let column = before[line_start..]
        .trim_start_matches('\u{feff}')
        .chars()
        .count()
        + 1;
    (line, column)
}

// ----- a TOML tree with spans --------------------------------------------------------------------------
//
// `toml::Spanned<T>` cannot be used throughout: implicitly created tables (`[states.v]` without a
// `[states]` header, dotted keys) have no span, and `Spanned` fails on them. These types speak the same
// private protocol as `Spanned` (a struct with these reserved names, which the TOML deserializer answers
// with start, end and value) and fall back to an unspanned value when no span is offered.

const SPANNED_NAME: &str = "$__serde_spanned_private_Spanned";
const SPANNED_START: &str = "$__serde_spanned_private_start";
const SPANNED_END: &str = "$__serde_spanned_private_end";
const SPANNED_VALUE: &str = "$__serde_spanned_private_value";
const SPANNED_FIELDS: &[&str] = &[SPANNED_START, SPANNED_END, SPANNED_VALUE];
const DATETIME_FIELD: &str = "$__toml_private_datetime";

/// A TOML value with its byte span in the file (when the parser knows it).
#[derive(Debug)]
struct Tv {
    span: Option<Range<usize>>,
    kind: Kind,
}

#[derive(Debug)]
enum Kind {
    Str(String),
    Int(i64),
    Float(f64),
    Bool(bool),
    Datetime,
    Array,
    /// Entries in file order.
    Table(Vec<(Key, Tv)>),
}

/// A table key with its byte span.
#[derive(Debug)]
struct Key {
    name: String,
    span: Option<Range<usize>>,
}

impl Kind {
    fn type_name(&self) -> &'static str {
        match self {
            Kind::Str(_) => "a string",
            Kind::Int(_) => "an integer",
            Kind::Float(_) => "a float",
            Kind::Bool(_) => "a boolean",
            Kind::Datetime => "a date-time",
            Kind::Array => "an array",
            Kind::Table(_) => "a table",
        }
    }
}

impl<'de> Deserialize<'de> for Tv {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Tv, D::Error> {
        d.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, TvVisitor)
    }
}

impl<'de> Deserialize<'de> for Key {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Key, D::Error> {
        d.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, KeyVisitor)
    }
}

/// The value part of a spanned value.
struct KindOnly(Kind);

impl<'de> Deserialize<'de> for KindOnly {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<KindOnly, D::Error> {
        d.deserialize_any(TvVisitor).map(|tv| KindOnly(tv.kind))
    }
}

fn unspanned(kind: Kind) -> Tv {
    Tv { span: None, kind }
}

/// Read the rest of a table whose first key has been read already.
fn read_table<'de, A: MapAccess<'de>>(first: Key, mut map: A) -> Result<Kind, A::Error> {
    if first.name == DATETIME_FIELD {
        map.next_value::<IgnoredAny>()?;
        while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        return Ok(Kind::Datetime);
    }
    let mut entries = Vec::new();
    let value: Tv = map.next_value()?;
    entries.push((first, value));
    while let Some(k) = map.next_key::<Key>()? {
        let v: Tv = map.next_value()?;
        entries.push((k, v));
    }
    Ok(Kind::Table(entries))
}

struct TvVisitor;

impl<'de> Visitor<'de> for TvVisitor {
    type Value = Tv;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a TOML value")
    }
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<Tv, E> {
        Ok(unspanned(Kind::Bool(v)))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Tv, E> {
        Ok(unspanned(Kind::Int(v)))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Tv, E> {
        Ok(unspanned(match i64::try_from(v) {
            Ok(i) => Kind::Int(i),
            Err(_) => Kind::Float(v as f64),
        }))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Tv, E> {
        Ok(unspanned(Kind::Float(v)))
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<Tv, E> {
        Ok(unspanned(Kind::Str(v.to_string())))
    }
    fn visit_string<E: de::Error>(self, v: String) -> Result<Tv, E> {
        Ok(unspanned(Kind::Str(v)))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Tv, A::Error> {
        while seq.next_element::<IgnoredAny>()?.is_some() {}
        Ok(unspanned(Kind::Array))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Tv, A::Error> {
        let Some(first) = map.next_key::<Key>()? else {
            return Ok(unspanned(Kind::Table(Vec::new())));
        };
        if first.span.is_some() || !SPANNED_FIELDS.contains(&first.name.as_str()) {
            return read_table(first, map).map(unspanned);
        }
        // The spanned protocol: start, end and value, in any order.
        let (mut start, mut end, mut kind) = (None, None, None);
        let mut key = Some(first);
        while let Some(k) = key {
            match k.name.as_str() {
                SPANNED_START => start = Some(map.next_value::<usize>()?),
                SPANNED_END => end = Some(map.next_value::<usize>()?),
                SPANNED_VALUE => kind = Some(map.next_value::<KindOnly>()?.0),
                other => {
                    return Err(de::Error::custom(format!(
                        "unexpected key `{other}` in a spanned value"
                    )))
                }
            }
            key = map.next_key::<Key>()?;
        }
        let kind = kind.ok_or_else(|| de::Error::custom("spanned value without a value"))?;
        let span = match (start, end) {
            (Some(s), Some(e)) if s <= e => Some(s..e),
            (Some(s), _) => Some(s..s),
            _ => None,
        };
        Ok(Tv { span, kind })
    }
}

struct KeyVisitor;

impl<'de> Visitor<'de> for KeyVisitor {
    type Value = Key;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a TOML key")
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<Key, E> {
        Ok(Key {
            name: v.to_string(),
            span: None,
        })
    }
    fn visit_string<E: de::Error>(self, v: String) -> Result<Key, E> {
        Ok(Key {
            name: v,
            span: None,
        })
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Key, A::Error> {
        let (mut start, mut end, mut name) = (None, None, None);
        while let Some(k) = map.next_key::<String>()? {
            match k.as_str() {
                SPANNED_START => start = Some(map.next_value::<usize>()?),
                SPANNED_END => end = Some(map.next_value::<usize>()?),
                SPANNED_VALUE => name = Some(map.next_value::<String>()?),
                other => {
                    return Err(de::Error::custom(format!(
                        "unexpected key `{other}` in a spanned key"
                    )))
                }
            }
        }
        let name = name.ok_or_else(|| de::Error::custom("spanned key without a name"))?;
        let span = match (start, end) {
            (Some(s), Some(e)) if s <= e => Some(s..e),
            (Some(s), _) => Some(s..s),
            _ => None,
        };
        Ok(Key { name, span })
    }
}

// ----- names -------------------------------------------------------------------------------------------

fn is_identifier(s: &str) -> bool {
    let mut cs = s.chars();
    matches!(cs.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && cs.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `prefix` followed by one or more digits.
fn is_indexed(s: &str, prefix: &str) -> bool {
    s.strip_prefix(prefix)
        .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Why a name is reserved, if it is.
fn reserved_reason(name: &str) -> Option<String> {
    if name == "t" {
        return Some("`t` is reserved for time".into());
    }
    if name == "pi" {
        return Some("`pi` is the constant π".into());
    }
    if name == "yr" {
        return Some("`yr` is reserved for the r-th derivative of the output, y^(r)".into());
    }
    if is_indexed(name, "xi") || is_indexed(name, "eta") {
        return Some(format!(
            "`{name}` is reserved for the normal-form coordinates xi1 … xiN, eta1 … etaN"
        ));
    }
    if FUNCTIONS.iter().any(|(f, _)| *f == name) {
        return Some(format!("`{name}` is a function of the expression language"));
    }
    None
}

/// Levenshtein distance (for "did you mean" hints on short names).
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// What a declared name is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum NameRef {
    Parameter(usize),
    Definition(usize),
    State(usize),
    Input,
}

impl NameRef {
    fn describe(self) -> &'static str {
        match self {
            NameRef::Parameter(_) => "a parameter",
            NameRef::Definition(_) => "a definition",
            NameRef::State(_) => "a state",
            NameRef::Input => "the input",
        }
    }
}

// ----- raw (checked for structure, not yet for meaning) ------------------------------------------------

/// An expression string and where it is in the file.
#[derive(Debug, Clone)]
struct Src {
    text: String,
    /// Span of the TOML value (quotes included).
    span: Option<Range<usize>>,
    /// Where the expression's bytes are in the file, when the string is written without escapes.
    content: Option<Content>,
}

/// The position of a string's content in the file.
#[derive(Debug, Clone)]
struct Content {
    /// File offset of the content's first byte.
    start: usize,
    /// Offsets (in the value) of line feeds that the file writes as CR LF: TOML reads a multi-line
    /// string's CR LF as LF, which shifts every later byte by one.
    crlf: Vec<usize>,
}

impl Src {
    /// File offset of byte `i` of the expression (or of the string value when it has escapes).
    fn at(&self, i: usize) -> Option<usize> {
        match &self.content {
            Some(c) => {
                let i = i.min(self.text.len());
                Some(c.start + i + c.crlf.iter().filter(|&&p| p <= i).count())
            }
            None => self.span.as_ref().map(|s| s.start),
        }
    }
    /// File offset of the string value itself.
    fn value_start(&self) -> Option<usize> {
        self.span.as_ref().map(|s| s.start)
    }
}

/// Where a string value's content is in the file, when the content is written verbatim (no escapes, no
/// line-ending backslashes).
fn string_content(text: &str, span: &Range<usize>, value: &str) -> Option<Content> {
    let raw = text.get(span.clone())?;
    let delim = if raw.starts_with("\"\"\"") || raw.starts_with("'''") {
        3
    } else if raw.starts_with('"') || raw.starts_with('\'') {
        1
    } else {
        return None;
    };
    if raw.len() < 2 * delim {
        return None;
    }
    let mut start = delim;
    if delim == 3 {
        // A newline right after the opening delimiter is not part of the string.
        if raw[3..].starts_with("\r\n") {
            start += 2;
        } else if raw[3..].starts_with('\n') {
            start += 1;
        }
    }
    let inner = raw.get(start..raw.len() - delim)?;
    let start = span.start + start;
    if inner == value {
        return Some(Content {
            start,
            crlf: Vec::new(),
        });
    }
    if delim == 3 && inner.replace("\r\n", "\n") == value {
        let crlf = inner
            .match_indices("\r\n")
            .enumerate()
            .map(|(k, (r, _))| r - k)
            .collect();
        return Some(Content { start, crlf });
    }
    None
}

#[derive(Debug)]
struct RawParameter {
    name: String,
    at: Option<usize>,
    value: f64,
    unit: Option<String>,
    doc: Option<String>,
}

#[derive(Debug)]
struct RawDefinition {
    name: String,
    at: Option<usize>,
    src: Src,
    unit: Option<String>,
    doc: Option<String>,
}

#[derive(Debug)]
enum RawEquation {
    Rhs(Src),
    Fg(Src, Src),
}

#[derive(Debug)]
struct RawState {
    name: String,
    at: Option<usize>,
    equation: RawEquation,
    unit: Option<String>,
    doc: Option<String>,
}

#[derive(Debug)]
struct RawInput {
    name: String,
    at: Option<usize>,
    unit: Option<String>,
    doc: Option<String>,
    min: Option<f64>,
    max: Option<f64>,
}

#[derive(Debug)]
struct RawOutput {
    name: String,
    h: Src,
    unit: Option<String>,
    doc: Option<String>,
    nominal: Option<f64>,
    reference_offset: Option<f64>,
    reference_scale: Option<f64>,
}

#[derive(Debug)]
struct RawExtra {
    name: String,
    at: Option<usize>,
    src: Src,
    unit: Option<String>,
    doc: Option<String>,
    accumulate: bool,
}

#[derive(Debug, Default)]
struct RawModel {
    name: Option<String>,
    description: Option<String>,
    parameters: Vec<RawParameter>,
    definitions: Vec<RawDefinition>,
    states: Vec<RawState>,
    input: Option<RawInput>,
    output: Option<RawOutput>,
    outputs: Vec<RawExtra>,
}

/// Where an expression is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Role {
    Definition(usize),
    Rhs(usize),
    F(usize),
    G(usize),
    H,
    Extra(usize),
}

impl Role {
    /// Does an expression in this role enter f, g or h?
    fn is_smooth_root(self) -> bool {
        matches!(self, Role::Rhs(_) | Role::F(_) | Role::G(_) | Role::H)
    }
}

/// One expression of the model, parsed.
struct Item {
    role: Role,
    src: Src,
    ast: Ast,
}

const TOP_KEYS_SHOWN: &str =
    "name, description, [parameters], [definitions], [states], [input], [output], [outputs]";

// ----- the reader --------------------------------------------------------------------------------------

struct Reader<'a> {
    file: &'a Path,
    text: &'a str,
}

type Entries = [(Key, Tv)];

impl<'a> Reader<'a> {
    fn err(
        &self,
        at: Option<usize>,
        kind: ModelErrorKind,
        message: impl Into<String>,
    ) -> ModelError {
        let (line, column) = match at {
            Some(o) => {
                let (l, c) = line_col(self.text, o);
                (Some(l), Some(c))
            }
            None => (None, None),
        };
        ModelError {
            file: self.file.to_path_buf(),
            line,
            column,
            message: message.into(),
            kind,
        }
    }

    /// "line 5, column 3" for messages that refer to another place.
    fn place(&self, at: Option<usize>) -> String {
        match at {
            Some(o) => {
                let (l, c) = line_col(self.text, o);
                format!("line {l}, column {c}")
            }
            None => "an unknown position".into(),
        }
    }

    fn line(&self, at: Option<usize>) -> String {
        match at {
            Some(o) => format!("line {}", line_col(self.text, o).0),
            None => "an unknown line".into(),
        }
    }

    fn read(&self) -> Result<Model, ModelError> {
        let hash = Sha256::digest(self.text.as_bytes());
        let source_hash: String = hash.iter().map(|b| format!("{b:02x}")).collect();
        let root: Tv = toml::from_str(self.text).map_err(|e| {
            let message = e
                .message()
                .trim()
                .lines()
                .map(str::trim)
                .collect::<Vec<_>>()
                .join("; ");
            self.err(
                e.span().map(|s| s.start),
                ModelErrorKind::Toml,
                format!("TOML syntax error: {message}"),
            )
        })?;
        let raw = self.structure(&root)?;
        self.build(raw, source_hash)
    }

    // ----- structure ---------------------------------------------------------------------------------

    fn table<'t>(&self, v: &'t Tv, what: &str) -> Result<&'t Entries, ModelError> {
        match &v.kind {
            Kind::Table(entries) => Ok(entries),
            k => Err(self.err(
                v.span.as_ref().map(|s| s.start),
                ModelErrorKind::Schema,
                format!("{what} must be a table, found {}", k.type_name()),
            )),
        }
    }

    fn string(&self, v: &Tv, what: &str) -> Result<String, ModelError> {
        match &v.kind {
            Kind::Str(s) => Ok(s.clone()),
            k => Err(self.err(
                v.span.as_ref().map(|s| s.start),
                ModelErrorKind::Schema,
                format!("{what} must be a string, found {}", k.type_name()),
            )),
        }
    }

    fn number(&self, v: &Tv, what: &str) -> Result<f64, ModelError> {
        let at = v.span.as_ref().map(|s| s.start);
        let x = match &v.kind {
            Kind::Int(i) => *i as f64,
            Kind::Float(x) => *x,
            k => {
                return Err(self.err(
                    at,
                    ModelErrorKind::Schema,
                    format!("{what} must be a number, found {}", k.type_name()),
                ))
            }
        };
        if !x.is_finite() {
            return Err(self.err(
                at,
                ModelErrorKind::NonFinite,
                format!("{what} must be finite, found {x}"),
            ));
        }
        Ok(x)
    }

    fn boolean(&self, v: &Tv, what: &str) -> Result<bool, ModelError> {
        match &v.kind {
            Kind::Bool(b) => Ok(*b),
            k => Err(self.err(
                v.span.as_ref().map(|s| s.start),
                ModelErrorKind::Schema,
                format!("{what} must be true or false, found {}", k.type_name()),
            )),
        }
    }

    /// An expression value: a string (or, for convenience, a plain number).
    fn expression(&self, v: &Tv, what: &str) -> Result<Src, ModelError> {
        let at = v.span.as_ref().map(|s| s.start);
        let text = match &v.kind {
            Kind::Str(s) => {
                let content = v
                    .span
                    .as_ref()
                    .and_then(|span| string_content(self.text, span, s));
                return Ok(Src {
                    text: s.clone(),
                    span: v.span.clone(),
                    content,
                });
            }
            Kind::Int(i) => i.to_string(),
            Kind::Float(x) if x.is_finite() => format!("{x:?}"),
            Kind::Float(x) => {
                return Err(self.err(
                    at,
                    ModelErrorKind::NonFinite,
                    format!("{what} must be finite, found {x}"),
                ));
            }
            k => {
                return Err(self.err(
                    at,
                    ModelErrorKind::Schema,
                    format!(
                        "{what} must be an expression in a string, e.g. \"-k*x1 + u\"; found {}",
                        k.type_name()
                    ),
                ))
            }
        };
        Ok(Src {
            text,
            span: v.span.clone(),
            content: None,
        })
    }

    fn optional_string(
        &self,
        entries: &Entries,
        key: &str,
        what: &str,
    ) -> Result<Option<String>, ModelError> {
        get(entries, key)
            .map(|v| self.string(v, &format!("{what}'s `{key}`")))
            .transpose()
    }

    /// Reject keys not in `allowed`.
    fn known_keys(
        &self,
        entries: &Entries,
        allowed: &[&str],
        what: &str,
    ) -> Result<(), ModelError> {
        for (k, _) in entries {
            if !allowed.contains(&k.name.as_str()) {
                let list: Vec<String> = allowed.iter().map(|a| format!("`{a}`")).collect();
                return Err(self.err(
                    key_at(k),
                    ModelErrorKind::Schema,
                    format!(
                        "unknown key `{}` in {what}; expected {}",
                        k.name.escape_debug(),
                        list.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    fn structure(&self, root: &Tv) -> Result<RawModel, ModelError> {
        let entries = self.table(root, "the model file")?;
        let mut raw = RawModel::default();
        let mut seen: HashSet<&str> = HashSet::new();
        for (k, v) in entries {
            seen.insert(k.name.as_str());
            match k.name.as_str() {
                "name" => {
                    let name = self.string(v, "the model's `name`")?;
                    if name.trim().is_empty() {
                        return Err(self.err(
                            tv_at(v),
                            ModelErrorKind::Schema,
                            "the model's `name` is empty",
                        ));
                    }
                    raw.name = Some(name);
                }
                "description" => {
                    raw.description = Some(self.string(v, "the model's `description`")?)
                }
                "parameters" => raw.parameters = self.parameters(self.table(v, "[parameters]")?)?,
                "definitions" => {
                    raw.definitions = self.definitions(self.table(v, "[definitions]")?)?
                }
                "states" => {
                    let states = self.table(v, "[states]")?;
                    if states.is_empty() {
                        return Err(self.err(
                            tv_at(v).or_else(|| key_at(k)),
                            ModelErrorKind::Schema,
                            "[states] is empty: a model needs at least one state, e.g. x1 = { rhs = \"-x1 + u\" }",
                        ));
                    }
                    raw.states = self.states(states)?;
                }
                "input" => raw.input = Some(self.input(v)?),
                "output" => raw.output = Some(self.output(v)?),
                "outputs" => raw.outputs = self.extra_outputs(self.table(v, "[outputs]")?)?,
                other => {
                    return Err(self.err(
                        key_at(k),
                        ModelErrorKind::Schema,
                        format!(
                            "unknown top-level key `{}`; expected one of: {TOP_KEYS_SHOWN}",
                            other.escape_debug()
                        ),
                    ))
                }
            }
        }
        for (section, example) in [
            ("states", "[states] x1 = { rhs = \"-x1 + u\" }"),
            ("input", "[input] name = \"u\""),
            ("output", "[output] name = \"y\", h = \"x1\""),
        ] {
            if !seen.contains(section) {
                return Err(self.err(
                    None,
                    ModelErrorKind::Schema,
                    format!("missing [{section}] section; a model needs one, e.g. {example}"),
                ));
            }
        }
        Ok(raw)
    }

    fn parameters(&self, entries: &Entries) -> Result<Vec<RawParameter>, ModelError> {
        let mut out = Vec::new();
        for (k, v) in entries {
            let what = format!("parameter `{}`", k.name.escape_debug());
            let at = key_at(k);
            let p = match &v.kind {
                Kind::Int(_) | Kind::Float(_) => RawParameter {
                    name: k.name.clone(),
                    at,
                    value: self.number(v, &format!("the value of {what}"))?,
                    unit: None,
                    doc: None,
                },
                Kind::Table(t) => {
                    self.known_keys(t, &["value", "unit", "doc"], &what)?;
                    let Some(value) = get(t, "value") else {
                        return Err(self.err(
                            tv_at(v).or(at),
                            ModelErrorKind::Schema,
                            format!("{what} has no `value`; expected e.g. {} = {{ value = 1.0, unit = \"kg\" }}", k.name),
                        ));
                    };
                    RawParameter {
                        name: k.name.clone(),
                        at,
                        value: self.number(value, &format!("the value of {what}"))?,
                        unit: self.optional_string(t, "unit", &what)?,
                        doc: self.optional_string(t, "doc", &what)?,
                    }
                }
                other => {
                    return Err(self.err(
                        tv_at(v),
                        ModelErrorKind::Schema,
                        format!(
                            "{what} must be a number or a table {{ value = …, unit = \"…\", doc = \"…\" }}; found {}",
                            other.type_name()
                        ),
                    ))
                }
            };
            out.push(p);
        }
        Ok(out)
    }

    fn definitions(&self, entries: &Entries) -> Result<Vec<RawDefinition>, ModelError> {
        let mut out = Vec::new();
        for (k, v) in entries {
            let what = format!("definition `{}`", k.name.escape_debug());
            let (src, unit, doc) = match &v.kind {
                Kind::Table(t) => {
                    self.known_keys(t, &["expr", "unit", "doc"], &what)?;
                    let Some(e) = get(t, "expr") else {
                        return Err(self.err(
                            tv_at(v).or(key_at(k)),
                            ModelErrorKind::Schema,
                            format!("{what} has no `expr`; write {} = \"…\" or {{ expr = \"…\", unit = \"…\" }}", k.name),
                        ));
                    };
                    (
                        self.expression(e, &what)?,
                        self.optional_string(t, "unit", &what)?,
                        self.optional_string(t, "doc", &what)?,
                    )
                }
                _ => (self.expression(v, &what)?, None, None),
            };
            out.push(RawDefinition {
                name: k.name.clone(),
                at: key_at(k),
                src,
                unit,
                doc,
            });
        }
        Ok(out)
    }

    fn states(&self, entries: &Entries) -> Result<Vec<RawState>, ModelError> {
        let mut out = Vec::new();
        for (k, v) in entries {
            let what = format!("state `{}`", k.name.escape_debug());
            let Kind::Table(t) = &v.kind else {
                return Err(self.err(
                    tv_at(v),
                    ModelErrorKind::Schema,
                    format!(
                        "{what} must be a table with `rhs` or with `f` and `g`, e.g. {} = {{ rhs = \"…\" }}; found {}",
                        k.name,
                        v.kind.type_name()
                    ),
                ));
            };
            self.known_keys(t, &["rhs", "f", "g", "unit", "doc"], &what)?;
            let at_table = tv_at(v).or(key_at(k));
            let equation = match (get_key(t, "rhs"), get_key(t, "f"), get_key(t, "g")) {
                (Some((_, rhs)), None, None) => RawEquation::Rhs(self.expression(rhs, &format!("{what}'s rhs"))?),
                (None, Some((_, f)), Some((_, g))) => RawEquation::Fg(
                    self.expression(f, &format!("{what}'s f"))?,
                    self.expression(g, &format!("{what}'s g"))?,
                ),
                (Some(_), Some((fk, _)), _) | (Some(_), None, Some((fk, _))) => {
                    return Err(self.err(
                        key_at(fk),
                        ModelErrorKind::Schema,
                        format!("{what} gives both `rhs` and `{}`; give either `rhs` or `f` and `g`, not both", fk.name),
                    ))
                }
                (None, Some(_), None) => {
                    return Err(self.err(
                        at_table,
                        ModelErrorKind::Schema,
                        format!("{what} gives `f` but no `g`; give both `f` and `g` (the input gain), or `rhs`"),
                    ))
                }
                (None, None, Some(_)) => {
                    return Err(self.err(
                        at_table,
                        ModelErrorKind::Schema,
                        format!("{what} gives `g` but no `f`; give both `f` and `g`, or `rhs`"),
                    ))
                }
                (None, None, None) => {
                    return Err(self.err(
                        at_table,
                        ModelErrorKind::Schema,
                        format!("{what} has no equation; give `rhs` (affine in the input) or `f` and `g`"),
                    ))
                }
            };
            out.push(RawState {
                name: k.name.clone(),
                at: key_at(k),
                equation,
                unit: self.optional_string(t, "unit", &what)?,
                doc: self.optional_string(t, "doc", &what)?,
            });
        }
        Ok(out)
    }

    fn input(&self, v: &Tv) -> Result<RawInput, ModelError> {
        let t = self.table(v, "[input]")?;
        self.known_keys(t, &["name", "unit", "doc", "min", "max"], "[input]")?;
        let Some(name_v) = get(t, "name") else {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                "[input] has no `name`; expected e.g. name = \"u\"",
            ));
        };
        let name = self.string(name_v, "the input's `name`")?;
        let at = match (&name_v.kind, &name_v.span) {
            (Kind::Str(s), Some(span)) => string_content(self.text, span, s)
                .map(|c| c.start)
                .or(Some(span.start)),
            _ => tv_at(name_v),
        };
        let min = get(t, "min")
            .map(|m| self.number(m, "the input's `min`"))
            .transpose()?;
        let max = get(t, "max")
            .map(|m| self.number(m, "the input's `max`"))
            .transpose()?;
        if let (Some(lo), Some(hi)) = (min, max) {
            if lo > hi {
                return Err(self.err(
                    get(t, "min").and_then(tv_at),
                    ModelErrorKind::Schema,
                    format!(
                        "the input's bounds are reversed: min = {lo} is greater than max = {hi}"
                    ),
                ));
            }
        }
        Ok(RawInput {
            name,
            at,
            unit: self.optional_string(t, "unit", "[input]")?,
            doc: self.optional_string(t, "doc", "[input]")?,
            min,
            max,
        })
    }

    fn output(&self, v: &Tv) -> Result<RawOutput, ModelError> {
        let t = self.table(v, "[output]")?;
        self.known_keys(
            t,
            &[
                "name",
                "h",
                "unit",
                "doc",
                "nominal",
                "reference_offset",
                "reference_scale",
            ],
            "[output]",
        )?;
        let Some(name_v) = get(t, "name") else {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                "[output] has no `name`; expected e.g. name = \"y\"",
            ));
        };
        let name = self.string(name_v, "the output's `name`")?;
        if !is_identifier(&name) {
            return Err(self.err(
                tv_at(name_v),
                ModelErrorKind::InvalidName,
                format!(
                    "invalid output name `{}`: names are identifiers [A-Za-z_][A-Za-z0-9_]*",
                    name.escape_debug()
                ),
            ));
        }
        let Some(h) = get(t, "h") else {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                "[output] has no `h`; expected the output as an expression of the states, e.g. h = \"x1\"",
            ));
        };
        // Optional numbers: the nominal output value and the affine map from the drive cycle to the reference.
        let optional_number = |key: &str| {
            get(t, key)
                .map(|v| self.number(v, &format!("the output's `{key}`")))
                .transpose()
        };
        let nominal = optional_number("nominal")?;
        let reference_offset = optional_number("reference_offset")?;
        let reference_scale = optional_number("reference_scale")?;
        if reference_scale == Some(0.0) {
            return Err(self.err(
                get(t, "reference_scale").and_then(tv_at),
                ModelErrorKind::Schema,
                "the output's `reference_scale` is 0: the reference y_d = reference_offset + reference_scale · \
                 (smoothed cycle) would not follow the cycle; give a nonzero factor (default 1)",
            ));
        }
        Ok(RawOutput {
            name,
            h: self.expression(h, "the output's h")?,
            unit: self.optional_string(t, "unit", "[output]")?,
            doc: self.optional_string(t, "doc", "[output]")?,
            nominal,
            reference_offset,
            reference_scale,
        })
    }

    fn extra_outputs(&self, entries: &Entries) -> Result<Vec<RawExtra>, ModelError> {
        let mut out = Vec::new();
        for (k, v) in entries {
            let what = format!("output `{}`", k.name.escape_debug());
            if !is_identifier(&k.name) {
                return Err(self.err(
                    key_at(k),
                    ModelErrorKind::InvalidName,
                    format!(
                        "invalid name for {what}: names are identifiers [A-Za-z_][A-Za-z0-9_]*"
                    ),
                ));
            }
            let (src, unit, doc, accumulate) = match &v.kind {
                Kind::Table(t) => {
                    self.known_keys(t, &["expr", "unit", "doc", "accumulate"], &what)?;
                    let Some(e) = get(t, "expr") else {
                        return Err(self.err(
                            tv_at(v).or(key_at(k)),
                            ModelErrorKind::Schema,
                            format!("{what} has no `expr`; expected e.g. {} = {{ expr = \"…\", unit = \"…\" }}", k.name),
                        ));
                    };
                    (
                        self.expression(e, &what)?,
                        self.optional_string(t, "unit", &what)?,
                        self.optional_string(t, "doc", &what)?,
                        get(t, "accumulate")
                            .map(|a| self.boolean(a, &format!("{what}'s `accumulate`")))
                            .transpose()?,
                    )
                }
                _ => (self.expression(v, &what)?, None, None, None),
            };
            out.push(RawExtra {
                name: k.name.clone(),
                at: key_at(k),
                src,
                unit,
                doc,
                accumulate: accumulate.unwrap_or(false),
            });
        }
        Ok(out)
    }

    // ----- names, expressions and derivation ---------------------------------------------------------

    fn build(&self, raw: RawModel, source_hash: String) -> Result<Model, ModelError> {
        let (Some(input), Some(output)) = (raw.input, raw.output) else {
            // `structure` has already reported a missing section.
            return Err(self.err(
                None,
                ModelErrorKind::Schema,
                "missing [input] or [output] section",
            ));
        };

        // Declared names: identifiers, not reserved, unique.
        let mut decls: Vec<(&str, Option<usize>, NameRef)> = Vec::new();
        decls.extend(
            raw.parameters
                .iter()
                .enumerate()
                .map(|(i, p)| (p.name.as_str(), p.at, NameRef::Parameter(i))),
        );
        decls.extend(
            raw.definitions
                .iter()
                .enumerate()
                .map(|(i, d)| (d.name.as_str(), d.at, NameRef::Definition(i))),
        );
        decls.extend(
            raw.states
                .iter()
                .enumerate()
                .map(|(i, s)| (s.name.as_str(), s.at, NameRef::State(i))),
        );
        decls.push((input.name.as_str(), input.at, NameRef::Input));
        decls.sort_by_key(|&(_, at, _)| at.unwrap_or(usize::MAX));
        let mut names: HashMap<&str, (Option<usize>, NameRef)> = HashMap::new();
        for &(name, at, what) in &decls {
            if !is_identifier(name) {
                return Err(self.err(
                    at,
                    ModelErrorKind::InvalidName,
                    format!(
                        "invalid name `{}` for {}: names are identifiers [A-Za-z_][A-Za-z0-9_]*",
                        name.escape_debug(),
                        what.describe()
                    ),
                ));
            }
            if let Some(why) = reserved_reason(name) {
                return Err(self.err(
                    at,
                    ModelErrorKind::ReservedName,
                    format!(
                        "reserved name `{name}` cannot be declared as {}: {why}",
                        what.describe()
                    ),
                ));
            }
            if let Some(&(first_at, first)) = names.get(name) {
                return Err(self.err(
                    at,
                    ModelErrorKind::DuplicateName,
                    format!(
                        "duplicate name `{name}`: declared as {} at {} and again here as {}",
                        first.describe(),
                        self.place(first_at),
                        what.describe()
                    ),
                ));
            }
            names.insert(name, (at, what));
        }
        // Extra outputs become CSV columns next to the states and the input.
        for e in &raw.outputs {
            let clash = match names.get(e.name.as_str()) {
                Some((_, NameRef::State(_))) => Some("a state"),
                Some((_, NameRef::Input)) => Some("the input"),
                _ if e.name == "t" => Some("the time column `t`"),
                _ if is_indexed(&e.name, "yd_") => {
                    Some("a column of output derivatives (yd_0, yd_1, …)")
                }
                _ if is_indexed(&e.name, "eta") => {
                    Some("a column of internal states (eta1, eta2, …)")
                }
                _ => None,
            };
            if let Some(clash) = clash {
                return Err(self.err(
                    e.at,
                    ModelErrorKind::DuplicateName,
                    format!(
                        "output `{}` has the same name as {clash}; results are reported in columns by name, \
                         so choose another name",
                        e.name
                    ),
                ));
            }
        }

        // Parse every expression, in file order.
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
        pending.push((Role::H, &output.h));
        pending.extend(
            raw.outputs
                .iter()
                .enumerate()
                .map(|(i, e)| (Role::Extra(i), &e.src)),
        );
        pending.sort_by_key(|(_, src)| src.span.as_ref().map_or(usize::MAX, |s| s.start));

        let describe = |role: Role| -> String {
            match role {
                Role::Definition(i) => format!("definition `{}`", raw.definitions[i].name),
                Role::Rhs(i) => format!("state `{}`'s rhs", raw.states[i].name),
                Role::F(i) => format!("state `{}`'s f", raw.states[i].name),
                Role::G(i) => format!("state `{}`'s g", raw.states[i].name),
                Role::H => "the output's h".to_string(),
                Role::Extra(i) => format!("output `{}`", raw.outputs[i].name),
            }
        };

        let mut items: Vec<Item> = Vec::with_capacity(pending.len());
        for (role, src) in pending {
            let ast = self.parse_expression(src, &describe(role))?;
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

        // Definitions: the graph of definition uses, with the offset of each use.
        let ndef = raw.definitions.len();
        let mut uses: Vec<Vec<(usize, Option<usize>)>> = vec![Vec::new(); ndef];
        let def_item: HashMap<usize, usize> = items
            .iter()
            .enumerate()
            .filter_map(|(k, it)| match it.role {
                Role::Definition(i) => Some((i, k)),
                _ => None,
            })
            .collect();
        let def_uses = |item: &Item| -> Vec<(usize, Option<usize>)> {
            item.ast
                .identifiers()
                .into_iter()
                .filter_map(|(name, span)| match names.get(name) {
                    Some(&(_, NameRef::Definition(j))) => Some((j, item.src.at(span.start))),
                    _ => None,
                })
                .collect()
        };
        for (i, u) in uses.iter_mut().enumerate() {
            if let Some(&k) = def_item.get(&i) {
                *u = def_uses(&items[k]);
            }
        }
        if let Some(cycle) = find_cycle(&uses) {
            let path: Vec<&str> = cycle
                .iter()
                .map(|&i| raw.definitions[i].name.as_str())
                .collect();
            let at = uses[cycle[0]]
                .iter()
                .find(|(j, _)| *j == cycle[1])
                .and_then(|&(_, at)| at);
            return Err(self.err(
                at,
                ModelErrorKind::CircularDefinition,
                format!("circular definition: {}", path.join(" -> ")),
            ));
        }
        for (i, u) in uses.iter().enumerate() {
            if let Some(&(j, at)) = u.iter().find(|&&(j, _)| j > i) {
                let (a, b) = (&raw.definitions[i].name, &raw.definitions[j].name);
                return Err(self.err(
                    at,
                    ModelErrorKind::DefinitionOrder,
                    format!(
                        "definition `{a}` uses `{b}`, which is defined later ({}); definitions may use only \
                         earlier ones, so move `{b}` above `{a}`",
                        self.line(raw.definitions[j].at)
                    ),
                ));
            }
        }

        // Non-smooth functions: never in rhs, f, g or h, nor in a definition that reaches them.
        let mut reached_by: Vec<Option<Role>> = vec![None; ndef];
        for item in items.iter().filter(|it| it.role.is_smooth_root()) {
            let mut stack: Vec<usize> = def_uses(item).into_iter().map(|(j, _)| j).collect();
            while let Some(j) = stack.pop() {
                if reached_by[j].is_none() {
                    reached_by[j] = Some(item.role);
                    stack.extend(uses[j].iter().map(|&(k, _)| k));
                }
            }
        }
        for item in &items {
            let Some((call, span)) = item
                .ast
                .calls()
                .into_iter()
                .find(|(name, _)| NON_SMOOTH_FUNCTIONS.contains(name))
            else {
                continue;
            };
            let at = item.src.at(span.start);
            let root = match item.role {
                Role::Definition(i) => match reached_by[i] {
                    Some(root) => format!("{} (used by {})", describe(item.role), describe(root)),
                    None => continue,
                },
                Role::Extra(_) => continue,
                role => describe(role),
            };
            return Err(self.err(
                at,
                ModelErrorKind::NonSmooth,
                format!(
                    "`{call}` is not smooth, so it may not enter f, g or h: abs, sign, min and max are allowed only \
                     in [outputs] (found in {root})"
                ),
            ));
        }

        // Symbols in a fixed order: parameters, definitions, states, input.
        let mut pool = Pool::new();
        let parameters: Vec<Parameter> = raw
            .parameters
            .into_iter()
            .map(|p| Parameter {
                symbol: pool.symbol(&p.name),
                name: p.name,
                value: p.value,
                unit: p.unit,
                doc: p.doc,
            })
            .collect();
        let nominal: HashMap<Symbol, f64> =
            parameters.iter().map(|p| (p.symbol, p.value)).collect();
        for d in &raw.definitions {
            pool.symbol(&d.name);
        }
        for s in &raw.states {
            pool.symbol(&s.name);
        }
        let u = pool.symbol(&input.name);
        let u_var = pool.var(u);
        let zero = pool.zero();
        let u_zero: HashMap<Symbol, Id> = HashMap::from([(u, zero)]);

        let mut interned: HashMap<Role, Id> = HashMap::new();
        for item in &items {
            let id = pool.from_ast(&item.ast);
            interned.insert(item.role, id);
        }
        let expr_of = |role: Role| interned.get(&role).copied().unwrap_or(zero);

        // Inline definitions in order (each uses only earlier ones).
        let mut inline: HashMap<Symbol, Id> = HashMap::new();
        let mut definitions = Vec::with_capacity(ndef);
        for (i, d) in raw.definitions.into_iter().enumerate() {
            let symbol = pool.symbol(&d.name);
            let expr = expr_of(Role::Definition(i));
            let inlined = pool.substitute(expr, &inline);
            inline.insert(symbol, inlined);
            definitions.push(Definition {
                name: d.name,
                symbol,
                source: d.src.text,
                expr,
                inlined,
                unit: d.unit,
                doc: d.doc,
            });
        }
        let def_symbols: HashMap<Symbol, usize> = definitions
            .iter()
            .enumerate()
            .map(|(i, d)| (d.symbol, i))
            .collect();

        // Where an expression depends on the input: its own use of `u`, or a definition that brings it in.
        let input_dependency = |pool: &Pool, item: &Item| -> (Option<usize>, String) {
            let ids = item.ast.identifiers();
            if let Some((_, span)) = ids.iter().find(|(n, _)| *n == input.name) {
                return (item.src.at(span.start), String::new());
            }
            for (n, span) in &ids {
                if let Some(sym) = pool.find_symbol(n) {
                    if let Some(&j) = def_symbols.get(&sym) {
                        if pool.depends_on(definitions[j].inlined, u) {
                            return (
                                item.src.at(span.start),
                                format!(" through definition `{n}`"),
                            );
                        }
                    }
                }
            }
            (item.src.at(0), String::new())
        };
        let item_of = |role: Role| items.iter().find(|it| it.role == role);

        // Does `e` really depend on the input (not just syntactically)?
        let depends_on_input = |pool: &mut Pool, e: Id| -> bool {
            if !pool.depends_on(e, u) {
                return false;
            }
            let d = pool.diff(e, u);
            !zero_test(pool, d, &nominal).is_zero()
        };

        // States: split into f + g u.
        let mut states = Vec::with_capacity(raw.states.len());
        for (i, s) in raw.states.into_iter().enumerate() {
            let symbol = pool.symbol(&s.name);
            let (f, g) = match &s.equation {
                RawEquation::Rhs(src) => {
                    let rhs = pool.substitute(expr_of(Role::Rhs(i)), &inline);
                    let f = pool.substitute(rhs, &u_zero);
                    let g = pool.diff(rhs, u);
                    let g2 = pool.diff(g, u);
                    if !zero_test(&mut pool, g2, &nominal).is_zero() {
                        return Err(self.err(
                            src.at(0),
                            ModelErrorKind::NotAffine,
                            format!(
                                "state `{}`'s right-hand side is not affine in the input `{}`: ∂²/∂{}² = {} \
                                 (the method needs dx/dt = f(x) + g(x)·{})",
                                s.name,
                                input.name,
                                input.name,
                                abbreviate(pool.display(g2)),
                                input.name
                            ),
                        ));
                    }
                    (f, pool.substitute(g, &u_zero))
                }
                RawEquation::Fg(..) => {
                    let mut fg = [zero; 2];
                    for (slot, role, which) in [(0, Role::F(i), "f"), (1, Role::G(i), "g")] {
                        let e = pool.substitute(expr_of(role), &inline);
                        if depends_on_input(&mut pool, e) {
                            let (at, via) = match item_of(role) {
                                Some(item) => input_dependency(&pool, item),
                                None => (None, String::new()),
                            };
                            return Err(self.err(
                                at,
                                ModelErrorKind::StateFunctionDependsOnInput,
                                format!(
                                    "state `{}`'s {which} depends on the input `{}`{via}; f and g must be functions \
                                     of the states (dx/dt = f(x) + g(x)·{}), or write the state as rhs = \"…\"",
                                    s.name, input.name, input.name
                                ),
                            ));
                        }
                        fg[slot] = pool.substitute(e, &u_zero);
                    }
                    (fg[0], fg[1])
                }
            };
            let gu = pool.mul2(g, u_var);
            let rhs = pool.add2(f, gu);
            states.push(State {
                name: s.name,
                symbol,
                unit: s.unit,
                doc: s.doc,
                rhs,
                f,
                g,
            });
        }

        // The output: h(x), free of the input.
        let h = pool.substitute(expr_of(Role::H), &inline);
        if depends_on_input(&mut pool, h) {
            let (at, via) = match item_of(Role::H) {
                Some(item) => input_dependency(&pool, item),
                None => (None, String::new()),
            };
            return Err(self.err(
                at,
                ModelErrorKind::OutputDependsOnInput,
                format!(
                    "the output's h depends on the input `{}`{via}; h may depend on the states only (the method \
                     needs y = h(x)); report input-dependent signals in [outputs]",
                    input.name
                ),
            ));
        }
        let h = pool.substitute(h, &u_zero);
        let output = Output {
            name: output.name,
            h,
            source: output.h.text,
            unit: output.unit,
            doc: output.doc,
            nominal: output.nominal,
            reference_offset: output.reference_offset.unwrap_or(0.0),
            reference_scale: output.reference_scale.unwrap_or(1.0),
        };

        let outputs = raw
            .outputs
            .into_iter()
            .enumerate()
            .map(|(i, e)| ExtraOutput {
                expr: pool.substitute(expr_of(Role::Extra(i)), &inline),
                name: e.name,
                source: e.src.text,
                unit: e.unit,
                doc: e.doc,
                accumulate: e.accumulate,
            })
            .collect();

        let name = raw.name.unwrap_or_else(|| {
            self.file
                .file_stem()
                .and_then(|s| s.to_str())
                .filter(|s| !s.is_empty())
                .unwrap_or("model")
                .to_string()
        });
        Ok(Model {
            name,
            description: raw.description,
            file: self.file.to_path_buf(),
            source_hash,
            pool,
            parameters,
            definitions,
            states,
            input: Input {
                name: input.name,
                symbol: u,
                unit: input.unit,
                doc: input.doc,
                min: input.min,
                max: input.max,
            },
            output,
            outputs,
        })
    }

    /// Parse one expression: not empty, not too large, valid syntax, finite number literals.
    fn parse_expression(&self, src: &Src, what: &str) -> Result<Ast, ModelError> {
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
        let ast = parse(&src.text).map_err(|e| {
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

fn get<'t>(entries: &'t Entries, key: &str) -> Option<&'t Tv> {
    get_key(entries, key).map(|(_, v)| v)
}

fn get_key<'t>(entries: &'t Entries, key: &str) -> Option<(&'t Key, &'t Tv)> {
    entries
        .iter()
        .find(|(k, _)| k.name == key)
        .map(|(k, v)| (k, v))
}

fn key_at(k: &Key) -> Option<usize> {
    k.span.as_ref().map(|s| s.start)
}

fn tv_at(v: &Tv) -> Option<usize> {
    v.span.as_ref().map(|s| s.start)
}

/// An expression for a message, cut to a readable length.
fn abbreviate(text: String) -> String {
    const MAX: usize = 200;
    match text.char_indices().nth(MAX) {
        Some((i, _)) => format!("{} …", &text[..i]),
        None => text,
    }
}

/// A declared name close to an unknown one, if exactly one is closest.
fn suggestion<'n>(unknown: &str, names: impl Iterator<Item = &'n str>) -> Option<&'n str> {
    let limit = if unknown.chars().count() <= 3 { 1 } else { 2 };
    let mut best: Vec<(usize, &str)> = names
        .map(|n| (edit_distance(unknown, n), n))
        .filter(|&(d, _)| d <= limit)
        .collect();
    best.sort();
    match best.as_slice() {
        [(d, n)] => Some(*n).filter(|_| *d > 0),
        [(d1, n), (d2, _), ..] if d1 < d2 => Some(*n),
        _ => None,
    }
}

/// A cycle in the definition graph, rotated to start at its earliest definition and closed
/// (`[a, b, a]`), or `None`.
fn find_cycle(uses: &[Vec<(usize, Option<usize>)>]) -> Option<Vec<usize>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    let n = uses.len();
    let mut mark = vec![Mark::New; n];
    for root in 0..n {
        if mark[root] != Mark::New {
            continue;
        }
        // Iterative depth-first search: (node, next edge index), with the open path on the stack.
        let mut stack: Vec<(usize, usize)> = vec![(root, 0)];
        mark[root] = Mark::Open;
        while let Some(&mut (v, ref mut next)) = stack.last_mut() {
            if let Some(&(w, _)) = uses[v].get(*next) {
                *next += 1;
                match mark.get(w).copied() {
                    Some(Mark::New) => {
                        mark[w] = Mark::Open;
                        stack.push((w, 0));
                    }
                    Some(Mark::Open) => {
                        let from = stack.iter().position(|&(x, _)| x == w).unwrap_or(0);
                        let mut cycle: Vec<usize> = stack[from..].iter().map(|&(x, _)| x).collect();
                        let first = cycle
                            .iter()
                            .enumerate()
                            .min_by_key(|&(_, &x)| x)
                            .map_or(0, |(k, _)| k);
                        cycle.rotate_left(first);
                        cycle.push(cycle[0]);
                        return Some(cycle);
                    }
                    _ => {}
                }
            } else {
                mark[v] = Mark::Done;
                stack.pop();
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        let text = "ab\nçd\n";
        assert_eq!(line_col(text, 0), (1, 1));
        assert_eq!(line_col(text, 3), (2, 1));
        assert_eq!(line_col(text, 5), (2, 2));
        assert_eq!(line_col(text, 100), (3, 1));
    }

    #[test]
    fn string_content_only_without_escapes() {
        let text = r#"a = "x + y"
b = "x\ty"
c = 'lit'
"#;
        let at =
            |span: Range<usize>, value: &str| string_content(text, &span, value).map(|c| c.start);
        assert_eq!(at(4..11, "x + y"), Some(5));
        assert_eq!(at(16..22, "x\ty"), None);
        assert_eq!(at(27..32, "lit"), Some(28));

        let text = "a = '''\r\nx +\r\n y'''";
        let c = string_content(text, &(4..text.len()), "x +\n y").expect("verbatim but for CR LF");
        let src = Src {
            text: "x +\n y".into(),
            span: Some(4..text.len()),
            content: Some(c),
        };
        assert_eq!(src.at(0), Some(9));
        assert_eq!(src.at(3), Some(13));
        assert_eq!(src.at(5).and_then(|o| text.get(o..o + 1)), Some("y"));
    }

    #[test]
    fn spans_for_implicit_tables() {
        let text = "[states.x1]\nrhs = \"u\"\n";
        let root: Tv = toml::from_str(text).expect("valid TOML");
        let Kind::Table(top) = &root.kind else {
            panic!("root is a table")
        };
        let Kind::Table(states) = &top[0].1.kind else {
            panic!("states is a table")
        };
        let Kind::Table(x1) = &states[0].1.kind else {
            panic!("x1 is a table")
        };
        assert_eq!(x1[0].0.name, "rhs");
        assert_eq!(x1[0].0.span, Some(12..15));
        assert_eq!(x1[0].1.span, Some(18..21));
    }

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

    #[test]
    fn cycles() {
        let uses = vec![vec![(1, None)], vec![(2, None)], vec![(1, None)]];
        assert_eq!(find_cycle(&uses), Some(vec![1, 2, 1]));
        let uses = vec![vec![(0, None)]];
        assert_eq!(find_cycle(&uses), Some(vec![0, 0]));
        let uses = vec![vec![], vec![(0, None)], vec![(0, None), (1, None)]];
        assert_eq!(find_cycle(&uses), None);
    }

    #[test]
    fn suggestions() {
        let names = ["c1", "x1", "u"];
        assert_eq!(suggestion("c9", names.iter().copied()), Some("c1"));
        assert_eq!(suggestion("zz", names.iter().copied()), None);
        assert_eq!(suggestion("mass", ["mas", "masss"].into_iter()), None);
    }
}
