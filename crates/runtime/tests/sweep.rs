//! Parameter sweeps: every row equals the single run of its variant (bit for bit), for the compiled and the
//! interpreted engine, with 1 and 2 threads; failing variants are rows with their error; bad designs are
//! errors of `build`.

use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, Figures, SimulationOptions, Sweep, SweepError, SweepResult};

fn compiled() -> Box<dyn InverseModel> {
    invsim_models::builtin("si_engine").expect("si_engine is built in")
}

fn interpreted() -> invsim_inversion::Interpreter {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine.toml");
    let d = invsim_inversion::derive_file(&path).expect("derive si_engine.toml");
    invsim_inversion::Interpreter::new(&d).expect("interpreter")
}

fn cycles() -> Vec<Cycle> {
    ["ece", "hwfet"]
        .iter()
        .map(|n| Cycle::builtin(n).expect("built in"))
        .collect()
}

fn opts(engine: &str, verify: bool) -> SimulationOptions {
    SimulationOptions::builder()
        .dt(0.5)
        .engine(engine)
        .verify(verify)
        .build()
        .expect("valid options")
}

/// Every row of `result` is bit for bit the figures of `simulate` of its variant on its cycle.
fn assert_rows_equal_single_runs(
    result: &SweepResult,
    mut model: Box<dyn InverseModel>,
    o: &SimulationOptions,
) {
    let cycles = cycles();
    assert_eq!(result.rows.len() % cycles.len(), 0);
    for (j, row) in result.rows.iter().enumerate() {
        assert_eq!(row.variant, j / cycles.len());
        let cycle = &cycles[j % cycles.len()];
        assert_eq!(row.cycle, cycle.name);
        for (name, &v) in result.parameters.iter().zip(&row.params) {
            model.set_param(name, v).expect("known parameter");
        }
        let single = simulate(model.as_ref(), cycle, o).expect("the variant runs");
        let expected = Figures::from_summary(&single.summary, &result.integrals);
        let got = row.outcome.as_ref().expect("the row ran");
        // Bit for bit: the same f64 values (PartialEq on every field).
        assert_eq!(got, &expected, "row {j}: {:?}", row.params);
    }
}

fn sweep_of(
    builder: invsim_runtime::SweepBuilder,
    o: &SimulationOptions,
    threads: usize,
) -> SweepResult {
    let mut b = builder
        .grid("m", 1000.0, 1800.0, 3)
        .values("i_t", vec![4.0, 6.0]);
    for c in &cycles() {
        b = b.cycle(c);
    }
    b.options(o.clone())
        .verify(o.verify)
        .threads(threads)
        .build()
        .expect("the sweep builds")
        .run()
}

#[test]
fn compiled_rows_equal_single_runs_with_1_and_2_threads() {
    let o = opts("compiled", false);
    for threads in [1, 2] {
        let result = sweep_of(Sweep::new(compiled), &o, threads);
        assert_eq!(result.rows.len(), 3 * 2 * 2);
        assert_eq!(result.failed(), 0);
        assert_eq!(result.integrals, ["fuel", "fuel_volume"]);
        assert_rows_equal_single_runs(&result, compiled(), &o);
    }
}

#[test]
fn interpreted_rows_equal_single_runs_with_1_and_2_threads() {
    let o = opts("interpreted", false);
    for threads in [1, 2] {
        let result = sweep_of(Sweep::of(interpreted()), &o, threads);
        assert_eq!(result.failed(), 0);
        assert_rows_equal_single_runs(&result, Box::new(interpreted()), &o);
    }
}

#[test]
fn verified_rows_have_the_tracking_error_of_single_runs() {
    let o = opts("compiled", true);
    let result = sweep_of(Sweep::new(compiled), &o, 2);
    assert!(result
        .header()
        .contains(&"max_abs_tracking_error".to_string()));
    for row in &result.rows {
        let f = row.outcome.as_ref().expect("ran");
        assert!(f.max_abs_tracking_error.is_some_and(|e| e < 0.1));
    }
    assert_rows_equal_single_runs(&result, compiled(), &o);
}

