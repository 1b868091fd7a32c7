//! Depth and size of user-controlled structure: every walk over the DAG (differentiation, substitution,
//! tidy, expansion, zero test, lowering to a tape, evaluation, printing) must survive chains of 20 000 and
//! 100 000 nested operations on a small stack (256 KiB, where a recursive walk overflows after a few
//! hundred levels), and printing must refuse, in O(1), what it cannot print.

use invsim_expr::limits::{MAX_PRINT_DEPTH, MAX_PRINT_SIZE};
use invsim_expr::{zero_test, Func, Id, Measure, Pool, Symbol, Tape};
use std::collections::HashMap;

/// Run `f` on a thread with a 256 KiB stack (a recursive walk over a deep chain overflows there).
fn small_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(f)
        .expect("spawn")
        .join()
        .expect("the walk must not overflow a 256 KiB stack");
}

/// The chains of the budget tests, each one level built on the previous one, over the symbol `x`.
#[derive(Clone, Copy, Debug)]
enum Chain {
    /// d_i = sin(d_{i-1})
    Sin,
    /// d_i = exp(d_{i-1}/10)
    Exp,
    /// d_i = d_{i-1}·x/2 + 1/10 (Horner: sums and products alternate, no calls)
    Horner,
    /// d_i = (d_{i-1}/2)^2 + 1/10
    Square,
}

fn chain(pool: &mut Pool, kind: Chain, n: usize) -> (Id, Symbol) {
    let xs = pool.symbol("x");
    let x = pool.var(xs);
    let (half, tenth) = (pool.rational(1, 2), pool.rational(1, 10));
    let mut d = x;
    for _ in 0..n {
        d = match kind {
            Chain::Sin => pool.call(Func::Sin, d),
            Chain::Exp => {
                let a = pool.mul(&[tenth, d]);
                pool.call(Func::Exp, a)
            }
            Chain::Horner => {
                let p = pool.mul(&[half, x, d]);
                pool.add(&[p, tenth])
            }
            Chain::Square => {
                let h = pool.mul(&[half, d]);
                let s = pool.powi(h, 2);
                pool.add(&[s, tenth])
            }
        };
    }
    (d, xs)
}

/// The same value by a plain loop in f64.
fn chain_value(kind: Chain, n: usize, x: f64) -> f64 {
    let mut d = x;
    for _ in 0..n {
        d = match kind {
            Chain::Sin => d.sin(),
            Chain::Exp => (d / 10.0).exp(),
            Chain::Horner => d * x / 2.0 + 0.1,
            Chain::Square => (d / 2.0).powi(2) + 0.1,
        };
    }
    d
}

fn every_walk(kind: Chain, n: usize) {
    let mut pool = Pool::new();
    let (e, x) = chain(&mut pool, kind, n);
    assert!(
        pool.depth(e) as usize > n,
        "{kind:?}: depth {}",
        pool.depth(e)
    );
    let x0 = 0.3;
    // Evaluation: the reference evaluator and the tape agree with the loop.
    let want = chain_value(kind, n, x0);
    let got = pool.eval(e, &HashMap::from([(x, x0)])).expect("bound");
    assert!(
        (got - want).abs() <= 1e-9 * want.abs().max(1.0),
        "{kind:?}: {got} vs {want}"
    );
    let tape = Tape::compile(&pool, &[e], &[x]).expect("compiles");
    let mut out = [0.0];
    tape.eval(&[x0], &mut out);
    assert!(
        (out[0] - want).abs() <= 1e-9 * want.abs().max(1.0),
        "{kind:?}: tape {}",
        out[0]
    );
    // Differentiation: the derivative of an n-deep chain is a product of n factors at every level (O(n²)
    // nodes in canonical form), so it is taken on a shorter chain, still far deeper than a recursion on
    // this stack allows.
    let (short, _) = chain(&mut pool, kind, 600);
    let de = pool.diff(short, x);
    // (The Exp chain's coefficient 10^-600 underflows to 0 in f64: only the Sin chain is checked here.)
    assert!(
        pool.depends_on(de, x) || !matches!(kind, Chain::Sin),
        "{kind:?}"
    );
    // Substitution, tidy, expansion (bounded by its term limit) and the zero test.
    let y = pool.symbol("y");
    let yv = pool.var(y);
    let s = pool.substitute(e, &HashMap::from([(x, yv)]));
    assert!(!pool.depends_on(s, x) && pool.depends_on(s, y));
    let t = pool.tidy(e);
    let tv = pool.eval(t, &HashMap::from([(x, x0)])).expect("bound");
    assert!(
        (tv - want).abs() <= 1e-9 * want.abs().max(1.0),
        "{kind:?}: tidy {tv}"
    );
    if matches!(kind, Chain::Sin | Chain::Exp) {
        // (A polynomial chain expands to n terms per level: O(n²) terms, not a depth question.)
        let _ = pool.expand(e);
    }
    let z = pool.sub(e, e);
    assert!(zero_test(&mut pool, z, &HashMap::new()).is_zero());
    // Printing refuses in O(1): too deep.
    let err = pool.try_display(e).expect_err("too deep to print");
    assert_eq!(err.measure, Measure::Depth);
    assert_eq!(err.limit, u64::from(MAX_PRINT_DEPTH));
    assert!(pool
        .display(e)
        .starts_with("<expression too large to print"));
    assert!(pool.latex(e).starts_with("<expression too large to print"));
}

