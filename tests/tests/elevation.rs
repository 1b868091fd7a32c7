//! Road grade from elevation over distance (`invsim_runtime::elevation`) against exact cases: a constant
//! slope gives that constant grade (tan(asin σ), rise over run); a sinusoidal profile over distance gives its
//! analytic derivative along s(t) = ∫ y_d dt, the smoothed reference's distance (integrated here by
//! Gauss–Legendre quadrature, independently of the code's Simpson rule); si_engine_grade's fuel with the
//! profile equals the run with the equivalent grade signal; the cycle's `elevation_m` column gives what the
//! same profile as a route file gives.

use invsim_inversion::{derive_file, Interpreter};
use invsim_runtime::signal_file::parse_signal_file;
use invsim_runtime::{simulate, Cycle, SignalInput, SignalValue, SimulationOptions, Smoother};
use std::fmt::Write as _;
use std::path::PathBuf;

fn interp() -> Interpreter {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    Interpreter::new(&derive_file(&root.join("models/si_engine_grade.toml")).unwrap()).unwrap()
}

const LOOKAHEAD: f64 = 5.0;

fn opts(signals: Vec<SignalInput>) -> SimulationOptions {
    SimulationOptions {
        dt: 0.1,
        lookahead: LOOKAHEAD,
        signals,
        engine: "interpreted".into(),
        ..SimulationOptions::default()
    }
}

/// A route file `distance_m,elevation_m` with nodes every `step` metres up to `length`.
fn route_file(step: f64, length: f64, h: impl Fn(f64) -> f64) -> SignalInput {
    let mut text = String::from("distance_m,elevation_m\n");
    let n = (length / step) as usize;
    for k in 0..=n {
        let s = k as f64 * step;
        let _ = writeln!(text, "{s},{}", h(s));
    }
    SignalInput {
        name: "grade".into(),
        value: parse_signal_file("route.csv", &text, "grade").unwrap(),
    }
}

#[test]
fn a_constant_slope_gives_a_constant_grade() {
    let m = interp();
    let cycle = Cycle::builtin("nedc").unwrap();
    let sigma = 0.03;
    let res = simulate(
        &m,
        &cycle,
        &opts(vec![route_file(100.0, 20e3, |s| 7.0 + sigma * s)]),
    )
    .unwrap();
    let want = sigma / (1.0 - sigma * sigma).sqrt();
    let (g, g1) = (
        res.column("grade").unwrap(),
        res.column("grade_d1").unwrap(),
    );
    for k in 0..res.len() {
        assert!(
            (g[k] - want).abs() < 1e-14 && g1[k].abs() < 1e-14,
            "k = {k}: {} {}",
            g[k],
            g1[k]
        );
    }
    // The same slope as the cycle's elevation column over its time (nodes at the cycle's own distance).
    let mut text = String::from("time_s,speed_mps,elevation_m\n");
    let mut s = 0.0;
    for i in 0..cycle.time.len() {
        if i > 0 {
            s += 0.5 * (cycle.speed[i - 1] + cycle.speed[i]) * (cycle.time[i] - cycle.time[i - 1]);
        }
        let _ = writeln!(
            text,
            "{},{},{}",
            cycle.time[i],
            cycle.speed[i],
            100.0 + sigma * s
        );
    }
    let with_column = Cycle::from_csv_str("hill.csv", &text).unwrap();
    let res = simulate(&m, &with_column, &opts(Vec::new())).unwrap();
    assert_eq!(
        res.summary.signals[0].source,
        "cycle column elevation_m, as grade"
    );
    let g = res.column("grade").unwrap();
    let worst = g.iter().map(|v| (v - want).abs()).fold(0.0, f64::max);
    assert!(worst < 1e-12, "worst {worst:e}");
}

/// h(s) = A sin(2π s/L): amplitude 5 m, wavelength 400 m (slopes up to 7.9 %).
const A: f64 = 5.0;
const L: f64 = 400.0;
fn hills(s: f64) -> f64 {
    A * (std::f64::consts::TAU * s / L).sin()
}
fn hills_slope(s: f64) -> f64 {
    A * std::f64::consts::TAU / L * (std::f64::consts::TAU * s / L).cos()
}

