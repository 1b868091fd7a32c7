//! The model file as read: its sections and keys checked for structure (known keys, value types, required
//! sections, finite numbers, `min <= max`), not yet for meaning; expressions are kept as text with their
//! positions ([`Src`]).

use super::engine::RawEngine;
use super::error::{ModelError, ModelErrorKind};
use super::headline::RawHeadline;
use super::keys;
use super::maps::RawMap;
use super::names::{is_identifier, Declaration, NameRef};
use super::signals::RawSignal;
use super::spanned::{string_content, Reader, Src};
use super::tree::{get, get_key, key_at, tv_at, Entries, Key, Kind, Tv};
use std::collections::HashSet;

/// A parameter as written: `name = 1.0` or `name = { value = …, unit = "…", doc = "…" }`.
#[derive(Debug)]
pub(super) struct RawParameter {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    pub(super) value: f64,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
}

/// A definition as written, its expression not yet parsed.
#[derive(Debug)]
pub(super) struct RawDefinition {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    pub(super) src: Src,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
}

/// A state's equation as written: `rhs`, or `f` and `g`.
#[derive(Debug)]
pub(super) enum RawEquation {
    Rhs(Src),
    Fg(Src, Src),
}

/// A state as written.
#[derive(Debug)]
pub(super) struct RawState {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    pub(super) equation: RawEquation,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
    /// `initial = VALUE`: the state's value at the start of a run where the inversion does not fix it.
    pub(super) initial: Option<f64>,
}

/// `[input]` as written.
#[derive(Debug)]
pub(super) struct RawInput {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
    pub(super) min: Option<f64>,
    pub(super) max: Option<f64>,
}

/// `[output]` as written.
#[derive(Debug)]
pub(super) struct RawOutput {
    pub(super) name: String,
    pub(super) h: Src,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
    pub(super) nominal: Option<f64>,
    pub(super) reference_offset: Option<f64>,
    pub(super) reference_scale: Option<f64>,
}

/// An extra output of `[outputs]` as written.
#[derive(Debug)]
pub(super) struct RawExtra {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    pub(super) src: Src,
    pub(super) unit: Option<String>,
    pub(super) doc: Option<String>,
    pub(super) accumulate: bool,
    /// `per_distance` as written (the default is decided with the reference map).
    pub(super) per_distance: Option<bool>,
}

/// The model file as read, every required section present.
#[derive(Debug)]
pub(super) struct RawModel {
    pub(super) name: Option<String>,
    pub(super) description: Option<String>,
    pub(super) parameters: Vec<RawParameter>,
    pub(super) definitions: Vec<RawDefinition>,
    pub(super) states: Vec<RawState>,
    pub(super) input: RawInput,
    pub(super) output: RawOutput,
    pub(super) outputs: Vec<RawExtra>,
    pub(super) engine: Option<RawEngine>,
    pub(super) headline: Option<RawHeadline>,
    /// `[maps]` (contract §6), in file order.
    pub(super) maps: Vec<RawMap>,
    /// `[signals]`, in file order.
    pub(super) signals: Vec<RawSignal>,
}

impl RawModel {
    /// The declared names (parameters, definitions, states, input) with their positions, in this order.
    pub(super) fn declarations(&self) -> Vec<Declaration<'_>> {
        let mut decls: Vec<Declaration<'_>> = Vec::new();
        decls.extend(
            self.parameters
                .iter()
                .enumerate()
                .map(|(i, p)| (p.name.as_str(), p.at, NameRef::Parameter(i))),
        );
        decls.extend(
            self.definitions
                .iter()
                .enumerate()
                .map(|(i, d)| (d.name.as_str(), d.at, NameRef::Definition(i))),
        );
        decls.extend(
            self.states
                .iter()
                .enumerate()
                .map(|(i, s)| (s.name.as_str(), s.at, NameRef::State(i))),
        );
        decls.push((self.input.name.as_str(), self.input.at, NameRef::Input));
        decls.extend(
            self.maps
                .iter()
                .enumerate()
                .map(|(i, m)| (m.name.as_str(), m.at, NameRef::Map(i))),
        );
        decls.extend(
            self.signals
                .iter()
                .enumerate()
                .map(|(i, s)| (s.name.as_str(), s.at, NameRef::Signal(i))),
        );
        decls
    }
}

