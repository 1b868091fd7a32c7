//! Reading a model file: bytes → UTF-8 text → a TOML tree with spans → the sections checked for structure
//! → names → expressions → definitions → smoothness → the affine split → a validated [`Model`]. The
//! stages run in this order so that a file with several problems reports the most basic one first. Undefined
//! parts of the expressions as written (`0/0`, `log(0)`, `(v-v)/(v-v)`) are refused right after the
//! definitions are inlined (`undefined.rs`), before the split could hide them.

use super::definitions::Interned;
use super::error::{ModelError, ModelErrorKind};
use super::expressions::{describe, Role};
use super::modal::{ModalFacts, ModalModel, ModeHeader, ModelFile};
use super::raw::RawModel;
use super::spanned::Reader;
use super::split::extra_outputs;
use super::tree::Tv;
use super::validated::{Input, MapInfo, Model, Signal};
use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::Path;

/// Largest model file read, in bytes (1 MiB; the shipped models are under 20 KiB). The file is read through
/// this cap, so a device or an endless stream (`/dev/zero`) is refused after 1 MiB + 1 byte.
pub const MAX_MODEL_FILE_BYTES: u64 = 1 << 20;

/// The bytes of `path`, at most [`MAX_MODEL_FILE_BYTES`].
pub fn read_capped(path: &Path) -> Result<Vec<u8>, ModelError> {
    let err = |message: String| ModelError {
        file: path.to_path_buf(),
        line: None,
        column: None,
        message,
        kind: ModelErrorKind::Io,
    };
    let file =
        std::fs::File::open(path).map_err(|e| err(format!("cannot read the model file: {e}")))?;
    // A buffer sized by the file's length where it has one (one `read` instead of a dozen doubling ones), one
    // byte more so that the read that finds the end needs no growth; a pipe has none and grows.
    let hint = file
        .metadata()
        .map_or(0, |m| m.len())
        .min(MAX_MODEL_FILE_BYTES);
    let mut bytes = Vec::with_capacity(hint as usize + 1);
    file.take(MAX_MODEL_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| err(format!("cannot read the model file: {e}")))?;
    if bytes.len() as u64 > MAX_MODEL_FILE_BYTES {
        return Err(err(format!(
            "the model file is larger than the limit of {MAX_MODEL_FILE_BYTES} bytes (1 MiB); a model file \
             is text of a few kilobytes"
        )));
    }
    Ok(bytes)
}

impl Model {
    /// Read and validate a model file (at most [`MAX_MODEL_FILE_BYTES`] bytes).
    pub fn from_path(path: &Path) -> Result<Model, ModelError> {
        let bytes = read_capped(path)?;
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
}

impl ModelFile {
    /// Read a model file that may declare modes (docs/reference.md §2.5); one without is read exactly as
    /// [`Model::from_path`] reads it.
    pub fn from_path(path: &Path) -> Result<ModelFile, ModelError> {
        ModelFile::from_bytes(path, &read_capped(path)?)
    }

    /// [`ModelFile::from_path`] on the file's bytes; `file` is used in messages.
    pub fn from_bytes(file: &Path, bytes: &[u8]) -> Result<ModelFile, ModelError> {
        let text =
            std::str::from_utf8(bytes).map_err(|_| match Model::from_bytes(file, bytes) {
                Err(e) => e,
                Ok(_) => Reader { file, text: "" }.err(None, ModelErrorKind::Io, "not UTF-8"),
            })?;
        ModelFile::from_str(file, text)
    }

    /// A file with modes for which compiled code exists (`compiled(sha256)` says so: the code was generated
    /// from these very bytes, which every mode's check passed then): the model without its modes, and every
    /// mode's header, without building each mode's model. `None` when the file has no modes or `compiled`
    /// refuses its hash (then [`ModelFile::from_path`] reads it in full).
    pub fn modal_headers(
        path: &Path,
        compiled: &dyn Fn(&str) -> bool,
    ) -> Result<Option<(ModalModel, Vec<ModeHeader>)>, ModelError> {
        let claims = |hash: &str| compiled(hash).then_some(None);
        ModelFile::modal_headers_of(path, &read_capped(path)?, &claims)
    }

    /// [`ModelFile::modal_headers`] of the file's bytes (`file` names it in messages), where `compiled` gives
    /// for a hash it claims what the compiled code knows of the file (`Some(Some(facts))`: then no mode's
    /// model is built at all; `Some(None)`: the first mode's model is built for the name, description,
    /// parameters and states).
    pub fn modal_headers_of(
        file: &Path,
        bytes: &[u8],
        compiled: &dyn Fn(&str) -> Option<Option<ModalFacts>>,
    ) -> Result<Option<(ModalModel, Vec<ModeHeader>)>, ModelError> {
        let Ok(text) = std::str::from_utf8(bytes) else {
            return Ok(None);
        };
        ModelFile::modal_headers_hashed(file, text, source_hash(text), compiled)
    }

