//! Known-answer tests of the expression engine, written to be read as a tour of it: canonical forms,
//! structural equality, sharing in Lie derivatives of the paper's SI-engine model, printing (text and
//! LaTeX), the tape, and parse errors with their spans.

use invsim_expr::{parse, zero_test, DecidedBy, Id, Number, Pool, Symbol, Tape, ZeroVerdict};
use std::collections::HashMap;

/// Parse `src` and print its canonical form.
fn canonical(pool: &mut Pool, src: &str) -> String {
    let e = pool
        .parse(src)
        .unwrap_or_else(|err| panic!("`{src}`: {err}"));
    pool.display(e)
}

// ----- canonical forms ---------------------------------------------------------------------------------

/// Every expression is built through canonicalising constructors, so the simplifications below happen on
/// construction; there is no separate `simplify` step.
#[test]
fn canonical_forms() {
    let mut pool = Pool::new();
    for (src, want) in [
        // Like factors and like terms are combined.
        ("x*x", "x^2"),
        ("x^a*x^b", "x^(a + b)"),
        ("2*x + 3*x - x", "4*x"),
        ("v^1.8*v", "v^2.8"),
        ("x^1.8*x^0.2", "x^2"),
        ("x/x", "1"),
        ("(a*b)^2", "a^2*b^2"),
        ("a/b/c", "a/(b*c)"),
        // Numeric coefficients are distributed over a single sum.
        ("2*(x + y)", "2*x + 2*y"),
        // Identities.
        ("x^0", "1"),
        ("x^1", "x"),
        ("0*x", "0"),
        ("x - x", "0"),
        ("exp(log(x))", "x"),
        ("log(exp(x))", "x"),
        ("exp(x)^2", "exp(2*x)"),
        ("sqrt(x)^2", "x"),
        // (x^2)^(1/2) = |x|, not x: left alone.
        ("(x^2)^0.5", "sqrt(x^2)"),
        // Trigonometric functions of atan: algebraic.
        ("cos(atan(x))", "1/sqrt(1 + x^2)"),
        ("sin(atan(x))", "x/sqrt(1 + x^2)"),
        ("tan(atan(x))", "x"),
        ("cos(atan(-x))", "1/sqrt(1 + x^2)"),
        // Odd and even functions.
        ("sin(-x)", "-sin(x)"),
        ("cos(-x)", "cos(x)"),
        // Precedence: `^` binds tighter than unary minus and is right-associative.
        ("-x^2", "-x^2"),
        ("2^3^2", "512"),
        // Sums are not expanded on construction (see `Pool::expand`).
        ("(x + y)^2", "(x + y)^2"),
        // Canonical order: numbers, then π, symbols by name, powers next to their base.
        ("pi*2", "2*pi"),
        ("c1*v^2 + c3*p_i", "c3*p_i + c1*v^2"),
    ] {
        assert_eq!(canonical(&mut pool, src), want, "canonical form of `{src}`");
    }
}

/// Decimal literals are exact rationals, so `0.1 + 0.2` is exactly 3/10 (and prints as `0.3`).
#[test]
fn exact_rationals() {
    let mut pool = Pool::new();
    let e = pool.parse("0.1 + 0.2").unwrap();
    assert_eq!(pool.as_number(e), Some(Number::ratio(3, 10)));
    assert_eq!(e, pool.rational(3, 10));
    assert_eq!(pool.display(e), "0.3");
    assert_eq!(canonical(&mut pool, "1/3 + 1/6"), "0.5");
    assert_eq!(canonical(&mut pool, "x/3 + x/6"), "x/2");
    assert_eq!(canonical(&mut pool, "2.5E+4*m_at"), "25000*m_at");
    // A rational that is not a terminating decimal prints as a fraction.
    assert_eq!(canonical(&mut pool, "x^(1/3)"), "x^(1/3)");
}

