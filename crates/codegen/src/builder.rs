//! The build-script API, in the style of `prost-build`: generate Rust modules for model files into a
//! directory, rewriting a file only when its contents change, and tell Cargo which files to watch.
//!
//! ```no_run
//! // build.rs
//! fn main() -> Result<(), invsim_codegen::Error> {
//!     invsim_codegen::Builder::new().model("model.toml").compile()?;
//!     Ok(())
//! }
//! // src/lib.rs: include!(concat!(env!("OUT_DIR"), "/<model name>.rs"));
//! ```

use crate::error::{CodegenError, Error};
use crate::generate::{generate, source_name};
use proc_macro2::TokenStream;
use quote::{format_ident, quote};
use std::path::{Path, PathBuf};

/// Generates one Rust module per model file.
#[derive(Debug, Clone)]
pub struct Builder {
    models: Vec<PathBuf>,
    out_dir: Option<PathBuf>,
    cargo_metadata: bool,
}

impl Default for Builder {
    fn default() -> Builder {
        Builder::new()
    }
}

/// What [`Builder::compile`] wrote for one model.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Generated {
    /// The model's name (its `name`, or the file stem).
    pub name: String,
    /// The module the file defines (`pub mod <module>`), also the file stem of [`Generated::path`].
    pub module: String,
    /// The model file.
    pub source: PathBuf,
    /// SHA-256 of the model file (lower-case hex).
    pub source_hash: String,
    /// The generated Rust file.
    pub path: PathBuf,
    /// Was the file (re)written? False when its contents were already up to date.
    pub written: bool,
    /// The modes of a model with operating modes, in the file's order (empty for a single-mode model).
    pub modes: Vec<String>,
}

impl Builder {
    /// A builder with no models, writing to `$OUT_DIR` and printing `cargo:rerun-if-changed` lines.
    pub fn new() -> Builder {
        Builder {
            models: Vec::new(),
            out_dir: None,
            cargo_metadata: true,
        }
    }

    /// Add a model file.
    pub fn model(mut self, path: impl AsRef<Path>) -> Builder {
        self.models.push(path.as_ref().to_path_buf());
        self
    }

    /// Add several model files.
    pub fn models<P: AsRef<Path>>(mut self, paths: impl IntoIterator<Item = P>) -> Builder {
        self.models
            .extend(paths.into_iter().map(|p| p.as_ref().to_path_buf()));
        self
    }

    /// Where to write `<module>.rs` (default: the `OUT_DIR` Cargo gives build scripts).
    pub fn out_dir(mut self, dir: impl AsRef<Path>) -> Builder {
        self.out_dir = Some(dir.as_ref().to_path_buf());
        self
    }

    /// Print `cargo:rerun-if-changed=<model file>` for every model read (default: on).
    pub fn cargo_metadata(mut self, on: bool) -> Builder {
        self.cargo_metadata = on;
        self
    }

    /// Generate every model; stops at the first error (whose message for a bad model is the one
    /// `invsim derive` prints).
    pub fn compile(self) -> Result<Vec<Generated>, Error> {
        let out_dir = match self.out_dir {
            Some(d) => d,
            None => std::env::var_os("OUT_DIR")
                .map(PathBuf::from)
                .ok_or(Error::NoOutDir)?,
        };
        std::fs::create_dir_all(&out_dir).map_err(|source| Error::Write {
            path: out_dir.clone(),
            source,
        })?;
        let mut done: Vec<Generated> = Vec::new();
        for path in &self.models {
            if self.cargo_metadata {
                println!("cargo:rerun-if-changed={}", path.display());
            }
            let (name, hash, modes, rust) = generate_any(path)?;
            let module = crate::names::module_name(&name);
            if let Some(first) = done.iter().find(|g| g.module == module) {
                return Err(Error::DuplicateModule {
                    module,
                    first: first.source.clone(),
                    second: path.clone(),
                });
            }
            let target = out_dir.join(format!("{module}.rs"));
            let written = write_if_changed(&target, &rust)?;
            done.push(Generated {
                name,
                module,
                source: path.clone(),
                source_hash: hash,
                path: target,
                written,
                modes,
            });
        }
        Ok(done)
    }
}

