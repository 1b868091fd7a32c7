//! Model-file reader: every malformed file in `tests/malformed/` fails where its header says, the shared
//! acceptance models load (or fail) as specified, valid models are split into f + g·u correctly, and no
//! input makes the reader panic.

use invsim_expr::{Id, Pool, Symbol};
use invsim_inversion::{Model, ModelError, ModelErrorKind};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The shared acceptance models, if present.
fn shared_models() -> Option<PathBuf> {
    let dir = manifest_dir().join("../../../shared/models");
    dir.is_dir().then_some(dir)
}

fn load(text: &str) -> Result<Model, ModelError> {
    Model::from_str(Path::new("test.toml"), text)
}

fn load_ok(text: &str) -> Model {
    match load(text) {
        Ok(m) => m,
        Err(e) => panic!("model should load, but: {e}"),
    }
}

/// Evaluate `e` with the model's nominal parameters and the given values of other symbols.
fn eval(m: &Model, e: Id, values: &[(&str, f64)]) -> f64 {
    let mut env: HashMap<Symbol, f64> = m.nominal();
    for (name, v) in values {
        let s = m
            .pool
            .find_symbol(name)
            .unwrap_or_else(|| panic!("no symbol `{name}`"));
        env.insert(s, *v);
    }
    m.pool.eval(e, &env).expect("all symbols bound")
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
}

// ----- malformed files -----------------------------------------------------------------------------------

/// The header `# expect: LINE:COLUMN SUBSTRING` (or `# expect: - SUBSTRING` for an error without a
/// position).
fn expectation(text: &str) -> Option<(Option<(usize, usize)>, String)> {
    let header = text.lines().next()?.strip_prefix("# expect:")?.trim();
    let (pos, substring) = header.split_once(' ')?;
    let pos = if pos == "-" {
        None
    } else {
        let (l, c) = pos.split_once(':')?;
        Some((l.parse().ok()?, c.parse().ok()?))
    };
    Some((pos, substring.trim().to_string()))
}

#[test]
fn malformed_files_fail_where_their_header_says() {
    let dir = manifest_dir().join("tests/malformed");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tests/malformed exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 24, "only {} malformed files", files.len());

    let mut failures = Vec::new();
    for path in &files {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("?")
            .to_string();
        let text = std::fs::read_to_string(path).expect("readable");
        let Some((pos, substring)) = expectation(&text) else {
            failures.push(format!(
                "{name}: no `# expect: LINE:COLUMN SUBSTRING` header"
            ));
            continue;
        };
        let err = match Model::from_path(path) {
            Ok(_) => {
                failures.push(format!(
                    "{name}: loaded, expected an error containing {substring:?}"
                ));
                continue;
            }
            Err(e) => e,
        };
        let got = err.line.zip(err.column);
        if got != pos {
            failures.push(format!("{name}: error at {got:?}, expected {pos:?}: {err}"));
        }
        if !err.message.contains(&substring) {
            failures.push(format!(
                "{name}: message {:?} does not contain {substring:?}",
                err.message
            ));
        }
        // The display form starts with the file and the position.
        let shown = err.to_string();
        let prefix = match pos {
            Some((l, c)) => format!("{}:{l}:{c}: ", path.display()),
            None => format!("{}: ", path.display()),
        };
        if !shown.starts_with(&prefix) {
            failures.push(format!(
                "{name}: displayed as {shown:?}, expected the prefix {prefix:?}"
            ));
        }
        if shown.contains('\n') {
            failures.push(format!("{name}: message spans several lines: {shown:?}"));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} files:\n{}",
        failures.len(),
        files.len(),
        failures.join("\n")
    );
}

