//! `math::pow_pos` and `math::pow_pos_slice` against `f64::powf` and against correctly rounded references.
//!
//! The fast path's error is below 1 ulp of the exact x^y and `powf`'s (glibc) below 0.52 ulp, so two results
//! differ by at most one representable `f64` ("step"); every comparison here asserts that, over millions of
//! points. Where the fast path does not apply the result must be `powf`'s, bit for bit.

use invsim_model_api::math::{pow_pos, pow_pos_slice, POW_POS_MAX_EXPONENT};

/// How many representable `f64` lie between `a` and `b` (0 if equal, `u64::MAX` for different signs,
/// non-finite values or one NaN).
fn steps(a: f64, b: f64) -> u64 {
    if a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()) {
        return 0;
    }
    if !a.is_finite() || !b.is_finite() || a.is_sign_negative() != b.is_sign_negative() {
        return u64::MAX;
    }
    a.to_bits().abs_diff(b.to_bits())
}

/// A small deterministic generator (no dependency): uniform in [0, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Log-uniform in [10^lo, 10^hi].
    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        10f64.powf(lo + (hi - lo) * self.next())
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// Tally of a comparison with `powf`.
#[derive(Default, Debug)]
struct Tally {
    points: usize,
    identical: usize,
    worst: u64,
    worst_at: (f64, f64),
}

impl Tally {
    fn add(&mut self, x: f64, y: f64, ours: f64) {
        let d = steps(ours, x.powf(y));
        self.points += 1;
        if d == 0 {
            self.identical += 1;
        }
        if d > self.worst {
            self.worst = d;
            self.worst_at = (x, y);
        }
    }

    fn check(&self, what: &str) {
        eprintln!(
            "{what}: {} points, {:.2} % identical to powf, largest difference {} step(s)",
            self.points,
            100.0 * self.identical as f64 / self.points as f64,
            self.worst
        );
        assert!(
            self.worst <= 1,
            "{what}: {} steps from powf at x = {:e}, y = {}",
            self.worst,
            self.worst_at.0,
            self.worst_at.1
        );
        // A sanity check on the comparison itself: most results are the correctly rounded one.
        assert!(self.identical * 10 > self.points * 9, "{what}: {self:?}");
    }
}

#[test]
fn random_points_over_the_whole_range() {
    // x ∈ [1e-300, 1e300] log-uniform, y ∈ [−4, 4]: a fresh (x, y) per point (scalar form).
    let mut rng = Lcg(1);
    let mut t = Tally::default();
    for _ in 0..2_000_000 {
        let (x, y) = (rng.log_uniform(-300.0, 300.0), rng.uniform(-4.0, 4.0));
        t.add(x, y, pow_pos(x, y));
    }
    t.check("x in [1e-300, 1e300], y in [-4, 4], scalar");
    // The slice form, one exponent per slice of 4096.
    let mut t = Tally::default();
    let mut out = vec![0.0; 4096];
    for _ in 0..500 {
        let y = rng.uniform(-4.0, 4.0);
        let xs: Vec<f64> = (0..4096).map(|_| rng.log_uniform(-300.0, 300.0)).collect();
        pow_pos_slice(&xs, y, &mut out);
        for (&x, &o) in xs.iter().zip(&out) {
            t.add(x, y, o);
        }
    }
    t.check("x in [1e-300, 1e300], y in [-4, 4], slices");
}

#[test]
fn the_exponents_invsim_uses() {
    // si_engine's friction term (S_p² + S_ε²)^0.9, its derivative's ^-0.1, shared roots ^0.1, the fuel maps'
    // ^0.8/^1.8, and typical thermodynamic exponents ((γ − 1)/γ, 1/γ, ...).
    let exponents = [
        0.9,
        -0.1,
        0.1,
        0.8,
        1.8,
        -0.9,
        0.5,
        1.5,
        2.5,
        -1.5,
        2.0 / 7.0,
        1.0 / 1.4,
        1.0 / 3.0,
        -1.0 / 3.0,
        0.25,
        1.25,
    ];
    let mut rng = Lcg(2);
    let mut out = vec![0.0; 10_000];
    for &y in &exponents {
        let mut t = Tally::default();
        for round in 0..60 {
            // Half the slices over the whole range, half over the physical one (speeds, pressures, flows).
            let xs: Vec<f64> = if round % 2 == 0 {
                (0..out.len())
                    .map(|_| rng.log_uniform(-300.0, 300.0))
                    .collect()
            } else {
                (0..out.len()).map(|_| rng.log_uniform(-6.0, 6.0)).collect()
            };
            pow_pos_slice(&xs, y, &mut out);
            for (&x, &o) in xs.iter().zip(&out) {
                t.add(x, y, o);
            }
        }
        t.check(&format!("y = {y}"));
    }
}

#[test]
fn large_exponents_up_to_the_fast_path_bound() {
    let mut rng = Lcg(3);
    let mut t = Tally::default();
    for _ in 0..1_000_000 {
        let y = rng.uniform(-POW_POS_MAX_EXPONENT, POW_POS_MAX_EXPONENT);
        // |y ln x| up to about 700: results over most of the normal range.
        let x = rng.log_uniform(-300.0 / y.abs().max(1.0), 300.0 / y.abs().max(1.0));
        t.add(x, y, pow_pos(x, y));
    }
    t.check("|y| <= 16");
    let mut t = Tally::default();
    for _ in 0..1_000_000 {
        let (x, y) = (rng.uniform(0.25, 4.0), rng.uniform(-16.0, 16.0));
        t.add(x, y, pow_pos(x, y));
    }
    t.check("x in [0.25, 4], |y| <= 16");
}

