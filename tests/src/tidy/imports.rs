//! The import graph between the files (modules) of one crate, from `use crate::…`, `use super::…`,
//! `use self::…`, paths relative to a child module, and `crate::x::` / `super::x::` paths in code, with
//! re-exports (`pub use`) followed to the file that defines the item; and its circles (strongly connected
//! components of more than one file).

use super::items::{in_regions, matching, test_regions};
use super::lex::{tokenize, Kind, Token};
use std::collections::BTreeMap;

/// One source file of a crate: its path (as reported) and its text.
#[derive(Debug, Clone)]
pub struct SourceFile {
    pub path: String,
    pub text: String,
}

/// The module path of a file under `src/`: `lib.rs`/`main.rs` → [], `a.rs` and `a/mod.rs` → [a], `a/b.rs` →
/// [a, b]. `rel` is the path below `src/`, with `/` separators.
pub fn module_path(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel.split('/').map(str::to_string).collect();
    let last = parts.pop().unwrap_or_default();
    let stem = last.strip_suffix(".rs").unwrap_or(&last).to_string();
    let is_root = parts.is_empty() && (stem == "lib" || stem == "main");
    if stem != "mod" && !is_root {
        parts.push(stem);
    }
    parts
}

/// A path named in a file: its segments as written, the line, and whether it is a `pub use` (a re-export,
/// recorded under `alias`).
#[derive(Debug, Clone)]
struct Named {
    segments: Vec<String>,
    line: usize,
    module: Vec<String>,
    reexport: Option<String>,
}

/// Parse the use tree starting at `i` under `prefix`; pushes (segments, alias) and returns the index after it.
fn use_tree(
    tokens: &[Token],
    mut i: usize,
    prefix: &[String],
    out: &mut Vec<(Vec<String>, String)>,
) -> usize {
    let mut path = prefix.to_vec();
    while let Some(t) = tokens.get(i) {
        if t.is("{") {
            let end = matching(tokens, i);
            i += 1;
            while i < end {
                i = use_tree(tokens, i, &path, out);
                if tokens.get(i).is_some_and(|t| t.is(",")) {
                    i += 1;
                }
            }
            return end + 1;
        }
        if t.is("*") {
            path.push("*".into());
            out.push((path, "*".into()));
            return i + 1;
        }
        if t.kind == Kind::Ident {
            path.push(t.text.clone());
            i += 1;
            if tokens.get(i).is_some_and(|t| t.is("::")) {
                i += 1;
                continue;
            }
            let mut alias = t.text.clone();
            if tokens.get(i).is_some_and(|t| t.is("as")) {
                alias = tokens
                    .get(i + 1)
                    .map(|t| t.text.clone())
                    .unwrap_or_default();
                i += 2;
            }
            if alias == "self" {
                alias = path
                    .get(path.len().saturating_sub(2))
                    .cloned()
                    .unwrap_or_default();
                path.pop();
            }
            out.push((path, alias));
            return i;
        }
        if t.is("::") {
            i += 1; // a leading `::` (an extern crate path)
            continue;
        }
        return i + 1;
    }
    i
}

/// Whether the `use` at `i` is a re-export: `pub use`, `pub(crate) use`, `pub(super) use`.
fn is_pub(tokens: &[Token], i: usize) -> bool {
    if i >= 1 && tokens[i - 1].is("pub") {
        return true;
    }
    i >= 2 && tokens[i - 1].is(")") && {
        let mut j = i - 1;
        while j > 0 && !tokens[j].is("(") {
            j -= 1;
        }
        j >= 1 && tokens[j - 1].is("pub")
    }
}

/// The inline modules `mod name { … }` of a token stream: (name, first token, last token).
fn inline_modules(tokens: &[Token]) -> Vec<(String, usize, usize)> {
    let mut out = Vec::new();
    for i in 0..tokens.len() {
        if tokens[i].is("mod") && tokens.get(i + 2).is_some_and(|t| t.is("{")) {
            out.push((tokens[i + 1].text.clone(), i + 2, matching(tokens, i + 2)));
        }
    }
    out
}

/// Every path a file names, outside its test code.
fn named_paths(file_module: &[String], tokens: &[Token]) -> Vec<Named> {
    let tests = test_regions(tokens);
    let inline = inline_modules(tokens);
    let module_at = |i: usize| -> Vec<String> {
        let mut m = file_module.to_vec();
        m.extend(
            inline
                .iter()
                .filter(|(_, a, b)| *a <= i && i <= *b)
                .map(|(n, _, _)| n.clone()),
        );
        m
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        let t = &tokens[i];
        if in_regions(&tests, t.line) {
            i += 1;
            continue;
        }
        if t.is("use") {
            let mut trees = Vec::new();
            let end = use_tree(tokens, i + 1, &[], &mut trees);
            let reexport = is_pub(tokens, i);
            for (segments, alias) in trees {
                out.push(Named {
                    segments,
                    line: t.line,
                    module: module_at(i),
                    reexport: reexport.then_some(alias),
                });
            }
            i = end;
            continue;
        }
        let starts_path = t.kind == Kind::Ident
            && tokens.get(i + 1).is_some_and(|n| n.is("::"))
            && !(i > 0 && (tokens[i - 1].is("::") || tokens[i - 1].is(".")));
        if starts_path {
            let mut segments = vec![t.text.clone()];
            let mut j = i + 1;
            while tokens.get(j).is_some_and(|n| n.is("::"))
                && tokens.get(j + 1).is_some_and(|n| n.kind == Kind::Ident)
            {
                segments.push(tokens[j + 1].text.clone());
                j += 2;
            }
            out.push(Named {
                segments,
                line: t.line,
                module: module_at(i),
                reexport: None,
            });
            i = j;
            continue;
        }
        i += 1;
    }
    out
}