#[test]
fn crlf_line_endings_give_the_same_positions() {
    let dir = manifest_dir().join("tests/malformed");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir)
        .expect("tests/malformed exists")
        .filter_map(Result::ok)
    {
        let path = entry.path();
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let Some((pos, substring)) = expectation(&text) else {
            continue;
        };
        let crlf = text.replace('\n', "\r\n");
        let err = Model::from_str(&path, &crlf).expect_err("still malformed");
        assert_eq!(err.line.zip(err.column), pos, "{}: {err}", path.display());
        assert!(
            err.message.contains(&substring),
            "{}: {err}",
            path.display()
        );
        checked += 1;
    }
    assert!(checked >= 24);
}

// ----- the shared acceptance models ----------------------------------------------------------------------

#[test]
fn shared_acceptance_models() {
    let Some(dir) = shared_models() else {
        println!("skipping: ../shared not found");
        return;
    };
    for name in [
        "motor_pendulum",
        "internal_dynamics",
        "singular_decoupling",
        "bad_no_relative_degree",
    ] {
        let path = dir.join(format!("{name}.toml"));
        match Model::from_path(&path) {
            Ok(m) => assert_eq!(m.name, name),
            Err(e) => panic!("{name} should load: {e}"),
        }
    }

    // Non-affine inputs are accepted since contract §5: the state is kept whole, marked not affine.
    let m = Model::from_path(&dir.join("bad_nonaffine.toml")).expect("bad_nonaffine loads");
    assert!(!m.is_affine() && m.states[0].affine && !m.states[1].affine);

    let err = Model::from_path(&dir.join("bad_unknown_symbol.toml"))
        .expect_err("bad_unknown_symbol must fail");
    assert_eq!(err.kind, ModelErrorKind::UnknownName);
    assert!(err.message.contains("`c9`"), "{err}");
    // Line 8 is `x1 = { rhs = "c1*x1 + c9*u" }`: the expression starts in column 15, `c9` is in column 23.
    assert_eq!((err.line, err.column), (Some(8), Some(23)), "{err}");
    assert!(
        err.to_string()
            .contains("bad_unknown_symbol.toml:8:23: unknown name `c9`"),
        "{err}"
    );
}

#[test]
fn motor_pendulum_is_split_into_f_and_g() {
    let Some(dir) = shared_models() else {
        println!("skipping: ../shared not found");
        return;
    };
    let m = Model::from_path(&dir.join("motor_pendulum.toml")).expect("loads");
    assert_eq!(
        m.description.as_deref(),
        Some("Pendulum on a DC motor shaft; voltage in, angle out.")
    );
    let names: Vec<&str> = m.states.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["th", "om", "i_m"]);
    assert_eq!(
        m.state_symbols(),
        m.states.iter().map(|s| s.symbol).collect::<Vec<_>>()
    );
    assert_eq!(m.input.name, "V");
    assert_eq!((m.input.min, m.input.max), (Some(-24.0), Some(24.0)));
    assert_eq!(m.input.unit.as_deref(), Some("V"));
    assert_eq!(m.parameters.len(), 8);
    assert_eq!(m.parameters[0].name, "m");
    assert_eq!(m.parameters[0].unit.as_deref(), Some("kg"));
    assert_eq!(m.parameters[0].doc.as_deref(), Some("bob mass"));
    assert_eq!(m.nominal().len(), 8);
    assert_eq!(m.output.name, "th");
    assert_eq!(m.output.source, "th");
    assert_eq!(m.outputs.len(), 1);
    assert!(m.outputs[0].accumulate);
    assert_eq!(m.outputs[0].unit.as_deref(), Some("W"));
    assert_eq!(m.source_hash.len(), 64);
    assert!(m
        .source_hash
        .bytes()
        .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase()));

    let (r, k, l) = (1.2, 0.1, 0.01);
    let i_m = &m.states[2];
    for (om, cur, v) in [(0.3, -1.5, 4.0), (-2.0, 0.7, -12.0), (10.0, 3.0, 0.0)] {
        let at = [("th", 0.4), ("om", om), ("i_m", cur), ("V", v)];
        // f = (-R i_m - K om)/L, g = 1/L.
        assert!(close(eval(&m, i_m.f, &at), (-r * cur - k * om) / l));
        assert!(close(eval(&m, i_m.g, &at), 1.0 / l));
        assert!(close(eval(&m, i_m.rhs, &at), (v - r * cur - k * om) / l));
    }
    // Canonical forms: g = 1/L and f = (-R*i_m - K*om)/L exactly.
    let mut pool: Pool = m.pool.clone();
    let g = pool.parse("1/L").expect("parses");
    assert_eq!(i_m.g, g, "g = {}", pool.display(i_m.g));
    let f = pool.parse("(-R*i_m - K*om)/L").expect("parses");
    let diff = pool.sub(i_m.f, f);
    assert!(
        invsim_expr::zero_test(&mut pool, diff, &m.nominal()).is_zero(),
        "f = {}",
        pool.display(i_m.f)
    );

    // The definition tau_g is inlined into om's equation, which does not depend on the input.
    let om = &m.states[1];
    assert!(m.pool.is_zero(om.g));
    let tau = m.pool.find_symbol("tau_g").expect("symbol");
    assert!(!m.pool.depends_on(om.f, tau));
    let at = [("th", 0.4), ("om", 0.3), ("i_m", 2.0)];
    let expected = (0.1 * 2.0 - 0.5 * 9.81 * 0.3 * 0.4_f64.sin() - 0.02 * 0.3) / 0.05;
    assert!(close(eval(&m, om.f, &at), expected));
    assert_eq!(m.definitions[0].name, "tau_g");
    assert_eq!(m.definitions[0].source, "m*g0*l*sin(th)");
}

