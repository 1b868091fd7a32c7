//! No import circle between the files of invsim-expr or invsim-codegen: a scan of the `crate::…` and
//! `super::…` paths of every source file (test modules excluded), and of the crate root's `use` items.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path (`["model", "batch"]`) → file, for every `.rs` file below `src`.
fn modules(src: &Path) -> BTreeMap<Vec<String>, PathBuf> {
    let mut out = BTreeMap::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).expect("source directory").flatten() {
            let path = entry.path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path
                    .strip_prefix(src)
                    .expect("below src")
                    .with_extension("");
                let mut segs: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if matches!(segs.last().map(String::as_str), Some("lib" | "mod")) {
                    segs.pop();
                }
                out.insert(segs, path);
            }
        }
    }
    out
}

/// The paths a file names: `crate::a::b`, `super::c`, and the segments of `use` groups (`use crate::{a, b}`
/// gives `crate::a` and `crate::b`); a crate root's `use a::…` counts as `crate::a`.
fn named_paths(text: &str, is_root: bool) -> Vec<Vec<String>> {
    let code = text.split("#[cfg(test)]").next().unwrap_or("");
    let code: String = code
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let mut out = Vec::new();
    for stmt in code.split(';') {
        let stmt = stmt.trim();
        let Some(at) = stmt
            .match_indices("use ")
            .map(|(i, _)| i)
            .find(|&i| i == 0 || !stmt[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_'))
        else {
            continue;
        };
        let body: String = stmt[at + 4..]
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect();
        let (prefix, group) = match body.find('{') {
            Some(i) => (&body[..i], body[i + 1..].trim_end_matches('}')),
            None => (body.as_str(), ""),
        };
        let mut base: Vec<String> = prefix
            .split("::")
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        if is_root && base.first().is_some_and(|s| s != "crate" && s != "super") {
            base.insert(0, "crate".into());
        }
        if group.is_empty() {
            out.push(base.clone());
        }
        for item in group.split(',').filter(|s| !s.is_empty()) {
            let mut p = base.clone();
            p.extend(item.split("::").map(String::from));
            out.push(p);
        }
    }
    for word in code.split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')) {
        let segs: Vec<String> = word
            .split("::")
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        if segs.len() > 1 && (segs[0] == "crate" || segs[0] == "super") {
            out.push(segs);
        }
    }
    out
}

/// The module a path lands in, as seen from module `from`.
fn target(
    path: &[String],
    from: &[String],
    mods: &BTreeMap<Vec<String>, PathBuf>,
) -> Option<Vec<String>> {
    let (mut at, rest) = match path.first().map(String::as_str) {
        Some("crate") => (Vec::new(), &path[1..]),
        Some("super") => {
            let ups = path.iter().take_while(|s| *s == "super").count();
            (
                from[..from.len().saturating_sub(ups)].to_vec(),
                &path[ups..],
            )
        }
        _ => return None,
    };
    for seg in rest {
        let mut next = at.clone();
        next.push(seg.clone());
        if !mods.contains_key(&next) {
            break;
        }
        at = next;
    }
    Some(at)
}

/// A cycle in the import graph of the crate at `src`, if there is one.
fn cycle(src: &Path) -> Option<Vec<Vec<String>>> {
    let mods = modules(src);
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (m, file) in &mods {
        let text = std::fs::read_to_string(file).expect("source file");
        let to: BTreeSet<Vec<String>> = named_paths(&text, m.is_empty())
            .iter()
            .filter_map(|p| target(p, m, &mods))
            .filter(|t| t != m)
            .collect();
        edges.insert(m.clone(), to);
    }
    fn visit(
        m: &Vec<String>,
        edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        stack: &mut Vec<Vec<String>>,
        done: &mut BTreeSet<Vec<String>>,
    ) -> Option<Vec<Vec<String>>> {
        if let Some(i) = stack.iter().position(|s| s == m) {
            return Some(stack[i..].to_vec());
        }
        if !done.insert(m.clone()) {
            return None;
        }
        stack.push(m.clone());
        for t in edges.get(m).into_iter().flatten() {
            if let Some(c) = visit(t, edges, stack, done) {
                return Some(c);
            }
        }
        stack.pop();
        None
    }
    let mut done = BTreeSet::new();
    edges
        .keys()
        .find_map(|m| visit(m, &edges, &mut Vec::new(), &mut done))
}

#[test]
fn no_import_circle_between_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for src in [root.join("src"), root.join("../expr/src")] {
        assert!(modules(&src).len() > 5, "{} has its files", src.display());
        if let Some(c) = cycle(&src) {
            panic!("import circle in {}: {c:?}", src.display());
        }
    }
}

#[test]
fn the_scan_sees_a_circle() {
    let dir = std::env::temp_dir().join(format!("invsim-imports-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch");
    let write = |name: &str, text: &str| std::fs::write(dir.join(name), text).expect("write");
    write("lib.rs", "//! root\nmod a;\nmod b;\n");
    write("a.rs", "//! a\nuse crate::b::B;\npub struct A;\n");
    write("b.rs", "//! b\nuse crate::{a::A, lib};\npub struct B;\n");
    assert!(cycle(&dir).is_some());
    write("b.rs", "//! b\npub struct B;\n");
    assert!(cycle(&dir).is_none());
    let _ = std::fs::remove_dir_all(&dir);
}