/// Read and derive one model file, single-mode or with modes: (name, SHA-256, modes, Rust source).
fn generate_any(path: &Path) -> Result<(String, String, Vec<String>, String), Error> {
    let file =
        invsim_inversion::ModelFile::from_path(path).map_err(invsim_inversion::Error::from)?;
    match file {
        invsim_inversion::ModelFile::Single(model) => {
            let d =
                invsim_inversion::Derivation::new(*model).map_err(invsim_inversion::Error::from)?;
            let rust = generate(&d, &source_name(path))?;
            Ok((
                d.model.name.clone(),
                d.model.source_hash.clone(),
                Vec::new(),
                rust,
            ))
        }
        invsim_inversion::ModelFile::Modal(m) => {
            let md = crate::modal::ModalDerivation::new(*m)?;
            let rust = crate::modal::generate_modal(&md, &source_name(path))?;
            let names = md.modes.into_iter().map(|x| x.name).collect();
            Ok((md.name, md.source_hash, names, rust))
        }
    }
}

/// Write `text` to `path` unless the file already holds exactly that (keeps timestamps, so Cargo does not
/// rebuild needlessly). Returns whether it wrote.
pub(crate) fn write_if_changed(path: &Path, text: &str) -> Result<bool, Error> {
    if std::fs::read(path).is_ok_and(|old| old == text.as_bytes()) {
        return Ok(false);
    }
    std::fs::write(path, text).map_err(|source| Error::Write {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(true)
}

/// The first of `models` for each model file's SHA-256 (two files with the same bytes are one arm of a match).
fn one_per_file<'g>(models: &[&'g Generated]) -> Vec<&'g Generated> {
    let mut seen = std::collections::HashSet::new();
    models
        .iter()
        .copied()
        .filter(|g| seen.insert(g.source_hash.clone()))
        .collect()
}