#[test]
fn a_failing_variant_is_a_row_with_its_error() {
    // i_t = 0: the engine is geared to nothing, β = 0 and the input is undefined.
    let cycle = Cycle::builtin("ece").expect("built in");
    let result = Sweep::new(compiled)
        .cycle(&cycle)
        .values("i_t", vec![5.0, 0.0, 4.0])
        .options(opts("compiled", false))
        .threads(2)
        .build()
        .expect("builds")
        .run();
    assert_eq!(result.failed(), 1);
    let err = result.rows[1].outcome.as_ref().expect_err("β = 0 fails");
    assert!(err.contains("β(ξ, η)") && err.contains("is 0"), "{err}");
    assert!(result.rows[0].outcome.is_ok() && result.rows[2].outcome.is_ok());
    let mut csv = Vec::new();
    result.write_csv(&mut csv).expect("csv");
    let text = String::from_utf8(csv).expect("utf-8");
    assert_eq!(text.lines().count(), 4);
    assert!(
        text.lines().nth(2).is_some_and(|l| l.contains(",error,")),
        "{text}"
    );
}

#[test]
fn a_table_gives_one_variant_per_row() {
    let cycle = Cycle::builtin("ece").expect("built in");
    let names = vec!["m".to_string(), "C_d".to_string()];
    let rows = vec![vec![1200.0, 0.3], vec![1500.0, 0.35]];
    let result = Sweep::new(compiled)
        .cycle(&cycle)
        .table(names, rows.clone())
        .options(opts("compiled", false))
        .build()
        .expect("builds")
        .run();
    assert_eq!(result.rows.len(), 2);
    assert_eq!(result.rows[1].params, rows[1]);
}

#[test]
fn bad_designs_are_build_errors() {
    let cycle = Cycle::builtin("ece").expect("built in");
    let build = |b: invsim_runtime::SweepBuilder| b.build().err().expect("an error");
    assert!(matches!(
        build(Sweep::new(compiled).grid("m", 1.0, 2.0, 2)),
        SweepError::NoCycles
    ));
    let e = build(Sweep::new(compiled).cycle(&cycle).grid("m", 1.0, 2.0, 0));
    assert!(matches!(e, SweepError::BadAxis { .. }), "{e}");
    let e = build(Sweep::new(compiled).cycle(&cycle).grid("mass", 1.0, 2.0, 2));
    assert!(e.to_string().contains("unknown parameter `mass`"), "{e}");
    let e = build(
        Sweep::new(compiled)
            .cycle(&cycle)
            .grid("m", 1.0, 2.0, 2)
            .grid("m", 1.0, 2.0, 2),
    );
    assert!(matches!(e, SweepError::DuplicateParameter { .. }), "{e}");
    let e = build(
        Sweep::new(compiled)
            .cycle(&cycle)
            .table(vec!["m".into()], vec![vec![1.0, 2.0]]),
    );
    assert!(
        matches!(
            e,
            SweepError::TableWidth {
                row: 1,
                got: 2,
                expected: 1
            }
        ),
        "{e}"
    );
}

#[test]
fn grid_axes_are_full_factorial_last_fastest() {
    let cycle = Cycle::builtin("ece").expect("built in");
    let sweep = Sweep::new(compiled)
        .cycle(&cycle)
        .grid("m", 1000.0, 2000.0, 3)
        .grid("C_d", 0.3, 0.4, 2)
        .build()
        .expect("builds");
    assert_eq!(sweep.parameters(), ["m", "C_d"]);
    let v = sweep.variants();
    assert_eq!(v.len(), 6);
    assert_eq!(v[0], [1000.0, 0.3]);
    assert_eq!(v[1], [1000.0, 0.4]);
    assert_eq!(v[5], [2000.0, 0.4]);
}

