//! The workspace's habits as tests (rust-analyzer's `tidy`): every source file opens with `//!`, no function
//! is longer than 150 lines outside tests and generated code, library code calls no `.unwrap()`/`.expect(`
//! outside tests unless listed below with the reason it cannot fail, and no crate's files import each other
//! in a circle. The checker lives in `invsim_tests::tidy`; every violation prints as `path:line: what (fix: …)`.
//!
//! The allow-lists below are the only exceptions. An entry that no longer excuses anything fails the test too
//! (remove it): the lists only shrink.

use invsim_tests::tidy::warnings::warning_sites;
use invsim_tests::tidy::{
    apply_allow_list, import_circles, line_contains, long_functions, missing_module_docs,
    same_subject, unwraps, workspace_sources, Allow, SourceFile, Violation, MAX_FUNCTION_LINES,
};
use std::path::Path;

/// Files that may open without `//!` (path, the same path, reason).
const ALLOW_MISSING_DOCS: &[Allow] = &[];

/// Functions longer than [`MAX_FUNCTION_LINES`] (path, function name, reason).
const ALLOW_LONG_FUNCTIONS: &[Allow] = &[];

/// `.unwrap()`/`.expect(` calls in library code (start of the path — a file, or a module's files —, a piece of
/// the source line, the reason the call cannot fail on user data).
const ALLOW_UNWRAPS: &[Allow] = &[
    (
        "crates/expr/src/pool",
        "expression pool exceeded 2^32 nodes",
        "node ids are u32 by design; 2^32 hash-consed nodes would need well over 100 GB before the count overflows",
    ),
    (
        "crates/inversion/src/derive",
        "r ≥ 1 implies one L_g L_f^k h",
        "the relative degree r ≥ 1 was found above by pushing one L_g L_f^k h per step, so the list is not empty",
    ),
];

/// Import circles (crate directory, its files in the circle sorted and separated by spaces, reason).
const ALLOW_CIRCLES: &[Allow] = &[];

fn sources() -> Vec<SourceFile> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let files = workspace_sources(&root).unwrap_or_else(|e| panic!("cannot read the sources: {e}"));
    assert!(files.len() > 30, "found only {} source files", files.len());
    files
}

/// Fail listing every violation the allow-list does not excuse and every entry that excuses nothing.
fn assert_clean(
    check: &str,
    list: &str,
    violations: Vec<Violation>,
    allow: &[Allow],
    matches: fn(&Violation, &Allow) -> bool,
) {
    let (left, stale) = apply_allow_list(violations, allow, matches);
    let mut lines: Vec<String> = left.iter().map(ToString::to_string).collect();
    lines.extend(stale.iter().map(|(path, subject, _)| {
        format!("{path}: {list} entry {subject:?} excuses nothing (fix: remove it from {list})")
    }));
    assert!(lines.is_empty(), "{check}:\n{}", lines.join("\n"));
}

#[test]
fn every_source_file_starts_with_a_module_doc_line() {
    let v = missing_module_docs(&sources());
    assert_clean(
        "files without `//!`",
        "ALLOW_MISSING_DOCS",
        v,
        ALLOW_MISSING_DOCS,
        same_subject,
    );
}

#[test]
fn no_function_is_longer_than_150_lines() {
    let v = long_functions(&sources(), MAX_FUNCTION_LINES);
    assert_clean(
        "long functions",
        "ALLOW_LONG_FUNCTIONS",
        v,
        ALLOW_LONG_FUNCTIONS,
        same_subject,
    );
}

#[test]
fn library_code_does_not_unwrap() {
    let v = unwraps(&sources());
    assert_clean(
        "unwrap/expect in library code",
        "ALLOW_UNWRAPS",
        v,
        ALLOW_UNWRAPS,
        line_contains,
    );
}

#[test]
fn no_import_circles_between_the_files_of_a_crate() {
    let v = import_circles(&sources());
    assert_clean(
        "import circles",
        "ALLOW_CIRCLES",
        v,
        ALLOW_CIRCLES,
        same_subject,
    );
}

// --- the checker itself can fail -----------------------------------------------------------------------------

fn sample(path: &str, text: String) -> SourceFile {
    SourceFile {
        path: path.into(),
        text,
    }
}