/// Structurally equal expressions are the same node: equality is an `Id` comparison, O(1).
#[test]
fn structural_equality_is_id_equality() {
    let mut pool = Pool::new();
    let a = pool.parse("a*b + c").unwrap();
    let b = pool.parse("c + b*a").unwrap();
    assert_eq!(a, b);
    assert_eq!(pool.parse("x + y - y").unwrap(), pool.sym("x"));
    assert_eq!(
        pool.parse("(a + b)*(c + d)").unwrap(),
        pool.parse("(d + c)*(b + a)").unwrap()
    );
    assert_ne!(pool.parse("a - b").unwrap(), pool.parse("b - a").unwrap());
    // Built by hand, the same expression again.
    let (x, y) = (pool.sym("x"), pool.sym("y"));
    let xy = pool.mul2(x, y);
    let yx = pool.mul2(y, x);
    assert_eq!(xy, yx);
    assert_eq!(xy, pool.parse("y*x").unwrap());
}

// ----- the paper's SI-engine model: Lie derivatives and sharing -------------------------------------------

/// The reduced SI-engine model (si_engine.md): states v, p_i, input m_at, output y = v,
///
/// ```text
/// dv/dt   = c1 v² + c2 v^1.8 + c3 p_i + c4
/// dp_i/dt = c5 v + c6 v p_i + c7 m_at
/// ```
///
/// split into the drift f and the input vector field g (dx/dt = f(x) + g(x) m_at).
struct SiEngine {
    pool: Pool,
    v: Symbol,
    p_i: Symbol,
    f: [Id; 2],
    g: [Id; 2],
    h: Id,
}

impl SiEngine {
    fn new() -> SiEngine {
        let mut pool = Pool::new();
        let f = [
            pool.parse("c1*v^2 + c2*v^1.8 + c3*p_i + c4").unwrap(),
            pool.parse("c5*v + c6*v*p_i").unwrap(),
        ];
        let g = [pool.zero(), pool.parse("c7").unwrap()];
        let h = pool.parse("v").unwrap();
        let (v, p_i) = (pool.symbol("v"), pool.symbol("p_i"));
        SiEngine {
            pool,
            v,
            p_i,
            f,
            g,
            h,
        }
    }

    /// The Lie derivative L_field e = ∂e/∂v · field_v + ∂e/∂p_i · field_p_i, by diff, mul and add.
    fn lie(&mut self, e: Id, field: [Id; 2]) -> Id {
        let terms: Vec<Id> = [self.v, self.p_i]
            .into_iter()
            .zip(field)
            .map(|(s, fs)| {
                let d = self.pool.diff(e, s);
                self.pool.mul2(d, fs)
            })
            .collect();
        self.pool.add(&terms)
    }
}

