//! `Plant::simulate_keeping` (what the Python package's `Model` runs through): a run that reads the smoothed
//! cycle kept from the previous run gives the figures of a run on its own, bit for bit, for models without
//! modes (r = n, a stable inversion of unstable internal dynamics) and with modes, when the cycle changes in
//! between, and with other options (`keep_series`) or another parameter value.

use crate::common;
use common::*;

use invsim_loader::EngineChoice;
use invsim_runtime::{Cycle, Plant, RunKeep, RunResult, SimulationOptions};

/// The summary of `result` as JSON (every figure the user sees, the provenance left out: it names no run).
fn figures(result: &RunResult) -> serde_json::Value {
    let mut v = match result {
        RunResult::Single(r) => serde_json::to_value(&r.summary),
        RunResult::Modal(r, _) => serde_json::to_value(&r.summary),
        _ => panic!("an inverse run"),
    }
    .expect("a summary");
    v.as_object_mut().expect("an object").remove("provenance");
    v
}

fn plant(model: &str) -> Plant {
    invsim_loader::load(&root().join(model), EngineChoice::Compiled)
        .unwrap_or_else(|e| panic!("{model}: {e}"))
        .into_plant()
}

#[test]
fn a_run_through_the_keep_is_a_run_on_its_own() {
    let (udds, nedc) = (
        Cycle::builtin("udds").expect("built in"),
        Cycle::builtin("nedc").expect("built in"),
    );
    // r = n; unstable internal dynamics solved non-causally; two with modes.
    for (model, dt, (name, value)) in [
        ("models/si_engine.toml", 0.1, ("m", 1600.0)),
        ("models/diesel_gasflow.toml", 1.0, ("V_im", 0.025)),
        ("models/si_engine_5speed.toml", 1.0, ("m", 1600.0)),
        (
            "models/ford_fusion_2012_dynamic_6speed.toml",
            0.1,
            ("m", 1600.0),
        ),
    ] {
        let mut p = plant(model);
        let opts = |keep_series: bool| {
            SimulationOptions::builder()
                .dt(dt)
                .keep_series(keep_series)
                .build()
                .expect("valid")
        };
        let keep = RunKeep::new();
        let alone = |p: &Plant, cycle: &Cycle, o: &SimulationOptions| {
            figures(&p.simulate(cycle, None, o).expect("runs"))
        };
        let kept = |p: &Plant, cycle: &Cycle, o: &SimulationOptions| {
            figures(
                &p.simulate_keeping(cycle, None, o, Some(&keep))
                    .expect("runs"),
            )
        };
        // The first run makes what the second reads; the cycle changes and changes back; the options differ
        // in what the kept data do not depend on.
        for (cycle, o) in [
            (&udds, opts(true)),
            (&udds, opts(false)),
            (&nedc, opts(false)),
            (&udds, opts(true)),
        ] {
            assert_eq!(
                kept(&p, cycle, &o),
                alone(&p, cycle, &o),
                "{model} {}",
                cycle.name
            );
        }
        // Another parameter value reads the same kept cycle and gives its own figures.
        p.set_param(name, value).expect("a parameter");
        let (a, b) = (
            kept(&p, &udds, &opts(false)),
            alone(&p, &udds, &opts(false)),
        );
        assert_eq!(a, b, "{model} with {name} = {value}");
        assert_ne!(
            a,
            kept(&plant(model), &udds, &opts(false)),
            "{model}: {name} moves the run"
        );
    }
}
