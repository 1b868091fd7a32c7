//! The workspace's coding habits as checks (rust-analyzer's `tidy`): every source file opens with a `//!`
//! line, no function is longer than [`MAX_FUNCTION_LINES`], library code calls no `.unwrap()`/`.expect(`
//! outside tests, and no crate's files import each other in a circle. Each check returns its violations
//! (path, line, what, a one-line fix hint); `tests/tests/tidy.rs` runs them on the workspace with allow-lists.

pub mod imports;
pub mod items;
pub mod lex;
pub mod warnings;

use std::fmt;
use std::path::Path;

pub use imports::SourceFile;

/// The longest function allowed, in lines from its `fn` line to its closing brace.
pub const MAX_FUNCTION_LINES: usize = 150;

/// One broken habit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Violation {
    /// The file (or, for a circle, the crate directory), relative to the workspace root.
    pub path: String,
    pub line: usize,
    /// What an allow-list entry names: the function, the source line, the files of a circle.
    pub subject: String,
    pub message: String,
    pub hint: &'static str,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: {} (fix: {})",
            self.path, self.line, self.message, self.hint
        )
    }
}

/// An allow-list entry: the path and subject of a [`Violation`] it excuses, and why.
pub type Allow = (&'static str, &'static str, &'static str);

/// Whether `text` is a generated file: it has a line starting with `// @generated`.
fn is_generated(text: &str) -> bool {
    text.lines()
        .any(|l| l.trim_start().starts_with("// @generated"))
}

fn rust_files_under(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
        if path.is_dir() {
            rust_files_under(&path, out);
        } else if path.extension().is_some_and(|x| x == "rs") {
            out.push(path);
        }
    }
}