/// A small crate with one of each violation, and the same habits kept where they do not apply.
fn bad_crate() -> Vec<SourceFile> {
    let body: String = (0..MAX_FUNCTION_LINES)
        .map(|k| format!("    let _x{k} = {k};\n"))
        .collect();
    vec![
        sample("crates/bad/src/lib.rs", "//! Root.\nmod a;\nmod b;\n".into()),
        sample(
            "crates/bad/src/a.rs",
            format!("//! A.\nuse crate::b::g;\npub fn long() {{\n{body}}}\npub fn f() {{ g() }}\n"),
        ),
        sample(
            "crates/bad/src/b.rs",
            "// no module doc\npub fn g() { let s = \"x.unwrap()\"; super::a::h(Some(1).unwrap()) }\n\
             #[cfg(test)]\nmod tests { fn t() { None::<u8>.unwrap(); } }\n"
                .into(),
        ),
    ]
}

#[test]
fn the_checker_detects_each_kind_of_violation() {
    let files = bad_crate();
    let docs = missing_module_docs(&files);
    assert_eq!(docs.len(), 1, "{docs:?}");
    assert_eq!(
        (docs[0].path.as_str(), docs[0].line),
        ("crates/bad/src/b.rs", 1)
    );

    let long = long_functions(&files, MAX_FUNCTION_LINES);
    assert_eq!(long.len(), 1, "{long:?}");
    assert_eq!((long[0].subject.as_str(), long[0].line), ("long", 3));
    assert!(
        long[0].to_string().contains("fn long is 152 lines long"),
        "{}",
        long[0]
    );

    let unwrap = unwraps(&files);
    assert_eq!(
        unwrap.len(),
        1,
        "the string and the test module are exempt: {unwrap:?}"
    );
    assert_eq!(
        (unwrap[0].path.as_str(), unwrap[0].line),
        ("crates/bad/src/b.rs", 2)
    );

    let circles = import_circles(&files);
    assert_eq!(circles.len(), 1, "{circles:?}");
    assert_eq!(
        circles[0].subject,
        "crates/bad/src/a.rs crates/bad/src/b.rs"
    );
    assert!(
        circles[0].to_string().contains("crates/bad/src/a.rs:2"),
        "{}",
        circles[0]
    );
}

#[test]
fn an_allow_list_excuses_only_what_it_names_and_reports_stale_entries() {
    let files = bad_crate();
    let allow: &[Allow] = &[
        ("crates/bad/src/a.rs", "long", "sample"),
        ("crates/bad/src/a.rs", "gone", "sample"),
    ];
    let (left, stale) = apply_allow_list(long_functions(&files, 10), allow, same_subject);
    assert!(left.is_empty(), "{left:?}");
    assert_eq!(stale, [&allow[1]]);
    let (left, _) = apply_allow_list(long_functions(&files, 10), &allow[1..], same_subject);
    assert_eq!(left.len(), 1);
}

// --- every warning explained in the guide's glossary -----------------------------------------------------------