// ----- valid models --------------------------------------------------------------------------------------

const VEHICLE: &str = r#"
description = "a car in one gear"

[parameters]
m = { value = 1300, unit = "kg", doc = "vehicle mass" }
c_d = 0.32
A = 2.0
rho = { value = 1.2 }
k_t = 150.0

[definitions]
F_drag = "0.5*rho*c_d*A*v^2"
F_w = { expr = "k_t*p", unit = "N", doc = "traction force" }
F_net = "F_w - F_drag"
P_w = "F_w*v"
limited = "min(max(P_w, 0), 1e5)"

[states.v]
rhs = "F_net/m"
unit = "m/s"
doc = "speed"

[states.p]
f = "-p"
g = "2"

[input]
name = "q"
doc = "throttle"

[output]
name = "speed"
h = "v"
unit = "m/s"

[outputs]
power = { expr = "P_w", unit = "W", accumulate = true }
clipped = "limited + abs(q)"
"#;

#[test]
fn definitions_are_inlined_in_order() {
    let m = Model::from_str(Path::new("cars/vehicle.toml"), VEHICLE).expect("loads");
    assert_eq!(m.name, "vehicle", "the name defaults to the file stem");
    assert_eq!(m.file, Path::new("cars/vehicle.toml"));
    let names: Vec<&str> = m.definitions.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["F_drag", "F_w", "F_net", "P_w", "limited"]);
    let f_w = &m.definitions[1];
    assert_eq!(
        (f_w.unit.as_deref(), f_w.doc.as_deref()),
        (Some("N"), Some("traction force"))
    );
    assert_eq!(f_w.source, "k_t*p");

    // As written, F_net refers to F_w and F_drag; inlined, it refers to neither.
    let net = &m.definitions[2];
    let (fw, fd) = (m.definitions[1].symbol, m.definitions[0].symbol);
    assert!(m.pool.depends_on(net.expr, fw) && m.pool.depends_on(net.expr, fd));
    assert!(!m.pool.depends_on(net.inlined, fw) && !m.pool.depends_on(net.inlined, fd));
    let at = [("v", 20.0), ("p", 3.0)];
    let expected = 150.0 * 3.0 - 0.5 * 1.2 * 0.32 * 2.0 * 400.0;
    assert!(close(eval(&m, net.inlined, &at), expected));

    // States in file order ([states.v] before [states.p]); v has no input term, p's f and g as given.
    let names: Vec<&str> = m.states.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["v", "p"]);
    assert!(close(eval(&m, m.states[0].f, &at), expected / 1300.0));
    assert!(m.pool.is_zero(m.states[0].g));
    assert!(close(
        eval(&m, m.states[1].rhs, &[("p", 3.0), ("q", 0.5)]),
        -3.0 + 2.0 * 0.5
    ));
    assert_eq!(m.states[0].unit.as_deref(), Some("m/s"));
    assert_eq!(m.states[0].doc.as_deref(), Some("speed"));

    // Parameters: plain numbers and tables, integers too.
    let values: Vec<(&str, f64)> = m
        .parameters
        .iter()
        .map(|p| (p.name.as_str(), p.value))
        .collect();
    assert_eq!(
        values,
        [
            ("m", 1300.0),
            ("c_d", 0.32),
            ("A", 2.0),
            ("rho", 1.2),
            ("k_t", 150.0)
        ]
    );
    assert_eq!(m.nominal()[&m.parameters[0].symbol], 1300.0);

    // [outputs] may use the input and the non-smooth functions, also through definitions.
    assert_eq!(m.outputs.len(), 2);
    assert!(m.outputs[0].accumulate && !m.outputs[1].accumulate);
    let q = m.input.symbol;
    assert!(m.pool.depends_on(m.outputs[1].expr, q));
    assert!(close(
        eval(
            &m,
            m.outputs[1].expr,
            &[("v", 20.0), ("p", 3.0), ("q", -0.5)]
        ),
        9000.0 + 0.5
    ));
    assert_eq!(m.outputs[1].source, "limited + abs(q)");
    assert_eq!(m.output.name, "speed");
    assert_eq!(m.input.doc.as_deref(), Some("throttle"));
    assert_eq!((m.input.min, m.input.max), (None, None));
}