/// The workspace's checked sources: `crates/*/src`, `xtask/src`, `tests/src` and every `build.rs` of those
/// packages; not their `tests/` or `benches/` folders, not generated files (a `// @generated` line).
pub fn workspace_sources(root: &Path) -> std::io::Result<Vec<SourceFile>> {
    let mut packages: Vec<std::path::PathBuf> = std::fs::read_dir(root.join("crates"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    packages.extend([root.join("xtask"), root.join("tests")]);
    let mut paths = Vec::new();
    for p in &packages {
        rust_files_under(&p.join("src"), &mut paths);
        if p.join("build.rs").is_file() {
            paths.push(p.join("build.rs"));
        }
    }
    let mut out = Vec::new();
    for p in paths {
        let text = std::fs::read_to_string(&p)?;
        let rel = p.strip_prefix(root).unwrap_or(&p);
        let path = rel.to_string_lossy().replace('\\', "/");
        if !is_generated(&text) {
            out.push(SourceFile { path, text });
        }
    }
    out.sort_by(|a, b| a.path.cmp(&b.path));
    Ok(out)
}

/// Files whose first line is not a `//!` line.
pub fn missing_module_docs(files: &[SourceFile]) -> Vec<Violation> {
    files
        .iter()
        .filter(|f| !f.text.starts_with("//!"))
        .map(|f| Violation {
            path: f.path.clone(),
            line: 1,
            subject: f.path.clone(),
            message: "the file does not start with a `//!` line".into(),
            hint: "open the file with `//! <what this file is for>`",
        })
        .collect()
}

/// Functions outside test code and code templates (`quote!`) longer than `max` lines.
pub fn long_functions(files: &[SourceFile], max: usize) -> Vec<Violation> {
    let mut out = Vec::new();
    for f in files {
        let tokens = lex::tokenize(&f.text);
        let exempt = items::exempt_regions(&tokens);
        for func in items::functions(&tokens) {
            if func.lines() > max && !items::in_regions(&exempt, func.first_line) {
                out.push(Violation {
                    path: f.path.clone(),
                    line: func.first_line,
                    subject: func.name.clone(),
                    message: format!(
                        "fn {} is {} lines long (at most {max})",
                        func.name,
                        func.lines()
                    ),
                    hint: "split it into named steps, each a function of its own",
                });
            }
        }
    }
    out
}

/// `.unwrap()` and `.expect(` calls outside test code and code templates (`quote!`) in library sources
/// (`crates/*/src`); a call on `self` is a method of the file's own type (a parser's `expect`), not `Option`'s
/// or `Result`'s.
pub fn unwraps(files: &[SourceFile]) -> Vec<Violation> {
    let mut out = Vec::new();
    for f in files.iter().filter(|f| is_library_source(&f.path)) {
        let tokens = lex::tokenize(&f.text);
        let exempt = items::exempt_regions(&tokens);
        let lines: Vec<&str> = f.text.lines().collect();
        for (i, t) in tokens.iter().enumerate().skip(1) {
            let call =
                (t.is("unwrap") && tokens.get(i + 2).is_some_and(|c| c.is(")"))) || t.is("expect");
            let is_call = call
                && tokens[i - 1].is(".")
                && tokens.get(i + 1).is_some_and(|p| p.is("("))
                && !(i >= 2 && tokens[i - 2].is("self"));
            if is_call && !items::in_regions(&exempt, t.line) {
                let text = lines.get(t.line - 1).map_or("", |l| l.trim());
                out.push(Violation {
                    path: f.path.clone(),
                    line: t.line,
                    subject: text.to_string(),
                    message: format!("`.{}(` in library code: `{text}`", t.text),
                    hint: "return a typed error (`?`, `ok_or`), or allow-list it with the reason it cannot fail",
                });
            }
        }
    }
    out
}

/// Whether `path` is the non-test source of a library crate under `crates/`.
fn is_library_source(path: &str) -> bool {
    let mut parts = path.split('/');
    parts.next() == Some("crates") && parts.next().is_some() && parts.next() == Some("src")
}

/// The crate directory of a source path and the path below its `src/` (`None` for `build.rs`).
fn crate_and_module(path: &str) -> Option<(&str, &str)> {
    let k = path.find("/src/")?;
    Some((&path[..k], &path[k + 5..]))
}

/// Import circles between the files of each crate.
pub fn import_circles(files: &[SourceFile]) -> Vec<Violation> {
    let mut crates: std::collections::BTreeMap<&str, Vec<(SourceFile, Vec<String>)>> =
        std::collections::BTreeMap::new();
    let has_lib = |krate: &str| {
        files
            .iter()
            .any(|f| f.path == format!("{krate}/src/lib.rs"))
    };
    for f in files {
        let Some((krate, rel)) = crate_and_module(&f.path) else {
            continue;
        };
        // A `main.rs` next to a `lib.rs` is a crate of its own that uses the library as an extern crate.
        let krate = if rel == "main.rs" && has_lib(krate) {
            &f.path
        } else {
            krate
        };
        let entry = (f.clone(), imports::module_path(rel));
        crates.entry(krate).or_default().push(entry);
    }
    let mut out = Vec::new();
    for (krate, files) in crates {
        for c in imports::graph(&files).circles() {
            let steps: Vec<String> = c.cycle.iter().map(|(p, l)| format!("{p}:{l}")).collect();
            out.push(Violation {
                path: krate.to_string(),
                line: c.cycle.first().map_or(0, |s| s.1),
                subject: c.files.join(" "),
                message: format!(
                    "import circle between {} (each imports the next: {} → back)",
                    c.files.join(", "),
                    steps.join(" → ")
                ),
                hint: "move what both sides need into a module of its own that imports neither",
            });
        }
    }
    out
}

/// The violations no entry of `allow` excuses, and the entries that excuse nothing (stale: remove them).
pub fn apply_allow_list(
    violations: Vec<Violation>,
    allow: &[Allow],
    matches: fn(&Violation, &Allow) -> bool,
) -> (Vec<Violation>, Vec<&Allow>) {
    let stale = allow
        .iter()
        .filter(|a| !violations.iter().any(|v| matches(v, a)))
        .collect();
    let left = violations
        .into_iter()
        .filter(|v| !allow.iter().any(|a| matches(v, a)))
        .collect();
    (left, stale)
}

/// An entry names the path and the subject exactly.
pub fn same_subject(v: &Violation, a: &Allow) -> bool {
    v.path == a.0 && v.subject == a.1
}

/// An entry names the start of the path (a file, or a module's files: `src/derive` for `derive.rs` and
/// `derive/*.rs`) and a piece of the source line.
pub fn line_contains(v: &Violation, a: &Allow) -> bool {
    v.path.starts_with(a.0) && v.subject.contains(a.1)
}