/// Every warning invsim can print: the file that makes it and the text that identifies it (a piece of its
/// format string), which the guide's glossary quotes. A warning site ([`warning_sites`]) not listed here, or an
/// entry whose file has fewer sites, fails the test: add the warning here and to `docs/guide.md` (section
/// "Warnings").
const WARNINGS: &[(&str, &str)] = &[
    (
        "crates/runtime/src/cycle/plausibility.rs",
        "is beyond any drive cycle",
    ),
    (
        "crates/runtime/src/cycle/plausibility.rs",
        "beyond what a car's tyres allow",
    ),
    (
        "crates/runtime/src/cycle/plausibility.rs",
        "the column probably holds milliseconds",
    ),
    ("crates/runtime/src/inverse/run.rs", "s in total (reached"),
    (
        "crates/runtime/src/inverse/run.rs",
        "the cycle covers no distance",
    ),
    (
        "crates/runtime/src/inverse/run.rs",
        "the internal states' initial values are ignored: stable inversion keeps its boundary",
    ),
    (
        "crates/runtime/src/inverse/run.rs",
        "the frozen linearisation ∂q/∂η has eigenvalues",
    ),
    (
        "crates/runtime/src/inverse/run.rs",
        "stable inversion: the estimated error",
    ),
    (
        "crates/runtime/src/inverse/checks.rs",
        "the smoothed reference y_d covers",
    ),
    (
        "crates/runtime/src/inverse/verify.rs",
        "verification: the open-loop replay strays from y_d",
    ),
    (
        "crates/runtime/src/tolerance_band.rs",
        "the smoothed reference leaves the cycle's tolerance band",
    ),
    (
        "crates/runtime/src/signals.rs",
        "the cycle's road grade is ignored",
    ),
    (
        "crates/runtime/src/initial.rs",
        "ignored: the inversion fixes it",
    ),
    (
        "crates/runtime/src/modes/summary.rs",
        "where a mode's free input leaves its bounds and no mode absorbs it",
    ),
    (
        "crates/runtime/src/modes/summary.rs",
        "that no impulse of the free input realises",
    ),
    (
        "crates/runtime/src/forward/mod.rs",
        "declares no input bounds: there is nothing to enforce",
    ),
    (
        "crates/runtime/src/forward/mod.rs",
        "the driver's demand for",
    ),
    (
        "crates/runtime/src/forward/trace.rs",
        "the vehicle misses the cycle's trace",
    ),
    (
        "crates/runtime/src/forward/modal_summary.rs",
        "the driver's demand leaves the bounds of the mode's free input",
    ),
    (
        "crates/inversion/src/derive/coordinates.rs",
        "has L_g η ≠ 0",
    ),
    (
        "crates/inversion/src/derive/relative_degree.rs",
        "was taken as identically zero by numeric probing",
    ),
    (
        "crates/inversion/src/derive/non_affine.rs",
        "was taken as identically zero by numeric probing",
    ),
    (
        "crates/inversion/src/derive/psi_inv.rs",
        "has no closed form in (ξ, η)",
    ),
    ("crates/inversion/src/derive/mod.rs", "β vanishes: "),
    (
        "crates/inversion/src/derive/mod.rs",
        "(Newton's method for the input fails there)",
    ),
    (
        "crates/import/src/fastsim.rs",
        "fields not modelled (ignored)",
    ),
    ("crates/import/src/bev.rs", "does not start at zero load"),
    (
        "crates/import/src/fuel.rs",
        "is not set: the fuel is reported as energy",
    ),
    (
        "crates/import/src/controls.rs",
        "the engine stops as soon as the car stands",
    ),
    (
        "crates/import/src/thermal.rs",
        "is a thermal model: it is not reproduced",
    ),
    (
        "crates/import/src/battery.rs",
        "the battery efficiency is read at the temperature signal `T_res`",
    ),
    (
        "crates/import/src/hev_rules.rs",
        "the engine kept on while cold is not reproduced",
    ),
    (
        "crates/import/src/hev_rules.rs",
        "FASTSim's controller is the model's rules for `--strategy rule-based`",
    ),
    (
        "crates/import/src/hev_rules.rs",
        "the engine is forced on below T_fc_on at each sample",
    ),
    ("crates/import/src/hev.rs", "the engine starts warm, its"),
];

/// The guide's section "Warnings": from its heading to the next heading of level 2 or 3 (or the end).
fn warnings_glossary() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/guide.md");
    let guide =
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let start = guide
        .find("\n### Warnings\n")
        .unwrap_or_else(|| panic!("docs/guide.md has no section `### Warnings`"));
    let rest = &guide[start + 1..];
    let end = rest[4..]
        .find("\n## ")
        .into_iter()
        .chain(rest[4..].find("\n### "))
        .min()
        .map_or(rest.len(), |e| e + 4);
    rest[..end].to_string()
}

#[test]
fn every_warning_is_explained_in_the_guide() {
    let files = sources();
    let glossary = warnings_glossary();
    let mut problems = Vec::new();
    for (path, text) in WARNINGS {
        let source = files.iter().find(|f| f.path == *path);
        if !source.is_some_and(|f| f.text.contains(text)) {
            problems.push(format!(
                "{path}: no warning text {text:?} (fix: update WARNINGS)"
            ));
        }
        if !glossary.contains(text) {
            problems.push(format!(
                "docs/guide.md, section Warnings: {text:?} (from {path}) is not explained (fix: add it)"
            ));
        }
    }
    let mut sites: std::collections::BTreeMap<&str, Vec<usize>> = Default::default();
    let found = warning_sites(&files);
    for s in &found {
        let path = WARNINGS
            .iter()
            .find(|(p, _)| *p == s.path)
            .map_or(s.path.as_str(), |(p, _)| p);
        sites.entry(path).or_default().push(s.line);
    }
    for (path, lines) in &sites {
        let listed = WARNINGS.iter().filter(|(p, _)| p == path).count();
        if lines.len() != listed {
            problems.push(format!(
                "{path}: {} warning site(s) (lines {lines:?}) but {listed} listed in WARNINGS (fix: list each \
                 warning and explain it in docs/guide.md)",
                lines.len()
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
