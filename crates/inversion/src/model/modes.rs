//! Reading a model file with `[inputs]` and `[modes]` (docs/reference.md §2.5): each mode becomes the TOML tree of an
//! ordinary single-input model — its free input the `[input]`, every other input a definition holding the
//! mode's value, the mode's parameter, definition and output overrides applied, a geared mode once per gear
//! with the gear's parameters — which the ordinary reader then checks and builds. The tree keeps the file's
//! positions, so every error in a mode names the file, line and column where it is written.

use super::error::{ModelError, ModelErrorKind};
use super::keys;
use super::modal::{
    ModalFacts, ModalInput, ModalModel, Mode, ModeHeader, ModeRole, ModelFile, SequenceOptions,
};
use super::spanned::Reader;
use super::tree::{get, get_key, key_at, tv_at, Entries, Key, Kind, Tv};
use std::collections::HashSet;

/// Top-level keys that only a modal model has.
const MODAL_KEYS: &[&str] = keys::TOP_MODAL;

/// A deep copy of a tree (the tree types are shared with the ordinary reader and are not `Clone`).
pub(super) fn clone_tv(v: &Tv) -> Tv {
    Tv {
        span: v.span.clone(),
        kind: match &v.kind {
            Kind::Str(s) => Kind::Str(s.clone()),
            Kind::Int(i) => Kind::Int(*i),
            Kind::Float(x) => Kind::Float(*x),
            Kind::Bool(b) => Kind::Bool(*b),
            Kind::Datetime => Kind::Datetime,
            Kind::Array(items) => Kind::Array(items.iter().map(clone_tv).collect()),
            Kind::Table(e) => {
                Kind::Table(e.iter().map(|(k, v)| (clone_key(k), clone_tv(v))).collect())
            }
        },
    }
}

fn clone_key(k: &Key) -> Key {
    Key {
        name: k.name.clone(),
        span: k.span.clone(),
    }
}

fn key(name: &str, span: Option<std::ops::Range<usize>>) -> Key {
    Key {
        name: name.to_string(),
        span,
    }
}

/// Identifiers in an expression's text (a lexical scan: enough to order definitions).
fn identifiers(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_alphabetic() || c == b'_' {
            let s = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            out.push(&text[s..i]);
        } else if c.is_ascii_digit() || c == b'.' {
            // A number, exponent included (`1e-3`): skip it whole so `e` is not an identifier.
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'.') {
                i += 1;
            }
        } else {
            i += 1;
        }
    }
    out
}

/// An input a mode gives a value: (input index, its key, its value).
type Fixed<'t> = (usize, &'t Key, &'t Tv);
/// An input a mode leaves to a strategy: (input index, where it is written).
type Decided = (usize, Option<usize>);

/// A mode's table as read (its values still trees).
pub(super) struct RawMode<'t> {
    pub(super) name: String,
    pub(super) at: Option<usize>,
    pub(super) role: ModeRole,
    pub(super) geared: bool,
    pub(super) free: usize,
    /// (input index, its key, its value).
    pub(super) fixed: Vec<(usize, &'t Key, &'t Tv)>,
    pub(super) parameters: Option<&'t Entries>,
    pub(super) definitions: Option<&'t Entries>,
    pub(super) output: Option<&'t Entries>,
    /// `couple = { s = "c(x)" }`: the states the mode ties to the others, with their couplings.
    pub(super) couple: Vec<(&'t Key, &'t Tv)>,
    /// `decided = ["T_m"]`: the inputs a strategy decides, by input index, with where each is written.
    pub(super) decided: Vec<(usize, Option<usize>)>,
}