    /// [`ModelFile::modal_headers_of`] of a text whose SHA-256 is known already (the compiled code's, whose
    /// file the text equals byte for byte): no hashing.
    pub fn modal_headers_hashed(
        file: &Path,
        text: &str,
        hash: String,
        compiled: &dyn Fn(&str) -> Option<Option<ModalFacts>>,
    ) -> Result<Option<(ModalModel, Vec<ModeHeader>)>, ModelError> {
        let Some(facts) = compiled(&hash) else {
            return Ok(None);
        };
        // With the compiled code's facts (the file is its model's byte for byte: the hash matched) only the
        // tables the headers come from are parsed; without, the first mode is built from the whole file.
        let root = match facts {
            Some(_) => Reader {
                file,
                text: &modal_tables_only(text),
            }
            .parse_toml()?,
            None => Reader { file, text }.parse_toml()?,
        };
        Reader { file, text }.read_headers(&root, hash, facts.as_ref())
    }

    /// [`ModelFile::from_path`] on text; `file` is used in messages.
    pub fn from_str(file: &Path, text: &str) -> Result<ModelFile, ModelError> {
        let reader = Reader { file, text };
        let (root, hash) = reader.parse_tree()?;
        reader.read_file(&root, hash)
    }
}

impl Reader<'_> {
    /// Parse the TOML (with spans), read its structure, then check its meaning.
    fn read(&self) -> Result<Model, ModelError> {
        let (root, source_hash) = self.parse_tree()?;
        let raw = self.structure(&root)?;
        self.build(raw, source_hash)
    }

    /// The file's TOML tree (with spans) and the SHA-256 of its text.
    pub(super) fn parse_tree(&self) -> Result<(Tv, String), ModelError> {
        Ok((self.parse_toml()?, source_hash(self.text)))
    }

    /// The file's TOML tree (with spans).
    fn parse_toml(&self) -> Result<Tv, ModelError> {
        toml::from_str(self.text).map_err(|e| {
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
        })
    }

    /// The checks on meaning, in order: names, expressions, definitions, smoothness, the affine split.
    pub(super) fn build(&self, raw: RawModel, source_hash: String) -> Result<Model, ModelError> {
        let names = self.declare(raw.declarations())?;
        let declared = raw.declarations().into_iter().map(|(n, at, _)| (n, at));
        let outputs_declared = raw.outputs.iter().map(|e| (e.name.as_str(), e.at));
        self.check_derivative_names(&raw.maps, declared.chain(outputs_declared))?;
        self.check_columns(&names, raw.outputs.iter().map(|e| (e.name.as_str(), e.at)))?;
        let items = self.parse_all(&raw, &names)?;
        self.check_engine_map(&raw)?;
        let uses = self.definition_graph(&raw, &names, &items)?;
        self.check_smooth(&raw, &names, &items, &uses)?;
        let described: Vec<String> = items.iter().map(|it| describe(&raw, it.role)).collect();

        let RawModel {
            name,
            description,
            parameters,
            definitions,
            states,
            input,
            output,
            outputs,
            engine,
            headline,
            maps,
            signals,
        } = raw;
        let engine = {
            let names: Vec<&str> = outputs.iter().map(|o| o.name.as_str()).collect();
            engine
                .map(|e| self.resolve_engine(&e, &names))
                .transpose()?
        };
        let tracks_speed = output.reference_offset.unwrap_or(0.0) == 0.0
            && output.reference_scale.unwrap_or(1.0) == 1.0;
        let mut m = Interned::new(
            parameters,
            definitions,
            &states,
            (&input, &signals),
            &maps,
            &items,
        )
        .map_err(|t| self.too_large_definition(t))?;
        let signals: Vec<Signal> = signals
            .into_iter()
            .map(|s| Signal {
                symbol: m.pool.symbol(&s.name),
                name: s.name,
                unit: s.unit,
                doc: s.doc,
                default: s.default,
                column: s.column,
            })
            .collect();
        let definition_symbols: Vec<_> = items
            .iter()
            .map(|it| match it.role {
                Role::Definition(i) => m.definitions.get(i).map(|d| d.symbol),
                _ => None,
            })
            .collect();
        self.check_defined(
            &mut m.pool,
            (&m.nominal, &m.inline),
            &items,
            (&described, &definition_symbols),
        )?;
        let states = self.split_states(states, &input.name, &mut m, &items)?;
        let output = self.split_output(output, &input.name, &mut m, &items)?;
        self.check_finite(&m.pool, &m.nominal, (&states, &output), &items)?;
        let outputs = extra_outputs(outputs, tracks_speed, &mut m);
        let headline = headline
            .map(|h| self.resolve_headline(h, &outputs, &m.parameters))
            .transpose()?;
        let maps = maps
            .into_iter()
            .map(|r| {
                // Interned::new declares every map; a missing one would be a bug, reported, not a panic.
                let id = m.pool.find_map(&r.name).ok_or_else(|| {
                    self.err(
                        None,
                        ModelErrorKind::Schema,
                        format!(
                            "map `{}` was not declared (a bug in invsim's reader)",
                            r.name
                        ),
                    )
                })?;
                Ok(MapInfo {
                    id,
                    name: r.name,
                    args: r.args,
                    unit: r.unit,
                    doc: r.doc,
                    file: r.file,
                    data: r.data,
                })
            })
            .collect::<Result<Vec<_>, ModelError>>()?;

        let name = name.unwrap_or_else(|| {
            self.file
                .file_stem()
                .and_then(|s| s.to_str())
                .filter(|s| !s.is_empty())
                .unwrap_or("model")
                .to_string()
        });
        Ok(Model {
            name,
            description,
            file: self.file.to_path_buf(),
            source_hash,
            pool: m.pool,
            parameters: m.parameters,
            definitions: m.definitions,
            states,
            input: Input {
                name: input.name,
                symbol: m.u,
                unit: input.unit,
                doc: input.doc,
                min: input.min,
                max: input.max,
            },
            output,
            outputs,
            engine,
            headline,
            maps,
            signals,
        })
    }
}

