//! `models/ford_fusion_2012_dynamic_6speed.toml` (FASTSim's Fusion with si_engine's intake-manifold dynamics,
//! its 6-speed automatic, idle, fuel cut-off and the friction brake): on the UDDS, HWFET and WLTC class 3b
//! every mode satisfies its own equations at every sample (v' = y_d' and, with r = 2, v'' = ∂f_v/∂x · f by
//! the chain rule, the built-in cycles flat: the grade and its derivatives 0), the replay through the mode
//! sequence tracks, every gear is used and the fuel is FASTSim's within the bounds docs/vehicles.md explains.

use invsim_model_api::InverseModel;
use invsim_runtime::modes::{simulate_modes, ModalOptions, Switching};
use invsim_runtime::Cycle;

use crate::modes::support::{load_repo, partial, spec, speed_schedule, Loaded};

fn fusion() -> Loaded {
    load_repo("models/ford_fusion_2012_dynamic_6speed.toml")
}

#[test]
fn fusion_6speed_satisfies_every_mode_tracks_and_burns_plausible_fuel() {
    let l = fusion();
    let s = spec(&l, speed_schedule(&l));
    // FASTSim's fuel for the same vehicle (docs/vehicles.md, section 3), kg.
    for (name, fastsim) in [("udds", 0.609), ("hwfet", 0.613), ("wltc3b", 1.156)] {
        let cycle = Cycle::builtin(name).expect("built-in");
        let opts = ModalOptions {
            lookahead: 5.0,
            dt: 0.1,
            switching: Switching::Reentry,
            transition_time: None,
            verify: true,
            keep_series: true,
        };
        let res = simulate_modes(&s, &cycle, &opts).expect("the run succeeds");
        let (mut worst1, mut worst2) = (0.0f64, 0.0f64);
        for k in 0..res.free.len() {
            let model = &l.interps[res.mode[k]];
            let w = vec![0.0; model.info().n_w()];
            let (x, u, y) = (&res.states[k], res.free[k], &res.yref[k]);
            let mut dx = [0.0; 2];
            model.rhs(x, &w, u, &mut dx);
            worst1 = worst1.max((dx[0] - y[1]).abs() / y[1].abs().max(1.0));
            if model.info().relative_degree == 2 {
                let fv = |z: &[f64]| {
                    let mut d = [0.0; 2];
                    model.rhs(z, &w, u, &mut d);
                    d[0]
                };
                let ydd = partial(&fv, x, 0) * dx[0] + partial(&fv, x, 1) * dx[1];
                worst2 = worst2.max((ydd - y[2]).abs() / y[2].abs().max(1.0));
            }
        }
        assert!(worst1 < 1e-8, "{name}: v' − y_d' up to {worst1:e} relative");
        assert!(
            worst2 < 1e-8,
            "{name}: v'' − y_d'' up to {worst2:e} relative"
        );
        let err = res.summary.max_abs_tracking_error.expect("verified");
        assert!(
            err < 1e-3 * cycle.max_speed(),
            "{name}: replay error {err} m/s"
        );
        let total: f64 = res.summary.modes.per_mode.iter().map(|m| m.time_s).sum();
        assert!((total - cycle.duration()).abs() < 1e-9);
        let gears = res.column("gear").expect("gear");
        let top = gears.iter().fold(0.0f64, |a, g| a.max(*g));
        assert!(name == "udds" || top == 6.0, "{name}: top gear {top}");
        let fuel = res.summary.totals.integrals["fuel"];
        let map = res.summary.totals.integrals["fuel_fastsim_map"];
        eprintln!("{name}: fuel {fuel:.3} kg, FASTSim's curve on this engine {map:.3} kg, FASTSim {fastsim} kg");
        // The mean-value engine burns more than FASTSim's efficiency curve (docs/vehicles.md): 10–35 %; the
        // curve applied to this engine's brake power is FASTSim's figure within 10 %.
        assert!(
            (1.1..1.35).contains(&(fuel / fastsim)),
            "{name}: {fuel} kg vs FASTSim {fastsim} kg"
        );
        assert!(
            (map / fastsim - 1.0).abs() < 0.1,
            "{name}: map {map} kg vs FASTSim {fastsim} kg"
        );
    }
}