/// One file's facts: the paths it names, its re-exports (alias → absolute path).
struct FileFacts {
    named: Vec<Named>,
    reexports: BTreeMap<String, Vec<String>>,
}

/// The crate's import graph: for every file, the files it uses with the first line that does.
pub struct Graph {
    pub files: Vec<String>,
    pub edges: BTreeMap<usize, BTreeMap<usize, usize>>,
}

type Modules = BTreeMap<Vec<String>, usize>;

/// The absolute module path a path written in `module` names, or `None` for an extern crate's path.
fn absolute(modules: &Modules, module: &[String], segments: &[String]) -> Option<Vec<String>> {
    let (first, rest) = segments.split_first()?;
    let mut base: Vec<String> = match first.as_str() {
        "crate" => Vec::new(),
        "self" => module.to_vec(),
        "super" => module[..module.len().saturating_sub(1)].to_vec(),
        _ => {
            let mut child = module.to_vec();
            child.push(first.clone());
            // A child module's path (an inline module's would be this file's own: no edge).
            if !modules.contains_key(&child) {
                return None;
            }
            child
        }
    };
    let mut rest = rest;
    while rest.first().is_some_and(|s| s == "super") {
        base.pop();
        rest = &rest[1..];
    }
    base.extend(rest.iter().cloned());
    Some(base)
}

/// The file that defines what the absolute path `abs` names, re-exports followed (at most 8 deep).
fn file_of(facts: &[FileFacts], modules: &Modules, abs: &[String], depth: usize) -> Option<usize> {
    let (file, len) = (0..=abs.len())
        .rev()
        .find_map(|k| modules.get(&abs[..k]).map(|&f| (f, k)))?;
    let item = abs.get(len)?;
    match facts[file].reexports.get(item) {
        Some(target) if depth < 8 => {
            let mut next = target.clone();
            next.extend(abs[len + 1..].iter().cloned());
            file_of(facts, modules, &next, depth + 1).or(Some(file))
        }
        _ => Some(file),
    }
}

/// Build the import graph of a crate's files, each with its module path ([`module_path`]).
pub fn graph(files: &[(SourceFile, Vec<String>)]) -> Graph {
    let modules: Modules = files
        .iter()
        .enumerate()
        .map(|(i, (_, m))| (m.clone(), i))
        .collect();
    let facts: Vec<FileFacts> = files
        .iter()
        .map(|(f, module)| {
            let named = named_paths(module, &tokenize(&f.text));
            let reexports = named
                .iter()
                .filter_map(|n| {
                    let alias = n.reexport.clone()?;
                    Some((alias, absolute(&modules, &n.module, &n.segments)?))
                })
                .collect();
            FileFacts { named, reexports }
        })
        .collect();
    let mut edges: BTreeMap<usize, BTreeMap<usize, usize>> = BTreeMap::new();
    for (from, f) in facts.iter().enumerate() {
        for n in f.named.iter().filter(|n| n.reexport.is_none()) {
            let to = absolute(&modules, &n.module, &n.segments)
                .and_then(|abs| file_of(&facts, &modules, &abs, 0));
            if let Some(to) = to.filter(|&to| to != from) {
                edges.entry(from).or_default().entry(to).or_insert(n.line);
            }
        }
    }
    Graph {
        files: files.iter().map(|(f, _)| f.path.clone()).collect(),
        edges,
    }
}

/// A circle: the files of one strongly connected component (sorted) and one cycle through them as
/// (file, line of its import of the next file).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Circle {
    pub files: Vec<String>,
    pub cycle: Vec<(String, usize)>,
}