#[test]
fn si_engine_lie_derivatives() {
    let mut m = SiEngine::new();
    let (f, g, h) = (m.f, m.g, m.h);
    let lf_h = m.lie(h, f);
    let lf2_h = m.lie(lf_h, f);
    let lg_h = m.lie(h, g);
    let lg_lf_h = m.lie(lf_h, g);
    let pool = &m.pool;

    // Relative degree 2: L_g h = 0, L_g L_f h = c3 c7 ≠ 0 (= β).
    assert!(pool.is_zero(lg_h));
    assert_eq!(pool.display(lg_lf_h), "c3*c7");
    assert_eq!(pool.display(lf_h), "c4 + c3*p_i + c2*v^1.8 + c1*v^2");
    assert_eq!(
        pool.display(lf2_h),
        "c3*(c5*v + c6*p_i*v) + (2*c1*v + 1.8*c2*v^0.8)*(c4 + c3*p_i + c2*v^1.8 + c1*v^2)"
    );

    // Sharing: L_f h is a node of L_f² h (the chain rule reuses it instead of copying it), and the whole
    // derivation stays a small DAG.
    assert!(pool.topological(&[lf2_h]).contains(&lf_h));
    assert!(pool.dag_size(&[lf_h]) < 20, "{}", pool.dag_size(&[lf_h]));
    assert!(pool.dag_size(&[lf2_h]) < 60, "{}", pool.dag_size(&[lf2_h]));
    let both = pool.dag_size(&[lf_h, lf2_h, lg_lf_h]);
    assert!(both < 60, "{both}");
    assert_eq!(
        both,
        pool.dag_size(&[lf2_h, lg_lf_h]),
        "L_f h adds no node to L_f² h"
    );

    // Values against the derivatives worked out by hand.
    let c = [-3.1e-4, -2.2e-3, 1.3e-4, -0.12, 2.9e3, -0.21, 4.6e7];
    let (v, p) = (13.9, 2.93e4);
    let mut env: HashMap<Symbol, f64> = HashMap::from([(m.v, v), (m.p_i, p)]);
    for (i, &ci) in c.iter().enumerate() {
        env.insert(pool.find_symbol(&format!("c{}", i + 1)).unwrap(), ci);
    }
    let f1 = c[0] * v * v + c[1] * v.powf(1.8) + c[2] * p + c[3];
    let f2 = c[4] * v + c[5] * v * p;
    let want_lf2 = (2.0 * c[0] * v + 1.8 * c[1] * v.powf(0.8)) * f1 + c[2] * f2;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(close(pool.eval(lf_h, &env).unwrap(), f1));
    assert!(close(pool.eval(lf2_h, &env).unwrap(), want_lf2));
    assert!(close(pool.eval(lg_lf_h, &env).unwrap(), c[2] * c[6]));
}

/// α(ξ) of si_engine.md is L_f² h with the states written in normal-form coordinates,
/// v = ξ1, p_i = x2(ξ) = (ξ2 − c1 ξ1² − c2 ξ1^1.8 − c4)/c3; substitution and the zero test confirm it.
#[test]
fn si_engine_alpha_in_normal_form_coordinates() {
    let mut m = SiEngine::new();
    let (f, h) = (m.f, m.h);
    let lf_h = m.lie(h, f);
    let lf2_h = m.lie(lf_h, f);
    let pool = &mut m.pool;
    let xi1 = pool.sym("xi1");
    let x2 = pool.parse("(xi2 - c1*xi1^2 - c2*xi1^1.8 - c4)/c3").unwrap();
    let to_xi = HashMap::from([(m.v, xi1), (m.p_i, x2)]);
    let alpha = pool.substitute(lf2_h, &to_xi);
    let documented = pool
        .parse(
            "(1.8*c2*xi1^0.8 + 2*c1*xi1)*xi2 \
             + c3*(c5*xi1 + c6*xi1*(xi2 - c1*xi1^2 - c2*xi1^1.8 - c4)/c3)",
        )
        .unwrap();
    let difference = pool.sub(alpha, documented);
    assert!(
        zero_test(pool, difference, &HashMap::new()).is_zero(),
        "{}",
        pool.display(difference)
    );
    // ξ2 = L_f h(x), so substituting the inverse back gives ξ2 exactly, in canonical form.
    let xi2 = pool.sym("xi2");
    assert_eq!(pool.substitute(lf_h, &to_xi), xi2);
}

// ----- calculus ------------------------------------------------------------------------------------------

#[test]
fn derivatives() {
    let mut pool = Pool::new();
    let x = pool.symbol("x");
    for (src, want) in [
        ("x^3", "3*x^2"),
        ("x^1.8", "9*x^0.8/5"),
        ("sin(x)^2", "2*sin(x)*cos(x)"),
        ("exp(2*x)", "2*exp(2*x)"),
        ("log(x)", "1/x"),
        ("atan(x)", "1/(1 + x^2)"),
        ("tanh(x)", "1 - tanh(x)^2"),
        ("a^x", "a^x*log(a)"),
        ("x^x", "x^x*(1 + log(x))"),
        ("abs(x)", "sign(x)"),
        ("y", "0"),
    ] {
        let e = pool.parse(src).unwrap();
        let d = pool.diff(e, x);
        assert_eq!(pool.display(d), want, "d/dx {src}");
    }
}