impl Reader<'_> {
    /// Read a file that may have modes: an ordinary model is built exactly as [`super::Model::from_str`].
    pub(super) fn read_file(&self, root: &Tv, hash: String) -> Result<ModelFile, ModelError> {
        let entries = self.table(root, "the model file")?;
        if !entries
            .iter()
            .any(|(k, _)| MODAL_KEYS.contains(&k.name.as_str()))
        {
            let raw = self.structure(root)?;
            return Ok(ModelFile::Single(Box::new(self.build(raw, hash)?)));
        }
        self.read_modal(entries, hash, Read::All)
            .map(|(m, _)| ModelFile::Modal(Box::new(m)))
    }

    /// A file with modes read for compiled code made from it (the same bytes, so every mode was checked
    /// when the code was generated): the model without its modes and every mode's header. Only the first
    /// mode's model is built (for the name, the description, the gearbox's parameters and the state order,
    /// which every mode shares); `None` for a file without modes.
    pub(super) fn read_headers(
        &self,
        root: &Tv,
        hash: String,
        facts: Option<&ModalFacts>,
    ) -> Result<Option<(ModalModel, Vec<ModeHeader>)>, ModelError> {
        let entries = self.table(root, "the model file")?;
        if !entries
            .iter()
            .any(|(k, _)| MODAL_KEYS.contains(&k.name.as_str()))
        {
            return Ok(None);
        }
        self.read_modal(entries, hash, Read::Headers(facts))
            .map(Some)
    }

    /// The modal model with every mode's model (`all`), or with no modes and every mode's header (only the
    /// first mode's model built, see [`Reader::read_headers`]).
    fn read_modal(
        &self,
        entries: &Entries,
        hash: String,
        read: Read<'_>,
    ) -> Result<(ModalModel, Vec<ModeHeader>), ModelError> {
        let all = matches!(read, Read::All);
        let facts = match read {
            Read::Headers(f) => f,
            Read::All => None,
        };
        if let Some((k, _)) = get_key(entries, "input") {
            return Err(self.err(
                key_at(k),
                ModelErrorKind::Schema,
                "a model with [inputs] or [modes] declares its inputs in [inputs.NAME] tables, not in [input]",
            ));
        }
        let inputs_tv = self.required(entries, "inputs", "[inputs.u] min = 0.0")?;
        let inputs = self.modal_inputs(self.table(inputs_tv, "[inputs]")?)?;
        let modes_tv = self.required(entries, "modes", "[modes.drive] inputs = { F_b = 0.0 }")?;
        let modes_entries = self.table(modes_tv, "[modes]")?;
        if modes_entries.is_empty() {
            return Err(self.err(
                tv_at(modes_tv),
                ModelErrorKind::Schema,
                "[modes] declares no mode",
            ));
        }
        let gearbox = get(entries, "gearbox")
            .map(|g| self.gearbox(g))
            .transpose()?;
        let sequence = get(entries, "sequence")
            .map(|s| self.sequence_options(s))
            .transpose()?
            .unwrap_or_default();
        let mut raws = Vec::new();
        for (k, v) in modes_entries {
            raws.push(self.raw_mode(k, v, &inputs)?);
        }
        self.check_roles(&raws, get(entries, "hybrid").is_some())?;
        let base: Vec<(&Key, &Tv)> = entries
            .iter()
            .filter(|(k, _)| !MODAL_KEYS.contains(&k.name.as_str()))
            .map(|(k, v)| (k, v))
            .collect();
        let (mut modes, mut headers) = (Vec::new(), Vec::new());
        let mut first: Option<super::validated::Model> = None;
        for raw in &raws {
            let gears: Vec<Option<usize>> = match (&gearbox, raw.geared) {
                (Some(g), true) => (1..=g.gears).map(Some).collect(),
                _ => vec![None],
            };
            for gear in gears {
                let gear_params = match (&gearbox, gear) {
                    (Some(g), Some(n)) => g
                        .parameters
                        .iter()
                        .map(|(p, v)| (p.clone(), v[n - 1]))
                        .collect(),
                    _ => Vec::new(),
                };
                let name = match gear {
                    Some(n) => format!("{}_{n}", raw.name),
                    None => raw.name.clone(),
                };
                if let Some(f) = facts {
                    headers.push(header_of(raw, name, gear, &|s| f.state_index(s)));
                    continue;
                }
                if let (false, Some(f)) = (all, &first) {
                    headers.push(header_of(raw, name, gear, &|s| state_index(&f.states, s)));
                    continue;
                }
                let tree = self.mode_tree(&base, raw, &inputs, &gear_params)?;
                let mut model = self.build(self.structure(&tree)?, hash.clone())?;
                self.apply_couplings(&mut model, raw)?;
                let header = header_of(raw, name, gear, &|s| state_index(&model.states, s));
                if all {
                    let mut mode = Mode::new(header, model);
                    mode.decided_at = raw
                        .decided
                        .iter()
                        .map(|(_, at)| at.map(|o| super::spanned::line_col(self.text, o)))
                        .collect();
                    modes.push(mode);
                } else {
                    headers.push(header);
                    first = Some(model);
                }
            }
        }
        let built = first.as_ref().or(modes.first().map(|m| &m.model));
        let (name, description, parameters): (String, Option<String>, Vec<&str>) =
            match (facts, built) {
                (Some(f), _) => (
                    f.name.clone(),
                    f.description.clone(),
                    f.parameters.iter().map(String::as_str).collect(),
                ),
                (None, Some(m)) => (
                    m.name.clone(),
                    m.description.clone(),
                    m.parameters.iter().map(|p| p.name.as_str()).collect(),
                ),
                (None, None) => {
                    return Err(self.err(
                        tv_at(modes_tv),
                        ModelErrorKind::Schema,
                        "[modes] declares no mode",
                    ))
                }
            };
        if let Some(g) = &gearbox {
            self.check_gear_parameters(g, &parameters)?;
        }
        let hybrid = get_key(entries, "hybrid")
            .map(|(k, v)| self.hybrid(k, v, &raws, built))
            .transpose()?;
        let model = ModalModel {
            name,
            description,
            file: self.file.to_path_buf(),
            source_hash: hash,
            inputs,
            gearbox,
            sequence,
            modes,
            hybrid,
        };
        Ok((model, headers))
    }

    pub(super) fn required<'t>(
        &self,
        entries: &'t Entries,
        key: &str,
        example: &str,
    ) -> Result<&'t Tv, ModelError> {
        get(entries, key).ok_or_else(|| {
            self.err(
                None,
                ModelErrorKind::Schema,
                format!("a model with modes needs a [{key}] section, e.g. {example}"),
            )
        })
    }

    fn modal_inputs(&self, entries: &Entries) -> Result<Vec<ModalInput>, ModelError> {
        let mut out: Vec<ModalInput> = Vec::new();
        for (k, v) in entries {
            let what = format!("input `{}`", k.name.escape_debug());
            let t = self.table(v, &what)?;
            self.known_keys(t, keys::MODAL_INPUT, &what)?;
            let bound = |b: &str| {
                get(t, b)
                    .map(|x| self.number(x, &format!("{what}'s `{b}`")))
                    .transpose()
            };
            let (min, max) = (bound("min")?, bound("max")?);
            if let (Some(lo), Some(hi)) = (min, max) {
                if lo > hi {
                    return Err(self.err(
                        tv_at(v),
                        ModelErrorKind::Schema,
                        format!("{what} has min = {lo} above max = {hi}"),
                    ));
                }
            }
            out.push(ModalInput {
                name: k.name.clone(),
                unit: self.optional_string(t, "unit", &what)?,
                doc: self.optional_string(t, "doc", &what)?,
                min,
                max,
            });
        }
        if out.len() < 2 {
            let at = entries.first().and_then(|(k, _)| key_at(k));
            return Err(self.err(
                at,
                ModelErrorKind::Schema,
                "[inputs] declares fewer than two inputs; a model with one input uses [input]",
            ));
        }
        Ok(out)
    }

    fn raw_mode<'t>(
        &self,
        k: &'t Key,
        v: &'t Tv,
        inputs: &[ModalInput],
    ) -> Result<RawMode<'t>, ModelError> {
        let what = format!("mode `{}`", k.name.escape_debug());
        if !super::names::is_identifier(&k.name) {
            return Err(self.err(
                key_at(k),
                ModelErrorKind::InvalidName,
                format!("{what}: a mode's name must be an identifier"),
            ));
        }
        let t = self.table(v, &what)?;
        self.known_keys(t, keys::MODE, &what)?;
        let role = match get(t, "role") {
            None => ModeRole::Traction,
            Some(r) => match self.string(r, &format!("{what}'s `role`"))?.as_str() {
                "traction" => ModeRole::Traction,
                "brake" => ModeRole::Brake,
                "standstill" => ModeRole::Standstill,
                other => {
                    return Err(self.err(
                        tv_at(r),
                        ModelErrorKind::Schema,
                        format!(
                            "{what}: unknown role `{}`; expected traction, brake or standstill",
                            other.escape_debug()
                        ),
                    ))
                }
            },
        };
        let geared = get(t, "geared")
            .map(|g| self.boolean(g, &format!("{what}'s `geared`")))
            .transpose()?
            .unwrap_or(true);
        let fixed = self.mode_fixed(t, &what, inputs)?;
        let decided = self.mode_decided(t, &what, inputs, &fixed)?;
        let free = self.mode_free(k, t, &what, inputs, (&fixed, &decided))?;
        let sub = |name: &str| -> Result<Option<&'t Entries>, ModelError> {
            get(t, name)
                .map(|x| self.table(x, &format!("{what}'s `{name}`")))
                .transpose()
        };
        Ok(RawMode {
            name: k.name.clone(),
            at: key_at(k),
            role,
            geared,
            free,
            fixed,
            parameters: sub("parameters")?,
            definitions: sub("definitions")?,
            output: sub("output")?,
            couple: match sub("couple")? {
                Some(c) => {
                    for (k, v) in c {
                        self.string(v, &format!("{what}'s coupling of `{}`", k.name))?;
                    }
                    c.iter().map(|(k, v)| (k, v)).collect()
                }
                None => Vec::new(),
            },
            decided,
        })
    }

    /// A mode's `decided = ["NAME", …]`: inputs of the model, neither given a value nor named twice, each
    /// with both bounds (the strategy searches between them).
    fn mode_decided(
        &self,
        t: &Entries,
        what: &str,
        inputs: &[ModalInput],
        fixed: &[(usize, &Key, &Tv)],
    ) -> Result<Vec<(usize, Option<usize>)>, ModelError> {
        let Some(v) = get(t, "decided") else {
            return Ok(Vec::new());
        };
        let Kind::Array(items) = &v.kind else {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                format!(
                    "{what}'s `decided` must be an array of input names, e.g. decided = [\"T_m\"]"
                ),
            ));
        };
        if items.is_empty() {
            return Err(self.err(
                tv_at(v),
                ModelErrorKind::Schema,
                format!("{what}'s `decided` names no input; leave the key out, or name the inputs a strategy decides"),
            ));
        }
        let mut out: Vec<(usize, Option<usize>)> = Vec::new();
        for item in items {
            let name = self.string(item, &format!("{what}'s `decided` entry"))?;
            let at = tv_at(item);
            let Some(i) = inputs.iter().position(|x| x.name == name) else {
                let known: Vec<&str> = inputs.iter().map(|x| x.name.as_str()).collect();
                return Err(self.err(
                    at,
                    ModelErrorKind::UnknownName,
                    format!(
                        "{what} decides `{}`, which is not an input; the inputs are: {}",
                        name.escape_debug(),
                        known.join(", ")
                    ),
                ));
            };
            if fixed.iter().any(|(j, _, _)| *j == i) || out.iter().any(|(j, _)| *j == i) {
                return Err(self.err(
                    at,
                    ModelErrorKind::Schema,
                    format!(
                        "{what} decides `{}` and also gives it a value or names it twice",
                        name.escape_debug()
                    ),
                ));
            }
            if inputs[i].min.is_none() || inputs[i].max.is_none() {
                return Err(self.err(
                    at,
                    ModelErrorKind::Schema,
                    format!(
                        "{what} decides `{}`, which has no bounds: a decided input needs `min` and `max` in \
                         [inputs.{}] (the strategy searches between them)",
                        name.escape_debug(),
                        name.escape_debug()
                    ),
                ));
            }
            out.push((i, at));
        }
        Ok(out)
    }

    fn mode_fixed<'t>(
        &self,
        t: &'t Entries,
        what: &str,
        inputs: &[ModalInput],
    ) -> Result<Vec<(usize, &'t Key, &'t Tv)>, ModelError> {
        let Some(values) = get(t, "inputs") else {
            return Ok(Vec::new());
        };
        let mut out = Vec::new();
        for (k, v) in self.table(values, &format!("{what}'s `inputs`"))? {
            let Some(i) = inputs.iter().position(|x| x.name == k.name) else {
                let known: Vec<&str> = inputs.iter().map(|x| x.name.as_str()).collect();
                return Err(self.err(
                    key_at(k),
                    ModelErrorKind::UnknownName,
                    format!(
                        "{what} gives a value to `{}`, which is not an input; the inputs are: {}",
                        k.name.escape_debug(),
                        known.join(", ")
                    ),
                ));
            };
            self.expression(v, &format!("{what}'s value of input `{}`", k.name))?;
            out.push((i, k, v));
        }
        Ok(out)
    }

    /// The one input a mode leaves free (exactly one: the others have values).
    fn mode_free(
        &self,
        k: &Key,
        t: &Entries,
        what: &str,
        inputs: &[ModalInput],
        (fixed, decided): (&[Fixed<'_>], &[Decided]),
    ) -> Result<usize, ModelError> {
        let free: Vec<usize> = (0..inputs.len())
            .filter(|i| !fixed.iter().any(|(j, _, _)| j == i))
            .filter(|i| !decided.iter().any(|(j, _)| j == i))
            .collect();
        let at = get(t, "inputs").and_then(tv_at).or(key_at(k));
        let declared = get(t, "free")
            .map(|f| Ok::<_, ModelError>((self.string(f, &format!("{what}'s `free`"))?, tv_at(f))))
            .transpose()?;
        if let Some((name, f_at)) = &declared {
            if !inputs.iter().any(|x| &x.name == name) {
                return Err(self.err(
                    *f_at,
                    ModelErrorKind::UnknownName,
                    format!(
                        "{what}: `free = \"{}\"` is not an input",
                        name.escape_debug()
                    ),
                ));
            }
            if !free.iter().any(|&i| &inputs[i].name == name) {
                return Err(self.err(
                    *f_at,
                    ModelErrorKind::Schema,
                    format!(
                        "{what}: `free = \"{}\"` but the mode also gives it a value",
                        name.escape_debug()
                    ),
                ));
            }
        }
        match free.as_slice() {
            [i] => Ok(*i),
            [] => Err(self.err(
                at,
                ModelErrorKind::Schema,
                format!("{what} has no free input: it gives every input a value or decides it; leave exactly one to the inversion"),
            )),
            many => {
                let names: Vec<&str> = many.iter().map(|&i| inputs[i].name.as_str()).collect();
                Err(self.err(
                    at,
                    ModelErrorKind::Schema,
                    format!(
                        "{what} has {} free inputs ({}); exactly one may be free, give the others a value in `inputs = {{ … }}`",
                        many.len(),
                        names.join(", ")
                    ),
                ))
            }
        }
    }

    /// At most one standstill mode, unless a strategy chooses among them (a `[hybrid]` table: the engine
    /// on or off at a standstill); a brake or standstill mode needs a traction mode to return to.
    fn check_roles(&self, raws: &[RawMode<'_>], strategy: bool) -> Result<(), ModelError> {
        let mut standstill = raws.iter().filter(|r| r.role == ModeRole::Standstill);
        if let (false, Some(_), Some(second)) = (strategy, standstill.next(), standstill.next()) {
            return Err(self.err(
                second.at,
                ModelErrorKind::Schema,
                "a second mode with role = \"standstill\": only a model with a [hybrid] table (whose strategy \
                 chooses among them) may have more than one",
            ));
        }
        if !raws.iter().any(|r| r.role == ModeRole::Traction) {
            return Err(self.err(
                raws.first().and_then(|r| r.at),
                ModelErrorKind::Schema,
                "no mode has role = \"traction\" (the default): the sequence needs one to drive",
            ));
        }
        Ok(())
    }

    /// The parameters a gearbox sets must be parameters of the model.
    fn check_gear_parameters(
        &self,
        g: &super::modal::Gearbox,
        parameters: &[&str],
    ) -> Result<(), ModelError> {
        for (p, _) in &g.parameters {
            if !parameters.contains(&p.as_str()) {
                return Err(self.err(
                    None,
                    ModelErrorKind::UnknownName,
                    format!(
                        "[gearbox] sets `{}`, which is not a parameter of the model",
                        p.escape_debug()
                    ),
                ));
            }
        }
        Ok(())
    }

    fn sequence_options(&self, v: &Tv) -> Result<SequenceOptions, ModelError> {
        let t = self.table(v, "[sequence]")?;
        self.known_keys(t, keys::SEQUENCE, "[sequence]")?;
        let mut o = SequenceOptions::default();
        let num = |k: &str| {
            get(t, k)
                .map(|x| self.number(x, &format!("[sequence] `{k}`")))
                .transpose()
        };
        if let Some(x) = num("standstill_below")? {
            o.standstill_below = x;
        }
        if let Some(x) = num("standstill_above")? {
            o.standstill_above = x;
        }
        o.brake_band = num("brake_band")?;
        if let Some(x) = num("min_dwell")? {
            o.min_dwell = x;
        }
        if o.standstill_above < o.standstill_below {
            return Err(self.err(
                get(t, "standstill_above").and_then(tv_at),
                ModelErrorKind::Schema,
                format!(
                    "[sequence] standstill_above = {} is below standstill_below = {}: the hysteresis band is inverted",
                    o.standstill_above, o.standstill_below
                ),
            ));
        }
        Ok(o)
    }

    /// The single-input tree of one mode (and gear).
    fn mode_tree(
        &self,
        base: &[(&Key, &Tv)],
        raw: &RawMode<'_>,
        inputs: &[ModalInput],
        gear_params: &[(String, f64)],
    ) -> Result<Tv, ModelError> {
        let mut top: Vec<(Key, Tv)> = base
            .iter()
            .map(|(k, v)| (clone_key(k), clone_tv(v)))
            .collect();
        for section in ["parameters", "definitions", "outputs"] {
            if !top.iter().any(|(k, _)| k.name == section) {
                top.push((
                    key(section, None),
                    Tv {
                        span: None,
                        kind: Kind::Table(Vec::new()),
                    },
                ));
            }
        }
        let free = &inputs[raw.free];
        top.push((key("input", None), input_table(free)));
        for (name, value) in gear_params {
            override_parameter(
                &mut top,
                name,
                Tv {
                    span: None,
                    kind: Kind::Float(*value),
                },
            );
        }
        if let Some(ps) = raw.parameters {
            for (k, v) in ps {
                if !section_has(&top, "parameters", &k.name) {
                    return Err(self.unknown_override(k, "parameter", &raw.name));
                }
                override_parameter(&mut top, &k.name, clone_tv(v));
            }
        }
        if let Some(ds) = raw.definitions {
            for (k, v) in ds {
                if !section_has(&top, "definitions", &k.name) {
                    return Err(self.unknown_override(k, "definition", &raw.name));
                }
                override_definition(&mut top, &k.name, clone_tv(v));
            }
        }
        if let Some(o) = raw.output {
            override_output(&mut top, o);
        }
        for (i, k, v) in &raw.fixed {
            insert_fixed_input(&mut top, &inputs[*i].name, k, v);
        }
        for (k, v) in &raw.couple {
            self.insert_coupling(&mut top, &raw.name, k, v)?;
        }
        for (i, _) in &raw.decided {
            insert_decided_input(&mut top, &inputs[*i]);
        }
        Ok(Tv {
            span: None,
            kind: Kind::Table(top),
        })
    }

    /// A coupling `s = "c"` as the definition `coupling_s` (after every other definition, so that it may use
    /// them all) and an extra output of that name (after the fixed inputs); `s` must be a state.
    fn insert_coupling(
        &self,
        top: &mut [(Key, Tv)],
        mode: &str,
        k: &Key,
        v: &Tv,
    ) -> Result<(), ModelError> {
        if !section_has(top, "states", &k.name) {
            return Err(self.err(
                key_at(k),
                ModelErrorKind::UnknownName,
                format!(
                    "mode `{}` couples `{}`, which is not a state of the model (`couple` ties a state to the \
                     others, e.g. couple = {{ w_e = \"i_g*i_f*v/r_w\" }})",
                    mode.escape_debug(),
                    k.name.escape_debug()
                ),
            ));
        }
        let name = super::coupling::coupling_name(&k.name);
        if ["parameters", "definitions", "states", "outputs", "signals"]
            .iter()
            .any(|s| section_has(top, s, &name))
        {
            return Err(self.err(
                key_at(k),
                ModelErrorKind::InvalidName,
                format!(
                    "mode `{}` couples `{}`, and the coupling's name `{name}` is taken by the model; rename \
                     that name",
                    mode.escape_debug(),
                    k.name.escape_debug()
                ),
            ));
        }
        if let Some(defs) = section_mut(top, "definitions") {
            defs.push((key(&name, k.span.clone()), clone_tv(v)));
        }
        if let Some(outs) = section_mut(top, "outputs") {
            let expr = Tv {
                span: None,
                kind: Kind::Str(name.clone()),
            };
            outs.push((key(&name, None), expr));
        }
        Ok(())
    }

    /// Tie each coupled state to its coupling in the mode's model ([`super::coupling`]).
    fn apply_couplings(
        &self,
        model: &mut super::validated::Model,
        raw: &RawMode<'_>,
    ) -> Result<(), ModelError> {
        let mut couplings = Vec::new();
        for (k, _) in &raw.couple {
            let name = super::coupling::coupling_name(&k.name);
            let s = model.states.iter().position(|s| s.name == k.name);
            let d = model.definitions.iter().find(|d| d.name == name);
            if let (Some(s), Some(d)) = (s, d) {
                couplings.push((s, d.inlined));
            }
        }
        super::coupling::couple(model, &couplings).map_err(|(j, e)| {
            let at = raw.couple.get(j).and_then(|(_, v)| tv_at(v));
            self.err(
                at,
                e.kind,
                format!("mode `{}`: {}", raw.name.escape_debug(), e.message),
            )
        })
    }

    fn unknown_override(&self, k: &Key, what: &str, mode: &str) -> ModelError {
        self.err(
            key_at(k),
            ModelErrorKind::UnknownName,
            format!(
                "mode `{}` overrides the {what} `{}`, which the model does not declare (a mode may only change \
                 what the model has)",
                mode.escape_debug(),
                k.name.escape_debug()
            ),
        )
    }
}

/// How much of a file with modes to read.
enum Read<'f> {
    /// Every mode's model built.
    All,
    /// Only the headers; the model's name, description, parameters and states from what compiled code knows of
    /// the file (`Some`), or from the first mode's model, built for them.
    Headers(Option<&'f ModalFacts>),
}

/// The index of the state called `name` among `states`.
fn state_index(states: &[super::validated::State], name: &str) -> Option<usize> {
    states.iter().position(|s| s.name == name)
}

/// The header of mode `name` (gear `gear`) of `raw`: its inputs' values and couplings as written, each coupled
/// state by its index among `states` (the model's, which every mode keeps whole: `coupling.rs`).
fn header_of(
    raw: &RawMode<'_>,
    name: String,
    gear: Option<usize>,
    state_index: &dyn Fn(&str) -> Option<usize>,
) -> ModeHeader {
    let fixed = raw
        .fixed
        .iter()
        .map(|(i, _, v)| {
            let text = match &v.kind {
                Kind::Str(s) => s.clone(),
                Kind::Int(n) => n.to_string(),
                Kind::Float(x) => format!("{x:?}"),
                _ => String::new(),
            };
            (*i, text)
        })
        .collect();
    let coupled = raw
        .couple
        .iter()
        .filter_map(|(k, v)| {
            let i = state_index(&k.name)?;
            let text = match &v.kind {
                Kind::Str(s) => s.clone(),
                _ => String::new(),
            };
            Some((i, text))
        })
        .collect();
    ModeHeader {
        name,
        family: raw.name.clone(),
        gear,
        role: raw.role,
        free: raw.free,
        fixed,
        coupled,
        decided: raw.decided.iter().map(|(i, _)| *i).collect(),
        parameters: raw
            .parameters
            .map(|ps| ps.iter().map(|(k, _)| k.name.clone()).collect())
            .unwrap_or_default(),
    }
}

fn input_table(free: &ModalInput) -> Tv {
    let s = |x: &str| Tv {
        span: None,
        kind: Kind::Str(x.to_string()),
    };
    let mut t = vec![(key("name", None), s(&free.name))];
    if let Some(u) = &free.unit {
        t.push((key("unit", None), s(u)));
    }
    if let Some(d) = &free.doc {
        t.push((key("doc", None), s(d)));
    }
    for (b, x) in [("min", free.min), ("max", free.max)] {
        if let Some(x) = x {
            t.push((
                key(b, None),
                Tv {
                    span: None,
                    kind: Kind::Float(x),
                },
            ));
        }
    }
    Tv {
        span: None,
        kind: Kind::Table(t),
    }
}

fn section_mut<'a>(top: &'a mut [(Key, Tv)], section: &str) -> Option<&'a mut Vec<(Key, Tv)>> {
    top.iter_mut()
        .find(|(k, _)| k.name == section)
        .and_then(|(_, v)| match &mut v.kind {
            Kind::Table(e) => Some(e),
            _ => None,
        })
}

