//! Fuzz entry points of the model reader, the expression parser and the whole derive pipeline.
//!
//! Each function takes the fuzzer's bytes, returns `Ok(())` when the library accepted them and `Err(message)`
//! when it rejected them, and panics only on a defect (a panic in the library or a broken property below).
//! The library's own budgets apply: the model reader's expression length and nesting limits, and for the bare
//! parser the same length limit, [`invsim_inversion::MAX_EXPRESSION_LEN`].

use invsim_expr::Pool;
use invsim_inversion::{Derivation, Model, MAX_EXPRESSION_LEN};
use std::path::Path;

/// The file name used in messages (and as the model's default name).
const FILE: &str = "fuzz.toml";

/// Model reader: bytes → validated model (UTF-8 check included, as for a file).
pub fn model_reader(data: &[u8]) -> Result<(), String> {
    Model::from_bytes(Path::new(FILE), data)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// Expression parser: text → syntax tree → canonical DAG → printed text, which must parse back (contract §1:
/// every printed expression is in the same language), and the printed derivative by the first name.
pub fn expr_parser(data: &[u8]) -> Result<(), String> {
    let text = std::str::from_utf8(data).map_err(|e| e.to_string())?;
    if text.len() > MAX_EXPRESSION_LEN {
        return Err(format!("longer than {MAX_EXPRESSION_LEN} bytes"));
    }
    let ast = invsim_expr::parse(text).map_err(|e| e.to_string())?;
    let mut pool = Pool::new();
    let e = pool.from_ast(&ast);
    let printed = pool.display(e);
    if let Err(err) = pool.parse(&printed) {
        panic!("printed form `{printed}` of `{text}` does not parse back: {err}");
    }
    if let Some((name, _)) = ast.identifiers().first() {
        let x = pool.symbol(name);
        let d = pool.diff(e, x);
        let _ = pool.display(d);
    }
    Ok(())
}

/// Derive pipeline: bytes → model → derivation → text, JSON and Markdown renderings.
pub fn derive_pipeline(data: &[u8]) -> Result<(), String> {
    let model = Model::from_bytes(Path::new(FILE), data).map_err(|e| e.to_string())?;
    let d = Derivation::new(model).map_err(|e| e.to_string())?;
    let _ = d.to_text();
    let _ = d.to_json().to_string();
    let _ = d.to_markdown();
    Ok(())
}