impl Graph {
    fn successors(&self, v: usize) -> impl Iterator<Item = usize> + '_ {
        self.edges
            .get(&v)
            .into_iter()
            .flat_map(|m| m.keys().copied())
    }

    /// The strongly connected components with more than one file (Tarjan's algorithm).
    pub fn circles(&self) -> Vec<Circle> {
        let mut t = Tarjan {
            graph: self,
            index: vec![None; self.files.len()],
            low: vec![0; self.files.len()],
            stack: Vec::new(),
            on_stack: vec![false; self.files.len()],
            next: 0,
            components: Vec::new(),
        };
        for v in 0..self.files.len() {
            if t.index[v].is_none() {
                t.visit(v);
            }
        }
        let mut out: Vec<Circle> = t
            .components
            .into_iter()
            .filter(|c| c.len() > 1)
            .map(|c| self.circle(&c))
            .collect();
        out.sort_by(|a, b| a.files.cmp(&b.files));
        out
    }

    /// One cycle through the component `c` (a shortest path back to its first file, by breadth-first search).
    fn circle(&self, c: &[usize]) -> Circle {
        let start = c
            .iter()
            .copied()
            .min_by_key(|&v| &self.files[v])
            .unwrap_or(c[0]);
        let mut prev: BTreeMap<usize, usize> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([start]);
        'search: while let Some(v) = queue.pop_front() {
            for w in self.successors(v).filter(|w| c.contains(w)) {
                if w == start {
                    prev.insert(start, v);
                    break 'search;
                }
                if let std::collections::btree_map::Entry::Vacant(e) = prev.entry(w) {
                    e.insert(v);
                    queue.push_back(w);
                }
            }
        }
        let mut path = vec![start];
        let mut v = prev.get(&start).copied().unwrap_or(start);
        while v != start && path.len() <= c.len() {
            path.push(v);
            v = prev.get(&v).copied().unwrap_or(start);
        }
        path.reverse();
        path.rotate_right(1);
        let cycle = (0..path.len())
            .map(|k| {
                let (a, b) = (path[k], path[(k + 1) % path.len()]);
                let line = self
                    .edges
                    .get(&a)
                    .and_then(|m| m.get(&b))
                    .copied()
                    .unwrap_or(0);
                (self.files[a].clone(), line)
            })
            .collect();
        let mut files: Vec<String> = c.iter().map(|&v| self.files[v].clone()).collect();
        files.sort();
        Circle { files, cycle }
    }
}

struct Tarjan<'a> {
    graph: &'a Graph,
    index: Vec<Option<usize>>,
    low: Vec<usize>,
    stack: Vec<usize>,
    on_stack: Vec<bool>,
    next: usize,
    components: Vec<Vec<usize>>,
}

impl Tarjan<'_> {
    fn visit(&mut self, v: usize) {
        self.index[v] = Some(self.next);
        self.low[v] = self.next;
        self.next += 1;
        self.stack.push(v);
        self.on_stack[v] = true;
        let succ: Vec<usize> = self.graph.successors(v).collect();
        for w in succ {
            match self.index[w] {
                None => {
                    self.visit(w);
                    self.low[v] = self.low[v].min(self.low[w]);
                }
                Some(iw) if self.on_stack[w] => self.low[v] = self.low[v].min(iw),
                _ => {}
            }
        }
        if Some(self.low[v]) == self.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = self.stack.pop() {
                self.on_stack[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            self.components.push(comp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(path: &str, text: &str) -> (SourceFile, Vec<String>) {
        let rel = path.trim_start_matches("src/");
        (
            SourceFile {
                path: path.into(),
                text: text.into(),
            },
            module_path(rel),
        )
    }

    #[test]
    fn module_paths() {
        assert!(module_path("lib.rs").is_empty());
        assert_eq!(module_path("a.rs"), ["a"]);
        assert_eq!(module_path("a/mod.rs"), ["a"]);
        assert_eq!(module_path("a/b.rs"), ["a", "b"]);
    }

    #[test]
    fn reexports_are_followed_and_test_code_is_ignored() {
        let files = [
            file(
                "src/lib.rs",
                "mod a; mod b; pub use a::A; pub use b::{B as Bee};",
            ),
            file(
                "src/a.rs",
                "use crate::Bee;\n#[cfg(test)]\nmod tests { use crate::b::X; }",
            ),
            file(
                "src/b.rs",
                "pub struct B; fn f() { let _ = super::c::g(); }",
            ),
            file("src/c.rs", "pub fn g() {}"),
        ];
        let g = graph(&files);
        let named = |i: usize| -> Vec<&str> {
            g.edges
                .get(&i)
                .map(|m| m.keys().map(|&k| g.files[k].as_str()).collect())
                .unwrap_or_default()
        };
        assert_eq!(named(0), Vec::<&str>::new(), "re-exports are not uses");
        assert_eq!(named(1), ["src/b.rs"]);
        assert_eq!(named(2), ["src/c.rs"]);
        assert!(g.circles().is_empty());
    }

    #[test]
    fn a_circle_is_reported_with_its_files_and_lines() {
        let files = [
            file("src/lib.rs", "mod a; mod b; mod c;"),
            file("src/a.rs", "use crate::b::B;"),
            file("src/b.rs", "\nuse super::c::{self, C};"),
            file("src/c.rs", "fn f() { crate::a::g() }"),
        ];
        let circles = graph(&files).circles();
        assert_eq!(circles.len(), 1);
        assert_eq!(circles[0].files, ["src/a.rs", "src/b.rs", "src/c.rs"]);
        assert_eq!(
            circles[0].cycle,
            [
                ("src/a.rs".to_string(), 1),
                ("src/b.rs".to_string(), 2),
                ("src/c.rs".to_string(), 1)
            ]
        );
    }
}