#[test]
fn the_source_hash_is_the_sha256_of_the_bytes() {
    use sha2::{Digest, Sha256};
    let m = load_ok(VEHICLE);
    let expected: String = Sha256::digest(VEHICLE.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(m.source_hash, expected);
}

#[test]
fn affinity_is_decided_semantically() {
    // u*(sin²+cos²) is affine, and u - u cancels in h.
    let m = load_ok(
        r#"
[states]
x1 = { rhs = "-x1 + u*(sin(x1)^2 + cos(x1)^2)" }
x2 = { rhs = "x1 + (x2 + u)^2 - u^2 - 2*x2*u" }
[input]
name = "u"
[output]
name = "y"
h = "x1 + u - u"
"#,
    );
    let at = [("x1", 0.7), ("x2", -0.2), ("u", 3.0)];
    assert!(close(eval(&m, m.states[0].g, &at), 1.0));
    assert!(!m.pool.depends_on(m.states[0].g, m.input.symbol));
    assert!(close(eval(&m, m.states[1].f, &at), 0.7 + 0.04));
    assert!(close(eval(&m, m.states[1].g, &at), 0.0));
    assert!(!m.pool.depends_on(m.output.h, m.input.symbol));

    // u^2 in a definition that enters the right-hand side makes the state non-affine (contract §5).
    let m = load_ok(
        r#"
[definitions]
sq = "u^2"
[states]
x1 = { rhs = "-x1 + sq" }
[input]
name = "u"
[output]
name = "y"
h = "x1"
"#,
    );
    assert!(!m.states[0].affine);
}

#[test]
fn non_smooth_definitions_are_fine_when_only_outputs_use_them() {
    let m = load_ok(
        r#"
[definitions]
mag = "abs(x1)"
[states]
x1 = { rhs = "-x1 + u" }
[input]
name = "u"
[output]
name = "y"
h = "x1"
[outputs]
magnitude = { expr = "mag" }
"#,
    );
    assert_eq!(m.outputs[0].name, "magnitude");

    // ... but not when the definition reaches h through another definition.
    let err = load(
        r#"
[definitions]
mag = "abs(x1)"
y2 = "mag + x1"
[states]
x1 = { rhs = "-x1 + u" }
[input]
name = "u"
[output]
name = "y"
h = "y2"
"#,
    )
    .expect_err("abs reaches h");
    assert_eq!(err.kind, ModelErrorKind::NonSmooth);
    assert_eq!((err.line, err.column), (Some(3), Some(8)));
    assert!(err.message.contains("used by the output's h"), "{err}");
}

#[test]
fn names_and_values_in_the_model() {
    let m = load_ok(
        r#"
name = "tiny"
[parameters]
xi = 1
eta = -2.5e-3
tau = { value = 7, doc = "time constant" }
[states]
x = { f = "-x/tau + xi*eta", g = "pi" }
[input]
name = "u"
min = -1
max = 1
[output]
name = "y"
h = "x"
"#,
    );
    assert_eq!(m.name, "tiny");
    assert_eq!(m.parameters[1].value, -2.5e-3);
    assert_eq!(m.parameters[2].value, 7.0);
    assert_eq!(m.parameters[2].doc.as_deref(), Some("time constant"));
    assert!(close(eval(&m, m.states[0].g, &[]), std::f64::consts::PI));
    assert_eq!((m.input.min, m.input.max), (Some(-1.0), Some(1.0)));
}

// ----- errors without a malformed file -------------------------------------------------------------------

#[test]
fn io_and_encoding_errors() {
    let err = Model::from_path(Path::new("/nonexistent/model.toml")).expect_err("no such file");
    assert_eq!(err.kind, ModelErrorKind::Io);
    assert_eq!((err.line, err.column), (None, None));
    assert!(
        err.to_string()
            .starts_with("/nonexistent/model.toml: cannot read the model file"),
        "{err}"
    );

    let bytes = b"[states]\nx1 = { rhs = \"-x1 \xff u\" }\n";
    let err = Model::from_bytes(Path::new("bin.toml"), bytes).expect_err("not UTF-8");
    assert_eq!(err.kind, ModelErrorKind::Io);
    assert_eq!((err.line, err.column), (Some(2), Some(19)));
    assert!(err.message.contains("UTF-8"));
}

#[test]
fn overlong_and_deeply_nested_input_is_an_error_not_a_crash() {
    let long = vec!["x1"; 3000].join(" + ");
    let text = format!("[states]\nx1 = {{ rhs = \"{long}\" }}\n[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x1\"\n");
    let err = load(&text).expect_err("too long");
    assert_eq!(err.kind, ModelErrorKind::Expression);
    assert!(err.message.contains("too long"), "{err}");

    let pow = vec!["x1"; 200].join("^");
    let text = format!("[states]\nx1 = {{ rhs = \"{pow}\" }}\n[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x1\"\n");
    let err = load(&text).expect_err("too deep");
    assert!(err.message.contains("nested too deeply"), "{err}");

    let arrays = format!("a = {}", "[".repeat(100_000));
    let err = load(&arrays).expect_err("TOML nesting");
    assert_eq!(err.kind, ModelErrorKind::Toml);
}

#[test]
fn a_byte_order_mark_does_not_count_as_a_column() {
    let text = "\u{feff}wrong = 1\n";
    let err = load(text).expect_err("unknown key");
    assert_eq!((err.line, err.column), (Some(1), Some(1)), "{err}");
}

// ----- robustness ----------------------------------------------------------------------------------------

const FUZZ_SEED: &str = r#"# seed
name = "fuzz"
[parameters]
m = { value = 0.5, unit = "kg", doc = "bob mass" }
k = 2.0
[definitions]
tau = "m*9.81*sin(th)"
drag = { expr = "k*om^2", unit = "N m" }
[states]
th = { rhs = "om", unit = "rad" }
om = { rhs = "(u - tau - drag)/m" }
w = { f = "-k*w + th", g = "1/(1 + th^2)" }
[states.z]
rhs = "exp(-z) + log(1 + om^2) - pi"
[input]
name = "u"
min = -1.0
max = 1.0
[output]
name = "y"
h = "th + w"
[outputs]
p = { expr = "u*om + max(abs(u), 0)", accumulate = true }
"#;

/// SplitMix64: a tiny deterministic generator, so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const TOKENS: &[&str] = &[
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    "\"",
    "'",
    "=",
    ",",
    "^",
    "*",
    "-",
    "+",
    "/",
    "\n",
    "nan",
    "inf",
    "-inf",
    "1e999",
    "abs(",
    "max(x,",
    "u",
    "tau",
    "xi1",
    "t",
    "pi",
    "\\",
    "\"\"\"",
    "[states]",
    "[input]",
    "rhs",
    "f = \"u\"",
    "g",
    "0",
    "1e-3",
    ".",
    "é",
    "\u{feff}",
    "#",
    "true",
    "[[a]]",
    "x.y",
    " ",
    "\t",
    "\r\n",
];

