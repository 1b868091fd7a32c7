//! Benchmark: the cost of exact gradients (`--gradient`) against the same run without them, compiled:
//! si_engine (r = n: pointwise chain rule) on NEDC at dt = 0.01 s with 10 parameters, and driveline (stiff
//! zero dynamics: η by the run's Dormand–Prince steps, the sensitivities by Gauss–Legendre over each step) on
//! NEDC at dt = 0.1 s with every parameter; runs with modes: si_engine_5speed (the brake and idle modes'
//! manifold sensitivities) on UDDS at dt = 1 s and 0.1 s with 10 parameters, and hev_p2's charge-sustaining
//! ECMS run (the search for s included) on UDDS at dt = 1 s with every parameter. Issue target: 10 parameters
//! within 3× of the plain run.

use criterion::{criterion_group, criterion_main, Criterion};
use invsim_loader::{load, EngineChoice, Loaded};
use invsim_runtime::gradient::{resolve_modal, ModalWrt};
use invsim_runtime::modes::{
    simulate_hybrid_differentiated, simulate_modes_differentiated, ModalOptions, ModalPlant,
    StrategyOptions, ZeroDynamicsReference,
};
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::hint::black_box;
use std::time::Duration;

/// si_engine's 10 parameters of the vehicle, the driveline and the engine.
const SI_ENGINE_TEN: [&str; 10] = [
    "m", "C_d", "A_f", "c_r", "eta_trm", "J_e", "V_d", "eta_th", "i_t", "r_w",
];

fn options(dt: f64, gradient: Option<Vec<String>>) -> SimulationOptions {
    SimulationOptions::builder()
        .dt(dt)
        .keep_series(false)
        .gradient(gradient)
        .build()
        .expect("valid options")
}

fn gradient(c: &mut Criterion) {
    let cycle = Cycle::builtin("nedc").expect("nedc");
    let ten: Vec<String> = SI_ENGINE_TEN.iter().map(|s| s.to_string()).collect();
    let cases = [
        ("si_engine dt=0.01", 0.01, Some(ten)),
        ("driveline dt=0.1", 0.1, Some(vec!["all".to_string()])),
    ];
    let mut group = c.benchmark_group("gradient NEDC, compiled");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    for (name, dt, names) in cases {
        let model_name = name.split(' ').next().expect("a model name");
        let model = invsim_models::builtin(model_name).expect("built in");
        for (label, wanted) in [("plain", None), ("with gradient", names)] {
            let opts = options(dt, wanted);
            group.bench_function(format!("{name} {label}"), |b| {
                b.iter(|| {
                    black_box(
                        simulate(model.as_ref(), &cycle, &opts)
                            .unwrap()
                            .summary
                            .samples,
                    )
                })
            });
        }
    }
    group.finish();
}

/// si_engine_5speed's 10 parameters, a gear's ratio and the final drive among them.
const FIVE_SPEED_TEN: [&str; 10] = [
    "m", "C_d", "A_f", "c_r", "eta_trm", "J_e", "V_d", "r_w", "i_f", "i_g[5]",
];

fn modal_plant(model: &str) -> ModalPlant {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(model);
    match load(&path, EngineChoice::Compiled).expect("loads") {
        Loaded::Modal(m) => m.plant,
        Loaded::Single(_) => panic!("{model} has modes"),
    }
}

fn modal_wrt(p: &ModalPlant, names: &[&str]) -> ModalWrt {
    let parameters = p.parameters();
    let names: Vec<String> = names.iter().map(|n| n.to_string()).collect();
    let params = resolve_modal(&parameters, p.gear_parameters(), &names).expect("known");
    ModalWrt::new(
        params,
        &parameters,
        p.metas().map(|m| (m.gear, &m.own_parameters[..])),
    )
}

fn modal_gradient(c: &mut Criterion) {
    let cycle = Cycle::builtin("udds").expect("udds");
    let mut group = c.benchmark_group("gradient UDDS with modes, compiled");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    let five = modal_plant("models/si_engine_5speed.toml");
    let wrt = modal_wrt(&five, &FIVE_SPEED_TEN);
    let spec = five.spec(five.gear_source(&cycle, None).expect("a schedule"));
    for dt in [1.0, 0.1] {
        let opts = ModalOptions {
            dt,
            keep_series: false,
            ..ModalOptions::default()
        };
        for (label, wanted) in [("plain", None), ("with gradient", Some(&wrt))] {
            group.bench_function(format!("si_engine_5speed dt={dt} {label}"), |b| {
                b.iter(|| {
                    let how = (ZeroDynamicsReference::default(), wanted);
                    black_box(
                        simulate_modes_differentiated(&spec, &cycle, &opts, &[], how).unwrap(),
                    )
                    .summary
                    .run
                    .distance_m
                })
            });
        }
    }
    let hev = modal_plant("models/hev_p2.toml");
    let all = modal_wrt(&hev, &["all"]);
    let spec = hev.spec(hev.gear_source(&cycle, None).expect("a schedule"));
    let opts = ModalOptions {
        dt: 1.0,
        keep_series: false,
        ..ModalOptions::default()
    };
    let strategy = StrategyOptions::default();
    for (label, wanted) in [("plain", None), ("with gradient", Some(&all))] {
        group.bench_function(format!("hev_p2 ECMS dt=1 {label}"), |b| {
            b.iter(|| {
                let (ecms, signals) = ((&strategy, &[][..]), (&[][..], wanted));
                black_box(
                    simulate_hybrid_differentiated(
                        &spec,
                        hev.hybrid(),
                        &cycle,
                        &opts,
                        ecms,
                        signals,
                    )
                    .unwrap(),
                )
                .summary
                .run
                .distance_m
            })
        });
    }
    group.finish();
}

criterion_group!(benches, gradient, modal_gradient);
criterion_main!(benches);