/// cos, sin and tan of atan(x) as the canonicaliser writes them give the functions' values to a few ulps
/// over grades and far beyond, and their derivatives agree with central differences. The reference is libm's
/// composition for |x| ≤ 1 (atan x within ±π/4, where cos and sin are well conditioned) and, beyond, the
/// triangle in 1/x (cos(atan x) = 1/(|x|·√(1 + 1/x²))), since cos near ±π/2 would cancel.
#[test]
fn trigonometry_of_atan_is_algebraic_and_exact() {
    let mut pool = Pool::new();
    let x = pool.symbol("x");
    let cos_atan = |x: f64| match x.abs() <= 1.0 {
        true => x.atan().cos(),
        false => 1.0 / (x.abs() * (1.0 + 1.0 / (x * x)).sqrt()),
    };
    let cases: [(&str, &dyn Fn(f64) -> f64); 3] = [
        ("cos(atan(x))", &cos_atan),
        ("sin(atan(x))", &|x| match x.abs() <= 1.0 {
            true => x.atan().sin(),
            false => x.signum() / (1.0 + 1.0 / (x * x)).sqrt(),
        }),
        ("tan(atan(x))", &|x| x),
    ];
    for (src, reference) in cases {
        let e = pool.parse(src).unwrap();
        let d = pool.diff(e, x);
        for i in -400..=400 {
            let v = if i % 2 == 0 {
                i as f64 * 1e-3
            } else {
                (i as f64 * 0.05).powi(5)
            };
            let values = HashMap::from([(x, v)]);
            let got = pool.eval(e, &values).unwrap();
            let want = reference(v);
            assert!(
                (got - want).abs() <= 4e-16 * (want.abs() + 1e-300) * 4.0,
                "{src} at {v}: {got} vs {want}"
            );
            let h = 1e-6 * (1.0 + v.abs());
            let fd = (reference(v + h) - reference(v - h)) / (2.0 * h);
            let dv = pool.eval(d, &values).unwrap();
            assert!(
                (dv - fd).abs() <= 1e-6 * fd.abs() + 1e-9,
                "d/dx {src} at {v}: {dv} vs {fd}"
            );
        }
    }
}

#[test]
fn substitution_expansion_and_the_zero_test() {
    let mut pool = Pool::new();
    // Substitution is simultaneous and rebuilds canonical forms.
    let e = pool.parse("x^2 + 2*y").unwrap();
    let (x, y) = (pool.symbol("x"), pool.symbol("y"));
    let (sx, sy) = (pool.var(x), pool.var(y));
    let swapped = pool.substitute(e, &HashMap::from([(x, sy), (y, sx)]));
    assert_eq!(pool.display(swapped), "2*x + y^2");
    let sq = pool.parse("sqrt(z)").unwrap();
    let r = pool.substitute(e, &HashMap::from([(x, sq)]));
    assert_eq!(pool.display(r), "2*y + z");

    // Expansion multiplies out products and integer powers of sums.
    let e = pool.parse("(x + y)^2 - (x - y)^2").unwrap();
    let ex = pool.expand(e).unwrap();
    assert_eq!(pool.display(ex), "4*x*y");

    // The zero test says how it decided.
    let nominal = HashMap::new();
    for (src, verdict) in [
        ("x - x", ZeroVerdict::Zero(DecidedBy::Canonical)),
        (
            "(x + y)^2 - (x^2 + 2*x*y + y^2)",
            ZeroVerdict::Zero(DecidedBy::Expanded),
        ),
        (
            "sin(x)^2 + cos(x)^2 - 1",
            ZeroVerdict::Zero(DecidedBy::Probing),
        ),
        (
            "sin(x)^2 + cos(x)^2 - 1 + 1e-3*x",
            ZeroVerdict::NonZero(DecidedBy::Probing),
        ),
        ("3", ZeroVerdict::NonZero(DecidedBy::Canonical)),
    ] {
        let e = pool.parse(src).unwrap();
        assert_eq!(zero_test(&mut pool, e, &nominal), verdict, "{src}");
    }
}