fn section_has(top: &[(Key, Tv)], section: &str, name: &str) -> bool {
    top.iter().find(|(k, _)| k.name == section).is_some_and(
        |(_, v)| matches!(&v.kind, Kind::Table(e) if e.iter().any(|(k, _)| k.name == name)),
    )
}

/// Replace a value, or the `field` of a table value (keeping its unit and doc).
fn replace_value(slot: &mut Tv, field: &str, value: Tv) {
    if let (Kind::Table(t), false) = (&mut slot.kind, matches!(value.kind, Kind::Table(_))) {
        if let Some((_, v)) = t.iter_mut().find(|(k, _)| k.name == field) {
            *v = value;
            return;
        }
    }
    *slot = value;
}

fn override_parameter(top: &mut [(Key, Tv)], name: &str, value: Tv) {
    if let Some(e) = section_mut(top, "parameters") {
        if let Some((_, slot)) = e.iter_mut().find(|(k, _)| k.name == name) {
            replace_value(slot, "value", value);
        }
    }
}

fn override_definition(top: &mut [(Key, Tv)], name: &str, value: Tv) {
    if let Some(e) = section_mut(top, "definitions") {
        if let Some((_, slot)) = e.iter_mut().find(|(k, _)| k.name == name) {
            replace_value(slot, "expr", value);
        }
    }
}