#[test]
fn correctly_rounded_references() {
    // IEEE square root and division are correctly rounded; products of small integers are exact. Within one
    // ulp of the exact value, the fast path is at most one step from each.
    let mut rng = Lcg(4);
    let mut worst = [0u64; 4];
    for _ in 0..500_000 {
        let x = rng.log_uniform(-300.0, 300.0);
        worst[0] = worst[0].max(steps(pow_pos(x, 0.5), x.sqrt()));
        worst[1] = worst[1].max(steps(pow_pos(x, -1.0), 1.0 / x));
        worst[2] = worst[2].max(steps(pow_pos(x, 1.0), x));
        let x = rng.log_uniform(-150.0, 150.0);
        // x² is not exact, but x · x is its correct rounding.
        worst[3] = worst[3].max(steps(pow_pos(x, 2.0), x * x));
    }
    assert!(worst.iter().all(|&w| w <= 1), "{worst:?}");
    for n in 1..=1000_u32 {
        let v = f64::from(n);
        assert!(steps(pow_pos(v, 3.0), v * v * v) <= 1, "{n}^3");
        assert!(steps(pow_pos(v * v * v * v, 0.25), v) <= 1, "({n}^4)^(1/4)");
    }
    assert!(steps(pow_pos(2.0, 10.0), 1024.0) <= 1);
    assert!(steps(pow_pos(0.25, -0.5), 2.0) <= 1);
}

#[test]
fn edge_cases_are_powf_exactly() {
    let xs = [
        0.0,
        -0.0,
        -1.0,
        -2.5,
        -1e-300,
        f64::MIN_POSITIVE,
        f64::MIN_POSITIVE / 2.0,
        5e-324,
        f64::MAX,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        1.0,
        f64::EPSILON,
        1.0 - f64::EPSILON / 2.0,
        1.0 + f64::EPSILON,
        0.5,
        2.0,
        1e300,
        1e-300,
    ];
    let ys = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        2.0,
        3.0,
        0.5,
        0.9,
        -0.1,
        1.8,
        16.0,
        -16.0,
        16.000_000_000_000_004,
        100.0,
        -100.0,
        1e300,
        5e-324,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
    ];
    for &y in &ys {
        let mut out = vec![0.0; xs.len()];
        pow_pos_slice(&xs, y, &mut out);
        for (&x, &o) in xs.iter().zip(&out) {
            let reference = x.powf(y);
            let scalar = pow_pos(x, y);
            assert!(
                o.to_bits() == scalar.to_bits() || (o.is_nan() && scalar.is_nan()),
                "slice and scalar differ at x = {x:e}, y = {y:e}: {o:e} vs {scalar:e}"
            );
            let fast_path = (f64::MIN_POSITIVE..=f64::MAX).contains(&x)
                && y.abs() <= POW_POS_MAX_EXPONENT
                && (y * x.ln()).abs() < 707.0;
            if fast_path {
                assert!(
                    steps(o, reference) <= 1,
                    "x = {x:e}, y = {y:e}: {o:e} vs powf {reference:e}"
                );
            } else {
                assert!(
                    o.to_bits() == reference.to_bits() || (o.is_nan() && reference.is_nan()),
                    "x = {x:e}, y = {y:e}: {o:e} vs powf {reference:e}"
                );
            }
        }
    }
    // Exact special results.
    for &y in &[0.1, -3.7, 16.0, 1e-300] {
        assert_eq!(pow_pos(1.0, y), 1.0);
    }
    for &x in &[1e-300, 0.3, 7.0, 1e300] {
        assert_eq!(pow_pos(x, 0.0), 1.0);
        assert_eq!(pow_pos(x, -0.0), 1.0);
    }
}

#[test]
fn results_near_overflow_and_underflow() {
    // |y ln x| around 708: the fast path stops just inside the normal range, powf takes over outside it.
    let mut rng = Lcg(5);
    let mut t = Tally::default();
    for _ in 0..200_000 {
        let y = rng.uniform(0.5, 4.0) * if rng.next() < 0.5 { -1.0 } else { 1.0 };
        let target = rng.uniform(690.0, 720.0) * if rng.next() < 0.5 { -1.0 } else { 1.0 };
        let x = (target / y).exp();
        let o = pow_pos(x, y);
        let reference = x.powf(y);
        if reference == 0.0 || reference.is_infinite() || reference < f64::MIN_POSITIVE {
            assert_eq!(o.to_bits(), reference.to_bits(), "x = {x:e}, y = {y}");
        } else {
            t.add(x, y, o);
        }
    }
    t.check("results near the ends of the normal range");
}

#[test]
fn slices_match_the_scalar_form_at_every_length() {
    let mut rng = Lcg(6);
    for len in (0..=600).chain([1023, 1024, 1025, 4096]) {
        let xs: Vec<f64> = (0..len)
            .map(|i| match i % 97 {
                13 => 0.0,
                41 => -rng.next(),
                77 => f64::NAN,
                _ => rng.log_uniform(-10.0, 10.0),
            })
            .collect();
        let y = rng.uniform(-3.0, 3.0);
        let mut out = vec![f64::NAN; len];
        pow_pos_slice(&xs, y, &mut out);
        for (&x, &o) in xs.iter().zip(&out) {
            let s = pow_pos(x, y);
            assert!(
                o.to_bits() == s.to_bits() || (o.is_nan() && s.is_nan()),
                "len {len}: x = {x:e}, y = {y}: {o:e} vs {s:e}"
            );
        }
    }
}

#[test]
#[should_panic(expected = "lengths differ")]
fn slices_of_different_lengths_panic() {
    pow_pos_slice(&[1.0, 2.0], 0.5, &mut [0.0]);
}