// ----- printing ------------------------------------------------------------------------------------------

/// What `display` prints parses back to the same node (the contract's language, section 1).
#[test]
fn printed_text_parses_back() {
    let mut pool = Pool::new();
    for (src, want) in [
        // The canonical form does not depend on grouping (a sum's numeric content joins the product's
        // coefficient), so the printer may group as it reads best.
        ("3*(a + b)*c", "3*c*(a + b)"),
        ("c*(3*a + 3*b)", "3*c*(a + b)"),
        ("(a + b)*sin(x)*3", "3*(a + b)*sin(x)"),
        ("-((a + b)*(c + d))", "-(a + b)*(c + d)"),
        ("-(a + b)*(c + d)", "-(a + b)*(c + d)"),
        ("x/(2*(x + y))", "x/(2*(x + y))"),
        ("x/(x + y)/2", "x/(2*(x + y))"),
        ("x/(x + y)/(2*z)", "x/(2*z*(x + y))"),
        // A non-integer coefficient is shown multiplied into a sum when that gives decimals.
        ("(0.464 + 0.0072*s)*k", "(0.464 + 0.0072*s)*k"),
        ("-(1 - a)*x/2", "(-0.5 + 0.5*a)*x"),
        ("y^-2", "1/y^2"),
        ("-1/(x*y)", "-1/(x*y)"),
        ("1e-300*x", "1e-300*x"),
        ("exp(-x)*sin(omega*t)", "exp(-x)*sin(omega*t)"),
    ] {
        let e = pool.parse(src).unwrap();
        let text = pool.display(e);
        assert_eq!(text, want, "display of `{src}`");
        assert_eq!(pool.parse(&text).unwrap(), e, "`{text}` parses back");
    }
}

#[test]
fn latex() {
    let mut pool = Pool::new();
    for (src, want) in [
        ("sqrt(x)/(2*y)", r"\frac{\sqrt{x}}{2 \, y}"),
        ("c1*v^2 + c3*p_i", r"c_{3} \, p_{i} + c_{1} \, v^{2}"),
        (
            "exp(-x)*sin(omega*t)",
            r"\exp\left(-x\right) \, \sin\left(\omega \, t\right)",
        ),
        (
            "xi1^1.8 - eta_trm/3",
            r"-\frac{\eta_{\mathrm{trm}}}{3} + \xi_{1}^{1.8}",
        ),
        (
            "atan(x) + abs(y) + min(a, b)",
            r"\arctan\left(x\right) + \left|y\right| + \min\left(a, b\right)",
        ),
        ("(x + y)^2", r"\left(x + y\right)^{2}"),
        ("x^(1/3)", r"x^{\frac{1}{3}}"),
        ("1/sqrt(1 + x^2)", r"\frac{1}{\sqrt{1 + x^{2}}}"),
        ("1e-300*m_at", r"1 \cdot 10^{-300} \, m_{\mathrm{at}}"),
        (
            "sign(x)*cos(2*pi*t)",
            r"\cos\left(2 \, \pi \, t\right) \, \operatorname{sign}\left(x\right)",
        ),
    ] {
        let e = pool.parse(src).unwrap();
        assert_eq!(pool.latex(e), want, "LaTeX of `{src}`");
    }
}

// ----- the tape ------------------------------------------------------------------------------------------