/// Merge a mode's `output = { … }` into `[output]`, key by key.
fn override_output(top: &mut [(Key, Tv)], o: &Entries) {
    if let Some(e) = section_mut(top, "output") {
        for (k, v) in o {
            match e.iter_mut().find(|(q, _)| q.name == k.name) {
                Some((_, slot)) => *slot = clone_tv(v),
                None => e.push((clone_key(k), clone_tv(v))),
            }
        }
    }
}

/// The fixed input as a definition (placed right after the last definition its value uses, so that the
/// definitions stay ordered) and as an extra output of its name.
fn insert_fixed_input(top: &mut [(Key, Tv)], name: &str, k: &Key, v: &Tv) {
    let text = match &v.kind {
        Kind::Str(s) => s.clone(),
        _ => String::new(),
    };
    let uses: HashSet<&str> = identifiers(&text).into_iter().collect();
    if let Some(defs) = section_mut(top, "definitions") {
        let pos = defs
            .iter()
            .rposition(|(d, _)| uses.contains(d.name.as_str()))
            .map_or(0, |p| p + 1);
        defs.insert(pos, (key(name, k.span.clone()), clone_tv(v)));
    }
    if let Some(outs) = section_mut(top, "outputs") {
        let expr = Tv {
            span: None,
            kind: Kind::Str(name.to_string()),
        };
        outs.push((key(name, None), expr));
    }
}

/// A decided input as a signal of the mode's model (its value the strategy's, per sample; the derivation
/// treats it like any exogenous signal), appended after the file's `[signals]` (the run reports its value
/// in the input's column).
fn insert_decided_input(top: &mut Vec<(Key, Tv)>, input: &ModalInput) {
    let s = |x: &str| Tv {
        span: None,
        kind: Kind::Str(x.to_string()),
    };
    if !top.iter().any(|(k, _)| k.name == "signals") {
        top.push((
            key("signals", None),
            Tv {
                span: None,
                kind: Kind::Table(Vec::new()),
            },
        ));
    }
    let mut entry = vec![(key("doc", None), s("decided by the strategy"))];
    if let Some(u) = &input.unit {
        entry.push((key("unit", None), s(u)));
    }
    if let Some(sigs) = section_mut(top, "signals") {
        sigs.push((
            key(&input.name, None),
            Tv {
                span: None,
                kind: Kind::Table(entry),
            },
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::identifiers;

    #[test]
    fn identifiers_skip_numbers() {
        assert_eq!(identifiers("1e-3*w_idle + x2^2"), vec!["w_idle", "x2"]);
    }
}