/// The SHA-256 of a model file's text, as lower-case hex (what compiled code is matched by).
fn source_hash(text: &str) -> String {
    Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// `text` with every top-level table other than the modal ones (`[inputs.*]`, `[modes.*]`, `[gearbox]`,
/// `[sequence]`, `[hybrid]`) and the keys before the first table blanked: each of their bytes but the line
/// ends replaced by a space, so that every offset (a span in a message) stays where it was. For a file that is
/// a compiled model's byte for byte, whose headers are all a compiled run reads from the TOML
/// ([`ModelFile::modal_headers_of`]): the rest (parameters, definitions, outputs, maps) is most of the file.
/// A table starts at a line `[KEY]` or `[KEY.…]` at the line's start (a comment may follow); a row of a
/// multi-line array is not one (it is not a key).
fn modal_tables_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut keep = false;
    for line in text.split_inclusive('\n') {
        if let Some(key) = table_key(line) {
            keep = super::keys::TOP_MODAL.contains(&key);
        }
        if keep {
            out.push_str(line);
        } else {
            // One space per byte (a character of several bytes too: no byte of one is a line end), the
            // line ends kept: the offsets stay.
            let blank = |b: u8| {
                if b == b'\n' || b == b'\r' {
                    char::from(b)
                } else {
                    ' '
                }
            };
            out.extend(line.bytes().map(blank));
        }
    }
    out
}

/// The top-level key of a table header line (`[gearbox]`, `[modes.drive]  # …` → `gearbox`, `modes`).
fn table_key(line: &str) -> Option<&str> {
    let rest = line.strip_prefix('[')?;
    let header = rest.split('#').next()?.trim_end();
    let inner = header.strip_suffix(']')?;
    let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.';
    if inner.is_empty() || !inner.chars().all(bare) {
        return None;
    }
    inner.split('.').next()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shipped model file with modes: the blanked text has the same bytes' count, the same lines, the
    /// modal tables parse to the same values as in the whole file, and nothing else is left.
    #[test]
    fn only_the_modal_tables_are_left_where_they_were() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let mut checked = 0;
        for entry in std::fs::read_dir(&dir).expect("models/") {
            let path = entry.expect("entry").path();
            if path.extension().is_none_or(|x| x != "toml") {
                continue;
            }
            let text = std::fs::read_to_string(&path).expect("readable");
            let full: toml::Table = toml::from_str(&text).expect("the whole file parses");
            if !full
                .keys()
                .any(|k| super::super::keys::TOP_MODAL.contains(&k.as_str()))
            {
                continue;
            }
            let blanked = modal_tables_only(&text);
            assert_eq!(blanked.len(), text.len(), "{}", path.display());
            assert_eq!(blanked.lines().count(), text.lines().count());
            let kept: toml::Table = toml::from_str(&blanked).expect("the modal tables parse");
            let modal: Vec<&String> = full
                .keys()
                .filter(|k| super::super::keys::TOP_MODAL.contains(&k.as_str()))
                .collect();
            assert_eq!(kept.keys().collect::<Vec<_>>(), modal, "{}", path.display());
            for k in modal {
                assert_eq!(kept[k], full[k], "{} [{k}]", path.display());
            }
            checked += 1;
        }
        assert!(checked >= 4, "only {checked} model files with modes");
    }

    #[test]
    fn a_row_of_an_array_is_no_table() {
        assert_eq!(table_key("[modes.drive]   # engine on\n"), Some("modes"));
        assert_eq!(table_key("[gearbox]\n"), Some("gearbox"));
        assert_eq!(table_key("[1.0, 2.0],\n"), None);
        assert_eq!(table_key("  [modes.x]\n"), None);
        assert_eq!(table_key("[[points]]\n"), None);
    }
}