/// α and β of the SI-engine model compiled into one tape over [xi1, xi2, c1..c7].
#[test]
fn tape_evaluates_alpha_and_beta() {
    let mut pool = Pool::new();
    let alpha = pool
        .parse(
            "(1.8*c2*xi1^0.8 + 2*c1*xi1)*xi2 \
             + c3*(c5*xi1 + c6*xi1*(xi2 - c1*xi1^2 - c2*xi1^1.8 - c4)/c3)",
        )
        .unwrap();
    let beta = pool.parse("c3*c7").unwrap();
    let inputs: Vec<Symbol> = ["xi1", "xi2", "c1", "c2", "c3", "c4", "c5", "c6", "c7"]
        .iter()
        .map(|n| pool.symbol(n))
        .collect();
    let tape = Tape::compile(&pool, &[alpha, beta], &inputs).unwrap();
    assert_eq!((tape.n_inputs(), tape.n_outputs()), (9, 2));
    // xi1^0.8 and xi1^1.8 share one powf.
    let powfs = tape
        .instructions()
        .iter()
        .filter(|i| matches!(i, invsim_expr::Instr::Powf(..)))
        .count();
    assert_eq!(powfs, 1);

    let point = [
        13.9, 0.4, -3.1e-4, -2.2e-3, 1.3e-4, -0.12, 2.9e3, -0.21, 4.6e7,
    ];
    let mut out = [0.0; 2];
    tape.eval(&point, &mut out);
    let mut buf = tape.new_buffer();
    let mut out_in = [0.0; 2];
    tape.eval_in(&mut buf, &point, &mut out_in);
    assert_eq!(out, out_in);

    let env: HashMap<Symbol, f64> = inputs.iter().copied().zip(point).collect();
    let [xi1, xi2, c1, c2, c3, c4, c5, c6, c7] = point;
    let x2 = (xi2 - c1 * xi1 * xi1 - c2 * xi1.powf(1.8) - c4) / c3;
    let want = (1.8 * c2 * xi1.powf(0.8) + 2.0 * c1 * xi1) * xi2 + c3 * (c5 * xi1 + c6 * xi1 * x2);
    for (got, want) in [
        (out[0], want),
        (out[1], c3 * c7),
        (pool.eval(alpha, &env).unwrap(), want),
    ] {
        assert!((got - want).abs() <= 1e-12 * want.abs(), "{got} vs {want}");
    }
}

// ----- parse errors --------------------------------------------------------------------------------------

/// Every error names what was expected and points at the offending bytes.
#[test]
fn parse_errors_have_spans() {
    for (src, span, message) in [
        (
            "a + * b",
            4..5,
            "expected a number, a name or `(`, found `*`",
        ),
        ("foo(x)", 0..3, "unknown function `foo`"),
        ("sin(x, y)", 0..9, "`sin` takes 1 argument, found 2"),
        ("pow(x)", 0..6, "`pow` takes 2 arguments, found 1"),
        ("(a + b", 6..6, "expected `)`"),
        ("x + (y*(z)", 10..10, "expected `)`"),
        ("a b", 2..3, "found `b`"),
        ("a)", 1..2, "unmatched `)`"),
        ("1.2.3", 0..4, "malformed number"),
        ("2e", 0..2, "expected digits after the exponent"),
        ("3x", 0..2, "malformed number"),
        ("a $ b", 2..3, "unexpected character `$`"),
        ("a × b", 2..4, "unexpected character `×`"),
        ("   ", 0..3, "empty expression"),
        ("x^", 2..2, "found the end of the expression"),
        (
            "sin x",
            0..3,
            "function `sin` must be called with parentheses",
        ),
        ("a ** b", 3..4, "`**` is not an operator"),
        ("()", 1..2, "empty parentheses"),
        ("min(a,)", 6..7, "found `)`"),
    ] {
        let err = parse(src).expect_err(src);
        assert_eq!(
            err.span, span,
            "span of the error in `{src}` ({})",
            err.message
        );
        assert!(
            err.message.contains(message),
            "`{src}`: message `{}` lacks `{message}`",
            err.message
        );
    }
}