fn mutate(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(bytes.len() + 1);
        match rng.below(5) {
            0 => {
                if at < bytes.len() {
                    bytes[at] = rng.next() as u8;
                }
            }
            1 | 2 => {
                let token = TOKENS[rng.below(TOKENS.len())].as_bytes();
                bytes.splice(at..at, token.iter().copied());
            }
            3 => {
                let end = (at + 1 + rng.below(12)).min(bytes.len());
                if at < end {
                    bytes.drain(at..end);
                }
            }
            _ => {
                // Copy a random chunk elsewhere.
                let from = rng.below(bytes.len());
                let end = (from + 1 + rng.below(40)).min(bytes.len());
                let chunk: Vec<u8> = bytes[from..end].to_vec();
                bytes.splice(at..at, chunk);
            }
        }
    }
    bytes
}

#[test]
fn random_mutations_never_panic() {
    load_ok(FUZZ_SEED);
    let mut rng = Rng(std::env::var("INVSIM_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x5EED));
    let (mut loaded, mut rejected) = (0, 0);
    let mut kinds: HashMap<ModelErrorKind, usize> = HashMap::new();
    // INVSIM_FUZZ_CASES raises the number of cases for a longer run.
    let cases: u64 = std::env::var("INVSIM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4000);
    for case in 0..cases {
        let bytes = mutate(&mut rng, FUZZ_SEED.as_bytes());
        let result = std::panic::catch_unwind(|| Model::from_bytes(Path::new("fuzz.toml"), &bytes));
        match result {
            Ok(Ok(_)) => loaded += 1,
            Ok(Err(e)) => {
                rejected += 1;
                *kinds.entry(e.kind).or_default() += 1;
                assert!(
                    !matches!(e.line, Some(0)) && !matches!(e.column, Some(0)),
                    "case {case}: {e}"
                );
                assert!(!e.message.is_empty());
            }
            Err(_) => panic!(
                "case {case} panicked on:\n{}",
                String::from_utf8_lossy(&bytes)
            ),
        }
    }
    println!("loaded {loaded}, rejected {rejected}: {kinds:?}");
    assert!(
        loaded > 0 && rejected > 0,
        "loaded {loaded}, rejected {rejected}"
    );
}

/// A random expression over the names of [`random_model`]. Non-smooth functions appear in one expression
/// of 20, `d` (the definition) only where `with_d`.
fn random_expression(rng: &mut Rng, depth: usize, with_d: bool) -> String {
    const LEAVES: &[&str] = &[
        "x1", "x2", "u", "k", "pi", "0", "1", "2", "0.5", "1e3", "-1", "d",
    ];
    const UNARY: &[&str] = &[
        "sin", "cos", "exp", "log", "sqrt", "tanh", "atan", "-", "abs", "sign",
    ];
    const BINARY: &[&str] = &["+", "-", "*", "/", "^", "pow", "min", "max"];
    let rare = |rng: &mut Rng, n: usize, k: usize| if rng.below(20) == 0 { n } else { n - k };
    if depth == 0 || rng.below(4) == 0 {
        let n = LEAVES.len() - usize::from(!with_d);
        return LEAVES[rng.below(n)].to_string();
    }
    match rng.below(3) {
        0 => {
            let n = rare(rng, UNARY.len(), 2);
            let f = UNARY[rng.below(n)];
            let a = random_expression(rng, depth - 1, with_d);
            if f == "-" {
                format!("-{a}")
            } else {
                format!("{f}({a})")
            }
        }
        _ => {
            let n = rare(rng, BINARY.len(), 2);
            let op = BINARY[rng.below(n)];
            let a = random_expression(rng, depth - 1, with_d);
            let b = random_expression(rng, depth - 1, with_d);
            if op.len() > 1 {
                format!("{op}({a}, {b})")
            } else {
                format!("({a}) {op} ({b})")
            }
        }
    }
}

/// A model whose expressions are random (token soup in one expression of 20).
fn random_model(rng: &mut Rng) -> String {
    let e = |rng: &mut Rng, with_d: bool| {
        if rng.below(20) == 0 {
            const SOUP: &[&str] = &[
                "x1", "u", "(", ")", "+", "*", "^", ",", "sin(", "2", "-", " ",
            ];
            (0..1 + rng.below(8))
                .map(|_| SOUP[rng.below(SOUP.len())])
                .collect::<String>()
        } else {
            random_expression(rng, 4, with_d)
        }
    };
    let d = e(rng, false);
    let (r1, r2, h, o) = (e(rng, true), e(rng, true), e(rng, true), e(rng, true));
    let x2 = if rng.below(2) == 0 {
        format!("rhs = \"{r2}\"")
    } else {
        format!("f = \"{r2}\", g = \"{}\"", e(rng, true))
    };
    format!(
        "[parameters]\nk = 2.0\n[definitions]\nd = \"{d}\"\n[states]\nx1 = {{ rhs = \"{r1}\" }}\n\
         x2 = {{ {x2} }}\n[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"{h}\"\n\
         [outputs]\no = \"{o}\"\n"
    )
}

#[test]
fn random_expressions_never_panic() {
    let mut rng = Rng(std::env::var("INVSIM_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(7));
    let cases: u64 = std::env::var("INVSIM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1500);
    let mut kinds: HashMap<Option<ModelErrorKind>, usize> = HashMap::new();
    for case in 0..cases {
        let text = random_model(&mut rng);
        match std::panic::catch_unwind(|| load(&text)) {
            Ok(r) => *kinds.entry(r.err().map(|e| e.kind)).or_default() += 1,
            Err(_) => panic!("case {case} panicked on:\n{text}"),
        }
    }
    println!("outcomes: {kinds:?}");
    assert!(
        kinds.contains_key(&None),
        "no random model loaded: {kinds:?}"
    );
}

// ----- per-distance outputs and the engine ---------------------------------------------------------------

const PER_DISTANCE_BASE: &str = r#"
[states]
v = { rhs = "-v + u", unit = "m/s" }
[input]
name = "u"
unit = "N"
[output]
name = "v"
h = "v"
unit = "m/s"
"#;

#[test]
fn per_distance_defaults_to_accumulated_outputs_of_a_speed_tracking_model() {
    let m = load_ok(&format!(
        "{PER_DISTANCE_BASE}[outputs]\nfuel = {{ expr = \"u\", accumulate = true }}\n\
         work = {{ expr = \"u*v\", accumulate = true, per_distance = false }}\nw = \"v\"\n\
         [engine]\nspeed = \"w\"\ntorque = \"fuel\"\n"
    ));
    let flags: Vec<(bool, bool)> = m
        .outputs
        .iter()
        .map(|o| (o.accumulate, o.per_distance))
        .collect();
    assert_eq!(flags, [(true, true), (true, false), (false, false)]);
    let e = m.engine.expect("an [engine]");
    assert_eq!((e.speed, e.torque), (2, 0));
    // A model whose reference is not the cycle's speed: no per-distance default, unless asked for.
    let m = load_ok(&format!(
        "{PER_DISTANCE_BASE}reference_scale = 1000.0\n[outputs]\nfuel = {{ expr = \"u\", accumulate = true }}\n\
         e = {{ expr = \"u\", accumulate = true, per_distance = true }}\n"
    ));
    let flags: Vec<bool> = m.outputs.iter().map(|o| o.per_distance).collect();
    assert_eq!(flags, [false, true]);
    assert!(m.engine.is_none());
}

#[test]
fn shipped_models_mark_per_distance_outputs_and_si_engine_its_engine() {
    let models = manifest_dir().join("../../models");
    let si = Model::from_path(&models.join("si_engine.toml")).expect("si_engine loads");
    for o in &si.outputs {
        assert_eq!(o.per_distance, o.accumulate, "si_engine {}", o.name);
    }
    let e = si.engine.expect("si_engine declares its engine");
    assert_eq!(si.outputs[e.speed].name, "n_e");
    assert_eq!(si.outputs[e.torque].name, "T_e");
    let diesel = Model::from_path(&models.join("diesel_gasflow.toml")).expect("diesel loads");
    assert!(diesel.outputs.iter().all(|o| !o.per_distance));
}

/// `[headline]`: the output's unit says what it measures (litres, kg, kWh, with the factor from its integral's
/// unit); petrol and diesel have default properties, another fuel gives its own, `density` may name a
/// parameter; the shipped models mark theirs.
#[test]
fn headline_reads_the_carrier_from_the_unit_and_the_fuel_from_its_name() {
    use invsim_model_api::{Carrier, Density, FuelFlow};
    let with = |unit: &str, headline: &str| {
        load_ok(&format!(
            "{PER_DISTANCE_BASE}[parameters]\nrho = 790.0\n[outputs]\n\
             q = {{ expr = \"u\", unit = \"{unit}\", accumulate = true }}\n[headline]\noutput = \"q\"\n{headline}"
        ))
        .headline
        .expect("a headline")
    };
    let h = with("g/s", "fuel = \"diesel\"\n");
    let Carrier::Fuel(f) = &h.carrier else {
        panic!("a fuel: {h:?}")
    };
    assert_eq!(h.output, 0);
    assert_eq!(f.flow, FuelFlow::Kilograms(1e-3));
    assert_eq!(
        (f.density, f.carbon_fraction),
        (Density::Value(835.0), 0.866)
    );
    let h = with(
        "ml/s",
        "fuel = \"E85\"\ndensity = \"rho\"\ncarbon_fraction = 0.57\n",
    );
    let Carrier::Fuel(f) = &h.carrier else {
        panic!("a fuel: {h:?}")
    };
    assert_eq!(f.name, "E85");
    assert_eq!(f.flow, FuelFlow::Litres(1e-3));
    assert_eq!(
        (f.density, f.carbon_fraction),
        (Density::Parameter(0), 0.57)
    );
    assert_eq!(
        with("W", "").carrier,
        Carrier::Electricity {
            kwh_per_unit: 1.0 / 3.6e6
        }
    );
    assert_eq!(
        with("kWh/s", "").carrier,
        Carrier::Electricity { kwh_per_unit: 1.0 }
    );

    let models = manifest_dir().join("../../models");
    for (file, output) in [
        ("si_engine.toml", "fuel_volume"),
        ("ford_fusion_2012_dynamic.toml", "fuel_volume"),
        ("bev.toml", "energy"),
        ("vehicles/ford_fusion_2012.toml", "fuel"),
        ("vehicles/nissan_leaf_2016.toml", "battery_energy"),
    ] {
        let m = Model::from_path(&models.join(file)).expect("a shipped model loads");
        let h = m.headline.expect("a shipped model marks its headline");
        assert_eq!(m.outputs[h.output].name, output, "{file}");
    }
    let diesel = Model::from_path(&models.join("diesel_gasflow.toml")).expect("diesel loads");
    assert!(diesel.headline.is_none(), "it tracks a boost pressure");
}