/// si_engine_grade, compiled, with a grade signal from a series (a hill over the cycles' first minutes) and
/// a constant auxiliary load.
fn graded(grade_peak: f64) -> (Box<dyn InverseModel>, SimulationOptions) {
    use invsim_runtime::signals::{SignalInput, SignalValue};
    let model = invsim_models::builtin("si_engine_grade").expect("si_engine_grade is built in");
    let mut o = opts("compiled", false);
    let time: Vec<f64> = (0..=120).map(|k| 10.0 * k as f64).collect();
    let values: Vec<f64> = time
        .iter()
        .map(|t| grade_peak * (std::f64::consts::PI * t / 600.0).sin().max(0.0))
        .collect();
    o.signals = vec![SignalInput {
        name: "grade".into(),
        value: SignalValue::Series {
            file: "hill.csv".into(),
            time,
            values,
        },
    }];
    (model, o)
}

#[test]
fn a_model_with_signals_shares_the_reference_and_its_rows_equal_single_runs() {
    let (model, o) = graded(0.04);
    assert!(!model.info().signals.is_empty());
    for threads in [1, 2] {
        let result = sweep_of(
            Sweep::new(|| invsim_models::builtin("si_engine_grade").expect("built in")),
            &o,
            threads,
        );
        assert_eq!(result.failed(), 0);
        assert_rows_equal_single_runs(
            &result,
            invsim_models::builtin("si_engine_grade").expect("built in"),
            &o,
        );
    }
    // The hill costs fuel: each variant burns more than on the flat road.
    let (_, flat) = graded(0.0);
    let hill = sweep_of(
        Sweep::new(|| invsim_models::builtin("si_engine_grade").expect("built in")),
        &o,
        1,
    );
    let level = sweep_of(
        Sweep::new(|| invsim_models::builtin("si_engine_grade").expect("built in")),
        &flat,
        1,
    );
    for (a, b) in hill.rows.iter().zip(&level.rows) {
        let (a, b) = (
            a.outcome.as_ref().expect("ran"),
            b.outcome.as_ref().expect("ran"),
        );
        assert!(a.integrals[0] > b.integrals[0], "{a:?} vs {b:?}");
    }
}

#[test]
fn a_reference_with_other_signal_sources_is_not_used() {
    use invsim_runtime::inverse::{reference, simulate_shared};
    let (model, hill) = graded(0.04);
    let (_, flat) = graded(0.0);
    let cycle = Cycle::builtin("ece").expect("built in");
    let shared = reference(model.as_ref(), &cycle, &hill).expect("the reference");
    // The run asks for the flat road: the hill's shared signals must not leak into it.
    let got = simulate_shared(model.as_ref(), &cycle, &shared, &flat, Vec::new()).expect("runs");
    let own = simulate(model.as_ref(), &cycle, &flat).expect("runs");
    assert_eq!(got.summary, own.summary);
    let with_hill =
        simulate_shared(model.as_ref(), &cycle, &shared, &hill, Vec::new()).expect("runs");
    assert_eq!(
        with_hill.summary,
        simulate(model.as_ref(), &cycle, &hill)
            .expect("runs")
            .summary
    );
    assert_ne!(with_hill.summary, got.summary);
}

/// The worker threads a sweep starts: rayon's choice for 0, else at most one per run and
/// `MAX_THREADS_PER_CORE` per core, at least one.
#[test]
fn worker_threads_are_bounded_by_runs_and_cores() {
    use invsim_runtime::sweep::{worker_threads, MAX_THREADS_PER_CORE};
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    assert_eq!(worker_threads(0, 100), 0);
    assert_eq!(worker_threads(5, 2), 2);
    assert_eq!(worker_threads(1, 100), 1);
    assert_eq!(worker_threads(3, 0), 1);
    assert_eq!(
        worker_threads(10_000, 1_000_000),
        MAX_THREADS_PER_CORE * cores
    );
    let sweep = Sweep::new(|| invsim_models::builtin("si_engine").expect("built in"))
        .cycle(&Cycle::builtin("ece").expect("built in"))
        .grid("m", 1000.0, 1600.0, 3)
        .threads(10_000)
        .build()
        .expect("sweep");
    assert_eq!(sweep.threads(), 3);
    assert_eq!(sweep.run().rows.len(), 3);
}