/// `if bytes == <g's model file> { return <found>; }`: a `by_source` look-up's arm for g.
fn source_arm(g: &Generated, found: TokenStream) -> TokenStream {
    let p = g.source.display().to_string();
    quote!(if bytes == include_bytes!(#p).as_slice() { return #found; })
}

/// The registry's part for models with modes: `MODAL_MODELS` (name, SHA-256, model file name) and
/// `modal_by_hash(sha256)`, every mode's model at its default parameters in the file's order.
fn modal_registry(all: &[&Generated]) -> TokenStream {
    let modal: Vec<&Generated> = all
        .iter()
        .copied()
        .filter(|g| !g.modes.is_empty())
        .collect();
    let rows = modal.iter().map(|g| {
        let (n, h, f) = (&g.name, &g.source_hash, source_name(&g.source));
        quote!((#n, #h, #f))
    });
    let arms: Vec<TokenStream> = one_per_file(&modal)
        .into_iter()
        .map(|g| {
            let (h, m) = (&g.source_hash, format_ident!("{}", g.module));
            quote!(#h => Some(#m::models()),)
        })
        .collect();
    let body = if arms.is_empty() {
        quote!(let _ = sha256; None)
    } else {
        quote!(match sha256 { #(#arms)* _ => None, })
    };
    let by_source: Vec<TokenStream> = one_per_file(&modal)
        .into_iter()
        .map(|g| {
            let h = &g.source_hash;
            source_arm(g, quote!(Some(#h)))
        })
        .collect();
    quote! {
        /// (name, SHA-256 of the model file, model file name) of every compiled model with operating modes,
        /// sorted by name.
        pub const MODAL_MODELS: &[(&str, &str, &str)] = &[#(#rows),*];

        /// The compiled modes of the model with operating modes generated from a model file with this
        /// SHA-256 (lower-case hex): every mode's model at its default parameters, in the file's order.
        pub fn modal_by_hash(sha256: &str) -> Option<Vec<Box<dyn invsim_model_api::InverseModel>>> {
            #body
        }

        /// The SHA-256 of the model file with operating modes whose bytes are exactly these (a comparison of
        /// lengths, then of bytes: what hashing them and [`modal_by_hash`] would find, without hashing).
        pub fn modal_hash_of_source(bytes: &[u8]) -> Option<&'static str> {
            let _ = bytes;
            #(#by_source)*
            None
        }
    }
}

/// Source of a registry over generated modules: `include!`s each file (by absolute path) and defines
/// `NAMES`, `MODELS` (name, SHA-256, model file name), `names()`, `builtin(name)`, `by_hash(sha256)` and
/// `by_source(bytes)`, the last three returning the model at its default parameters as a boxed `InverseModel`.
pub fn registry(models: &[Generated]) -> Result<String, CodegenError> {
    let mut all: Vec<&Generated> = models.iter().collect();
    all.sort_by(|a, b| a.name.cmp(&b.name));
    let includes = all.iter().map(|g| {
        let p = g.path.display().to_string();
        quote!(include!(#p);)
    });
    let modal = modal_registry(&all);
    let sorted: Vec<&Generated> = all.iter().copied().filter(|g| g.modes.is_empty()).collect();
    let names: Vec<&str> = sorted.iter().map(|g| g.name.as_str()).collect();
    let rows = sorted.iter().map(|g| {
        let (n, h, f) = (&g.name, &g.source_hash, source_name(&g.source));
        quote!((#n, #h, #f))
    });
    let ctor = |g: &Generated| -> TokenStream {
        let m = format_ident!("{}", g.module);
        quote!(Some(Box::new(#m::Model::default())))
    };
    let by_name = sorted.iter().map(|g| {
        let (n, c) = (&g.name, ctor(g));
        quote!(#n => #c,)
    });
    let by_hash: Vec<TokenStream> = one_per_file(&sorted)
        .into_iter()
        .map(|g| {
            let (h, c) = (&g.source_hash, ctor(g));
            quote!(#h => #c,)
        })
        .collect();
    let by_source: Vec<TokenStream> = one_per_file(&sorted)
        .into_iter()
        .map(|g| source_arm(g, ctor(g)))
        .collect();
    let (builtin, by_hash) = if sorted.is_empty() {
        (
            quote! {
                pub fn builtin(_name: &str) -> Option<Box<dyn invsim_model_api::InverseModel>> {
                    None
                }
            },
            quote! {
                pub fn by_hash(_sha256: &str) -> Option<Box<dyn invsim_model_api::InverseModel>> {
                    None
                }
            },
        )
    } else {
        (
            quote! {
                pub fn builtin(name: &str) -> Option<Box<dyn invsim_model_api::InverseModel>> {
                    match name {
                        #(#by_name)*
                        _ => None,
                    }
                }
            },
            quote! {
                pub fn by_hash(sha256: &str) -> Option<Box<dyn invsim_model_api::InverseModel>> {
                    match sha256 {
                        #(#by_hash)*
                        _ => None,
                    }
                }
            },
        )
    };
    let tokens = quote! {
        #(#includes)*

        /// Names of the compiled models, sorted.
        pub const NAMES: &[&str] = &[#(#names),*];

        /// (name, SHA-256 of the model file, model file name) of every compiled model, sorted by name.
        pub const MODELS: &[(&str, &str, &str)] = &[#(#rows),*];

        /// Names of the compiled models, sorted.
        pub fn names() -> &'static [&'static str] {
            NAMES
        }

        /// The compiled model called `name`, at its default parameters.
        #builtin

        /// The compiled model generated from a model file with this SHA-256 (lower-case hex), at its default
        /// parameters.
        #by_hash

        /// The compiled model generated from a model file with exactly these bytes, at its default
        /// parameters (what [`by_hash`] finds, without hashing: a comparison of lengths, then of bytes).
        pub fn by_source(bytes: &[u8]) -> Option<Box<dyn invsim_model_api::InverseModel>> {
            let _ = bytes;
            #(#by_source)*
            None
        }

        #modal
    };
    crate::format::format_file(
        tokens,
        "// @generated by invsim: registry of compiled models; do not edit\n",
        &[],
        "the registry",
    )
}