/// s(t) = ∫ y_d dt on the grid `time` (from its first point), three-point Gauss–Legendre on each interval.
fn smoothed_distance(cycle: &Cycle, time: &[f64]) -> Vec<f64> {
    let sm = Smoother::new(cycle, LOOKAHEAD).unwrap();
    let (x, w) = ((0.6f64).sqrt(), [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0]);
    let mut s = vec![0.0];
    for j in 1..time.len() {
        let (a, b) = (time[j - 1], time[j]);
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        let q: f64 = [-x, 0.0, x]
            .iter()
            .zip(w)
            .map(|(&xi, wi)| wi * sm.derivative(0, c + h * xi))
            .sum();
        s.push(s[j - 1] + h * q);
    }
    s
}

#[test]
fn a_sinusoidal_profile_gives_its_derivative_along_the_smoothed_distance() {
    let m = interp();
    let cycle = Cycle::builtin("nedc").unwrap();
    let res = simulate(&m, &cycle, &opts(vec![route_file(5.0, 15e3, hills)])).unwrap();
    let raw = &res.signals[0];
    assert_eq!(
        raw.source,
        "command line (route.csv, elevation over distance)"
    );
    let s = smoothed_distance(&cycle, &raw.time);
    // Node spacing d = 5 m: by Taylor, the three-point slopes are off by at most d²·max|h‴|/6 inside and the
    // one-sided ones d²·max|h‴|/3 at the ends (the Hermite derivative between nodes adds O(d³)); with
    // max|h‴| = A(2π/L)³ these are 8.1e-5 and 1.6e-4 against a peak grade of 0.079.
    let d3 = A * (std::f64::consts::TAU / L).powi(3);
    let (bound_inside, bound_end) = (25.0 * d3 / 6.0, 25.0 * d3 / 3.0);
    let (mut inside, mut worst) = (0.0f64, 0.0f64);
    for (j, &g) in raw.values.iter().enumerate() {
        let sigma = hills_slope(s[j]);
        let e = (g - sigma / (1.0 - sigma * sigma).sqrt()).abs();
        worst = worst.max(e);
        if s[j] > 10.0 {
            inside = inside.max(e);
        }
    }
    eprintln!("grade error: inside {inside:e} (bound {bound_inside:e}), overall {worst:e} (bound {bound_end:e})");
    assert!(
        inside < 1.1 * bound_inside,
        "worst grade error inside {inside:e}"
    );
    assert!(worst < 1.1 * bound_end, "worst grade error {worst:e}");
    assert!(raw.values.iter().fold(0.0f64, |m, v| m.max(v.abs())) > 0.07);

    // The equivalent grade signal, tan(asin h'(s(t))) on the same times from this test's own distance, gives
    // the same fuel.
    let equivalent: Vec<f64> = s
        .iter()
        .map(|&x| {
            let sigma = hills_slope(x);
            sigma / (1.0 - sigma * sigma).sqrt()
        })
        .collect();
    let given = SignalInput {
        name: "grade".into(),
        value: SignalValue::Series {
            file: "grade.csv".into(),
            time: raw.time.clone(),
            values: equivalent,
        },
    };
    let direct = simulate(&m, &cycle, &opts(vec![given])).unwrap();
    let (f_route, f_grade) = (
        res.summary.totals.integrals["fuel"],
        direct.summary.totals.integrals["fuel"],
    );
    assert!(
        (f_route - f_grade).abs() < 1e-5 * f_grade,
        "fuel {f_route} (profile) vs {f_grade} (grade)"
    );
    // Hills cost fuel: the climbs are not all given back (no brake; negative air flow is cut off).
    let flat = simulate(&m, &cycle, &opts(Vec::new())).unwrap();
    assert!(f_route > flat.summary.totals.integrals["fuel"]);
}