#[test]
fn chains_of_20000_survive_every_walk_on_a_small_stack() {
    for kind in [Chain::Sin, Chain::Exp, Chain::Horner, Chain::Square] {
        small_stack(move || every_walk(kind, 20_000));
    }
}

#[test]
fn chains_of_100000_survive_every_walk_on_a_small_stack() {
    for kind in [Chain::Sin, Chain::Exp] {
        small_stack(move || every_walk(kind, 100_000));
    }
}

/// d_i = sin(d_{i-1}) + cos(d_{i-1})·d_{i-1}: three uses per level, so the DAG grows by a few nodes per level
/// while the written-out size triples. The DAG-based walks stay linear in the levels; printing refuses.
#[test]
fn growth_by_reuse_is_linear_in_the_dag_and_refused_by_the_printer() {
    let mut pool = Pool::new();
    let xs = pool.symbol("x");
    let mut d = pool.var(xs);
    for _ in 0..60 {
        let s = pool.call(Func::Sin, d);
        let c = pool.call(Func::Cos, d);
        let cd = pool.mul(&[c, d]);
        d = pool.add(&[s, cd]);
    }
    let before = pool.len();
    let dd = pool.diff(d, xs);
    let t = pool.tidy(dd);
    // Work bounded by DAG nodes: differentiation adds a few nodes per level, not 3^60.
    assert!(
        pool.len() - before < 60 * 40,
        "{} new nodes",
        pool.len() - before
    );
    assert!(pool.dag_size(&[t]) < 60 * 40);
    assert_eq!(pool.written_size(d), u64::MAX, "3^60 saturates");
    let err = pool.try_display(d).expect_err("too large");
    assert_eq!((err.measure, err.limit), (Measure::Written, MAX_PRINT_SIZE));
    // A tape evaluates it: one instruction per distinct operation.
    let tape = Tape::compile(&pool, &[d, dd], &[xs]).expect("compiles");
    let mut out = [0.0; 2];
    tape.eval(&[0.1], &mut out);
    assert!(out.iter().all(|v| v.is_finite()));
}

/// Long flat sums and products are shallow: printed and differentiated as they always were.
#[test]
fn long_sums_and_products_print_and_differentiate() {
    small_stack(|| {
        let mut pool = Pool::new();
        let x = pool.symbol("x");
        let xv = pool.var(x);
        let terms: Vec<Id> = (0..20_000)
            .map(|i| {
                let s = pool.symbol(&format!("a{i}"));
                let a = pool.var(s);
                pool.mul(&[a, xv])
            })
            .collect();
        let sum = pool.add(&terms);
        assert!(pool.depth(sum) <= 3);
        assert!(pool.display(sum).starts_with("a0*x + a1*x"));
        let d = pool.diff(sum, x);
        assert!(pool.display(d).starts_with("a0 + a1"));
        let prod = pool.mul(&terms[..5_000]);
        let dp = pool.diff(prod, x);
        assert!(pool.dag_size(&[dp]) > 5_000);
        let p = pool.try_display(prod).expect("prints");
        assert!(p.contains("x^5000"), "{}", &p[p.len() - 40..]);
    });
}