/// The sections while the file is read (a required one may still be missing).
#[derive(Debug, Default)]
struct Sections {
    name: Option<String>,
    description: Option<String>,
    parameters: Vec<RawParameter>,
    definitions: Vec<RawDefinition>,
    states: Vec<RawState>,
    input: Option<RawInput>,
    output: Option<RawOutput>,
    outputs: Vec<RawExtra>,
    engine: Option<RawEngine>,
    headline: Option<RawHeadline>,
    maps: Vec<RawMap>,
    signals: Vec<RawSignal>,
}

const TOP_KEYS_SHOWN: &str =
    "name, description, [parameters], [definitions], [states], [input], [output], [outputs], [engine], \
     [headline], [signals], [maps]";

impl Reader<'_> {
    /// The top-level keys and sections; the required ones present.
    pub(super) fn structure(&self, root: &Tv) -> Result<RawModel, ModelError> {
        let entries = self.table(root, "the model file")?;
        let mut raw = Sections::default();
        let mut seen: HashSet<&str> = HashSet::new();
        let unknown = |k: &Key, other: &str| {
            self.err(
                key_at(k),
                ModelErrorKind::Schema,
                format!(
                    "unknown top-level key `{}`; expected one of: {TOP_KEYS_SHOWN}",
                    other.escape_debug()
                ),
            )
        };
        for (k, v) in entries {
            seen.insert(k.name.as_str());
            // The list of keys decides what is accepted (the reference documents that list); a key listed
            // without an arm below is refused the same way, so the two cannot drift apart silently.
            let listed = keys::TOP_SINGLE.contains(&k.name.as_str());
            match k.name.as_str() {
                other if !listed => return Err(unknown(k, other)),
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
                "engine" => raw.engine = Some(self.engine(v)?),
                "headline" => raw.headline = Some(self.headline(v)?),
                "maps" => raw.maps = self.maps(v)?,
                "signals" => raw.signals = self.signals(self.table(v, "[signals]")?)?,
                other => return Err(unknown(k, other)),
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
        let (Some(input), Some(output)) = (raw.input, raw.output) else {
            // The check above has already reported a missing section.
            return Err(self.err(
                None,
                ModelErrorKind::Schema,
                "missing [input] or [output] section",
            ));
        };
        Ok(RawModel {
            name: raw.name,
            description: raw.description,
            parameters: raw.parameters,
            definitions: raw.definitions,
            states: raw.states,
            input,
            output,
            outputs: raw.outputs,
            engine: raw.engine,
            headline: raw.headline,
            maps: raw.maps,
            signals: raw.signals,
        })
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
                    self.known_keys(t, keys::PARAMETER, &what)?;
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
                    self.known_keys(t, keys::DEFINITION, &what)?;
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
            self.known_keys(t, keys::STATE, &what)?;
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
                initial: get(t, "initial")
                    .map(|v| self.number(v, &format!("{what}'s `initial`")))
                    .transpose()?,
            });
        }
        Ok(out)
    }

    fn input(&self, v: &Tv) -> Result<RawInput, ModelError> {
        let t = self.table(v, "[input]")?;
        self.known_keys(t, keys::INPUT, "[input]")?;
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
        self.known_keys(t, keys::OUTPUT, "[output]")?;
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
            let (src, unit, doc, accumulate, per_distance) = match &v.kind {
                Kind::Table(t) => {
                    self.known_keys(t, keys::EXTRA_OUTPUT, &what)?;
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
                        get(t, "per_distance")
                            .map(|a| self.boolean(a, &format!("{what}'s `per_distance`")))
                            .transpose()?,
                    )
                }
                _ => (self.expression(v, &what)?, None, None, None, None),
            };
            out.push(RawExtra {
                name: k.name.clone(),
                at: key_at(k),
                src,
                unit,
                doc,
                accumulate: accumulate.unwrap_or(false),
                per_distance,
            });
        }
        Ok(out)
    }

    // ----- names, expressions and derivation ---------------------------------------------------------
}
