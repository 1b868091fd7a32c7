//! Size budgets on model files: chains of definitions too deep once inlined are a located model error
//! naming the definition and the limit (not a stack overflow), on a small stack; definitions that reuse
//! their predecessor (written-out size ×3 per line) derive and compile to an interpreter in work linear in
//! the lines, and `derive`'s printing refuses them with a message naming the quantity.

use invsim_expr::limits::{MAX_DEPTH, MAX_PRINT_SIZE};
use invsim_inversion::{Derivation, Interpreter, Model, ModelErrorKind};
use std::path::Path;

/// A one-state model whose right-hand side uses the last of `n` chained definitions `d_i = step(d_{i-1})`.
fn chain_model(step: &str, n: usize) -> String {
    let mut s = String::from(
        "name = \"chain\"\n[parameters]\nk = { value = 1.0 }\n[definitions]\nd0 = { expr = \"x/10\" }\n",
    );
    for i in 1..=n {
        let e = step.replace("{p}", &format!("d{}", i - 1));
        s.push_str(&format!("d{i} = {{ expr = \"{e}\" }}\n"));
    }
    s.push_str(&format!(
        "[states]\nx = {{ rhs = \"-k*x + d{n}/100 + u\" }}\n[input]\nname = \"u\"\n\
         [output]\nname = \"y\"\nh = \"x\"\n"
    ));
    s
}

/// Run `f` on a thread with a 256 KiB stack.
fn small_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(f)
        .expect("spawn")
        .join()
        .expect("no stack overflow on a 256 KiB stack");
}

const CHAINS: [&str; 5] = [
    "sin({p})",
    "exp({p}/10)",
    "{p}*x/2 + 1/10",
    "({p}/2 + 1)^2",
    "tanh({p}) - {p}^3/7",
];

#[test]
fn deep_chains_of_definitions_are_a_located_error() {
    // Every form 20 000 deep, and one 100 000 deep (a 3 MB file: the depth, not the size, is what fails).
    let cases = CHAINS
        .iter()
        .map(|&step| (step, 20_000))
        .chain([(CHAINS[0], 100_000)]);
    for (step, n) in cases {
        let text = chain_model(step, n);
        small_stack(move || {
            let err = Model::from_str(Path::new("chain.toml"), &text).expect_err("too deep");
            assert_eq!(err.kind, ModelErrorKind::Expression, "{err}");
            let msg = err.to_string();
            assert!(msg.contains(&format!("(limit {MAX_DEPTH})")), "{msg}");
            assert!(msg.contains("definition `d"), "{msg}");
            assert!(err.line.is_some(), "{msg}");
        });
    }
}

#[test]
fn chains_within_the_depth_limit_derive_and_interpret() {
    for step in CHAINS {
        let text = chain_model(step, 300);
        std::thread::Builder::new()
            .stack_size(8 << 20)
            .spawn(move || {
                let m = Model::from_str(Path::new("chain.toml"), &text).expect("loads");
                let d = Derivation::new(m).expect("derives");
                Interpreter::new(&d).expect("compiles");
                let j = d.to_json();
                assert_eq!(j["relative_degree"], 1);
            })
            .expect("spawn")
            .join()
            .expect("no overflow");
    }
}

/// Growth by reuse: `d_i = sin(d_{i-1}) + cos(d_{i-1})*d_{i-1}` triples the written-out size per line.
#[test]
fn growth_by_reuse_is_linear_work_and_refused_by_derive_printing() {
    for (step, n) in [
        ("sin({p}) + cos({p})*{p}", 40),
        ("{p}*{p} + {p}/3", 60),
        ("exp({p}/9) + {p} - {p}^2/5", 50),
    ] {
        let text = chain_model(step, n);
        let m = Model::from_str(Path::new("grow.toml"), &text).expect("loads");
        let d = Derivation::new(m).expect("derives");
        // Work bounded by distinct nodes, not by the written-out size.
        assert!(d.pool().len() < 200 * n, "{step}: {} nodes", d.pool().len());
        Interpreter::new(&d).expect("compiles");
        let err = d.check_printable().expect_err("too large to print");
        let msg = err.to_string();
        assert!(msg.contains(&format!("limit {MAX_PRINT_SIZE}")), "{msg}");
        assert!(msg.contains("definition `d"), "{msg}");
        assert!(msg.starts_with("grow.toml: f_x"), "{msg}");
    }
}

/// Growth by differentiation: a fourth-order chain, each Lie derivative differentiating the previous one.
#[test]
fn growth_by_differentiation_is_printed_when_small() {
    let text = "name = \"lie\"\n[states]\nx1 = { rhs = \"x2\" }\nx2 = { rhs = \"x3\" }\n\
                x3 = { rhs = \"x4\" }\nx4 = { rhs = \"-sin(x1)*cos(x2)*x3*x4 + u\" }\n\
                [input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x1\"\n";
    let m = Model::from_str(Path::new("lie.toml"), text).expect("loads");
    let d = Derivation::new(m).expect("derives");
    d.check_printable().expect("small enough to print");
    assert_eq!(d.relative_degree, 4);
}
