//! Exact gradients of runs with modes (`crates/runtime/src/modes/gradient.rs`) against central finite
//! differences of the summary's fuel for every parameter of si_engine_5speed and the 6-speed Fusion on NEDC and
//! UDDS (each gear's ratio on its own), a map's grid values of the 6-speed Fusion, the compiled engine against
//! the interpreter, and `simulate --gradient` of a model with modes as a user meets it.

use crate::common;
use common::*;

use invsim_loader::EngineChoice;
use invsim_runtime::gradient::{resolve_modal, resolve_modal_with_maps, ModalWrt};
use invsim_runtime::modes::{
    simulate_modes_differentiated, ModalOptions, ModalPlant, ModalSummary, ZeroDynamicsReference,
};
use invsim_runtime::Cycle;

fn run(p: &ModalPlant, (cycle, dt): (&Cycle, f64), wrt: Option<&ModalWrt>) -> ModalSummary {
    let gears = p.gear_source(cycle, None).expect("a speed schedule");
    let opts = ModalOptions {
        keep_series: false,
        dt,
        ..ModalOptions::default()
    };
    let spec = p.spec(gears);
    simulate_modes_differentiated(
        &spec,
        cycle,
        &opts,
        &[],
        (ZeroDynamicsReference::default(), wrt),
    )
    .unwrap_or_else(|e| panic!("{} on {}: {e}", p.name(), cycle.name))
    .summary
}

fn fuel(s: &ModalSummary) -> f64 {
    s.totals.integrals["fuel"]
}

/// The mode sequence of a run, as its time per mode and its number of switches.
fn sequence(s: &ModalSummary) -> (Vec<f64>, usize) {
    let m = &s.modes;
    (m.per_mode.iter().map(|t| t.time_s).collect(), m.switches)
}

/// d fuel/dp_c by central differences with the step h = 1e-4·|p| and 2h: (D(h), the error estimate
/// |D(2h) − D(h)|/3 plus the fuel's own noise over h, whether every run kept the base run's mode sequence).
/// The noise is taken as 1e-12 of the fuel: a run is deterministic and smooth in p between decisions, the
/// zero dynamics' integrator takes the same steps for nearby p, and the differences of S_eps
/// (whose derivative is 1e-4 of the others') agree with the gradient to 1.4e-8 absolute at h = 1e-6, a fuel
/// change of 1.4e-14, 2e-14 of the fuel. The runs at ±2h, which only estimate the error, are made only where
/// D(h) does not already [`agrees`] with the exact `g` with the noise alone (the estimate only adds to it).
fn central(
    p: &mut ModalPlant,
    (wrt, c): (&ModalWrt, usize),
    cycle: (&Cycle, f64),
    base: &ModalSummary,
    g: f64,
) -> (f64, f64, bool) {
    let value = moved_value(p, wrt, c);
    let h = if value == 0.0 {
        1e-4
    } else {
        1e-4 * value.abs()
    };
    let mut same = true;
    let mut at = |v: f64| {
        p.set_as_moved(wrt, c, v).expect("settable");
        let s = run(p, cycle, None);
        same &= sequence(&s) == sequence(base);
        fuel(&s)
    };
    let d1 = (at(value + h) - at(value - h)) / (2.0 * h);
    let noise = 1e-12 * fuel(base).abs() / h;
    let err = if agrees(g, d1, noise) {
        noise
    } else {
        let d2 = (at(value + 2.0 * h) - at(value - 2.0 * h)) / (4.0 * h);
        (d2 - d1).abs() / 3.0 + noise
    };
    p.set_as_moved(wrt, c, value).expect("settable");
    (d1, err, same)
}

/// Whether the exact derivative `g` agrees with the central differences `d` ± `err`: within 1e-6 relative,
/// or within twice the differences' own error estimate.
fn agrees(g: f64, d: f64, err: f64) -> bool {
    (g - d).abs() <= (1e-6 * g.abs().max(d.abs())).max(2.0 * err)
}

/// Every parameter's d fuel/dp (each gearbox parameter per gear) within 1e-6 relative of the central
/// differences or twice their own error estimate; the compiled engine equal to the interpreter within 1e-12 of
/// the fuel for a relative change of the parameter (each engine's run takes its own steps, and the
/// sensitivities follow them: the two differ by the runs' rounding; 1e-7, the tolerance, while the gradient
/// integrated η again on steps of its own); d fuel_per_100km and the
/// headline's litres follow from d fuel by the summary's formulas. dt = 1 s: the gradient is that of the run
/// on its grid whatever the step, and the differences need 4 runs per parameter (a tenth of the time of
/// dt = 0.1 s).
fn check(model: &str) {
    check_on(model, (&["nedc", "udds"], 1.0), &["all"]);
}

/// [`check`] of the derivatives `names` on `cycles` at the output step dt.
fn check_on(model: &str, (cycles, dt): (&[&str], f64), names: &[&str]) {
    for cycle in cycles {
        let cycle = Cycle::builtin(cycle).expect("built in");
        let comp = modal_plant(model, EngineChoice::Compiled);
        let interp = modal_plant(model, EngineChoice::Interpreted);
        let wrt = modal_wrt(&comp, names);
        let (sc, si) = std::thread::scope(|scope| {
            let i = scope.spawn(|| run(&interp, (&cycle, dt), Some(&wrt)));
            (
                run(&comp, (&cycle, dt), Some(&wrt)),
                i.join().expect("the interpreted run"),
            )
        });
        let (gc, gi) = (
            &sc.gradient.as_ref().expect("a gradient").figures,
            &si.gradient.as_ref().expect("a gradient").figures,
        );
        let f0 = fuel(&sc);
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let indices: Vec<usize> = (0..wrt.params.len()).collect();
        std::thread::scope(|scope| {
            for chunk in indices.chunks(indices.len().div_ceil(threads).max(1)) {
                let (wrt, cycle, sc, gc, gi) = (&wrt, &cycle, &sc, gc, gi);
                scope.spawn(move || {
                    let mut p = modal_plant(model, EngineChoice::Compiled);
                    for &c in chunk {
                        let name = &wrt.params[c].name;
                        let g = gc["fuel"][name];
                        let value = moved_value(&p, wrt, c);
                        let scale = value.abs().max(f64::MIN_POSITIVE);
                        assert!(
                            (g - gi["fuel"][name]).abs() * scale <= 1e-12 * f0.max(g.abs() * scale),
                            "{model} {}: dfuel/d{name} compiled {g:e} interpreted {:e}",
                            cycle.name,
                            gi["fuel"][name]
                        );
                        let (d, err, same) = central(&mut p, (wrt, c), (cycle, dt), sc, g);
                        let ok = agrees(g, d, err);
                        eprintln!("{model} {} {name}: {g:e} fd {d:e} ± {err:e} same sequence {same}", cycle.name);
                        assert!(
                            ok,
                            "{model} {}: dfuel/d{name} = {g:e}, central differences {d:e} ± {err:e} (mode sequence kept: {same})",
                            cycle.name
                        );
                    }
                });
            }
        });
    }
}

#[test]
fn si_engine_5speed_against_finite_differences() {
    check("models/si_engine_5speed.toml");
}

#[test]
fn fusion_6speed_against_finite_differences() {
    check("models/ford_fusion_2012_dynamic_6speed.toml");
}

/// Re-entries whose transition moves the reference of a mode with internal dynamics: on UDDS at dt = 0.1 s the
/// 6-speed Fusion's brake and idle modes (the intake manifold's filling) start transitions from states that
/// the gear ratios move, so ∂q/∂(ξ, y^(r))·de(t) drives the manifold's sensitivities (without it d fuel/d i_g[3]
/// is 3·10⁻⁵ off, d fuel/d i_g[4] 1.7·10⁻⁵, d fuel/d S 1.6·10⁻⁶; at dt = 1 s none of it exceeds 3·10⁻⁷).
#[test]
fn fusion_6speed_transitions_into_internal_dynamics_against_finite_differences() {
    check_on(
        "models/ford_fusion_2012_dynamic_6speed.toml",
        (&["udds"], 0.1),
        &["i_g[3]", "i_g[4]", "S"],
    );
}

/// The zero dynamics' sensitivities follow the run's own steps (`modes/gradient_zd.rs`): DOP853's with the
/// 4-stage Gauss–Legendre method from dt = 0.05 s (the tests above), DOPRI5's with the 2-stage one below it.
/// At dt = 0.02 s on NEDC si_engine_5speed's derivatives by the intake manifold's volume (V_i, which acts
/// through η alone), the mass and a gear's ratio against central differences; and the differentiated run is
/// the plain run bit for bit at dt = 1, 0.1 and 0.02 s: its integrator keeps its continuous extension for the
/// gradient and takes the same steps, and where the plain run integrates the affine manifold modes by the
/// variation of constants (`ode/affine.rs`, dt ≥ 0.05 s) so does the differentiated one, with DOP853 beside it
/// for the steps the sensitivities follow.
#[test]
fn the_sensitivities_follow_the_run_s_steps_at_both_integrators() {
    let model = "models/si_engine_5speed.toml";
    check_on(model, (&["nedc"], 0.02), &["V_i", "m", "i_g[2]"]);
    let cycle = Cycle::builtin("nedc").expect("built in");
    let p = modal_plant(model, EngineChoice::Compiled);
    let wrt = modal_wrt(&p, &["V_i"]);
    for dt in [1.0, 0.1, 0.02] {
        let (plain, differentiated) = (
            run(&p, (&cycle, dt), None),
            run(&p, (&cycle, dt), Some(&wrt)),
        );
        assert_eq!(
            plain.totals.integrals, differentiated.totals.integrals,
            "dt {dt}"
        );
        assert_eq!(sequence(&plain), sequence(&differentiated), "dt {dt}");
        assert!(plain.gradient.is_none() && differentiated.gradient.is_some());
    }
}

/// A still interval that repeats the last one bit for bit takes its remembered result in a plain run
/// (`modes/still.rs`), while a differentiated run, which logs every step, integrates each: both give the same
/// state, input and mode at every sample, bit for bit, on the UDDS (17 stops) with DOP853 (dt 0.1 s) and
/// DOPRI5 (dt 0.02 s), for si_engine_5speed and the 6-speed Fusion.
#[test]
fn a_remembered_still_interval_is_the_integrated_one_bit_for_bit() {
    let cycle = Cycle::builtin("udds").expect("built in");
    for model in [
        "models/si_engine_5speed.toml",
        "models/ford_fusion_2012_dynamic_6speed.toml",
    ] {
        let p = modal_plant(model, EngineChoice::Compiled);
        let wrt = modal_wrt(&p, &["V_i"]);
        for dt in [0.1, 0.02] {
            let gears = p.gear_source(&cycle, None).expect("a speed schedule");
            let spec = p.spec(gears);
            let opts = ModalOptions {
                dt,
                ..ModalOptions::default()
            };
            let zd = ZeroDynamicsReference::default();
            let runs = [None, Some(&wrt)].map(|w| {
                simulate_modes_differentiated(&spec, &cycle, &opts, &[], (zd, w)).expect("runs")
            });
            let [plain, differentiated] = &runs;
            let bits = |v: &[Vec<f64>]| -> Vec<Vec<u64>> {
                v.iter()
                    .map(|c| c.iter().map(|x| x.to_bits()).collect())
                    .collect()
            };
            assert_eq!(plain.mode, differentiated.mode, "{model} dt {dt}");
            for (a, b) in [
                (plain.states.columns(), differentiated.states.columns()),
                (plain.x_end.columns(), differentiated.x_end.columns()),
                (plain.data.clone(), differentiated.data.clone()),
            ] {
                assert_eq!(bits(&a), bits(&b), "{model} dt {dt}");
            }
        }
    }
}

/// A map's grid values in a run with modes: the 6-speed Fusion's fc_map (FASTSim's efficiency curve, plain
/// linear, read by the drive modes' comparison output fuel_fastsim_map) on NEDC. d fuel_fastsim_map/d fc_map[4]
/// (a load the run drives at) against the central difference of the map's value in every mode (the figure is
/// linear in it: the difference is exact to rounding); fc_map[12] (full load, never reached) and the engine's
/// own fuel (which does not read the map) have the derivative 0 exactly; the compiled modes equal the
/// interpreted ones within 1e-12 of the figure.
#[test]
fn fusion_6speed_map_values_against_finite_differences() {
    let model = "models/ford_fusion_2012_dynamic_6speed.toml";
    let cycle = Cycle::builtin("nedc").expect("built in");
    let names: Vec<String> = vec!["fc_map[4]".into(), "fc_map[12]".into()];
    let wrt_of = |p: &ModalPlant| {
        let parameters = p.parameters();
        let (grid, params) =
            resolve_modal_with_maps((&parameters, p.gear_parameters()), &p.maps(), &names)
                .expect("grid values");
        let modes = p.metas().map(|m| (m.gear, &m.own_parameters[..]));
        ModalWrt::new(params, &parameters, modes).with_grid(parameters.len(), &grid, p.mode_maps())
    };
    let (mut comp, interp) = (
        modal_plant(model, EngineChoice::Compiled),
        modal_plant(model, EngineChoice::Interpreted),
    );
    let (gc, gi) = (
        run(&comp, (&cycle, 1.0), Some(&wrt_of(&comp)))
            .gradient
            .expect("a gradient")
            .figures,
        run(&interp, (&cycle, 1.0), Some(&wrt_of(&interp)))
            .gradient
            .expect("a gradient")
            .figures,
    );
    let f = "fuel_fastsim_map";
    let map = comp.maps()[0].clone();
    assert_eq!(map.name(), "fc_map");
    let mut at = |v: f64| {
        let mut values = map.values().to_vec();
        values[3] = v;
        comp.set_map("fc_map", (map.x(), None, &values))
            .expect("the same grid");
        run(&comp, (&cycle, 1.0), None).totals.integrals[f]
    };
    let (v, h) = (map.values()[3], 1e-4 * map.values()[3]);
    let d = (at(v + h) - at(v - h)) / (2.0 * h);
    let g = gc[f]["fc_map[4]"];
    assert!(
        g.abs() > 0.1 && (g - d).abs() <= 1e-6 * d.abs(),
        "{g:e} vs {d:e}"
    );
    assert!(
        (g - gi[f]["fc_map[4]"]).abs() * v <= 1e-12 * at(v),
        "{g:e} vs {:e}",
        gi[f]["fc_map[4]"]
    );
    assert_eq!((gc[f]["fc_map[12]"], gc["fuel"]["fc_map[4]"]), (0.0, 0.0));
}

/// `invsim simulate --gradient` of a model with modes: the summary's block with a row per figure and the
/// derivatives asked for (a gear's ratio by its per-gear name), the text's table, and the numbers those of the
/// library's run (the same compiled modes) bit for bit.
#[test]
fn simulate_of_a_model_with_modes_as_a_user_meets_it() {
    let json = tmp("gradient-modes.json");
    let model = "models/si_engine_5speed.toml";
    let o = invsim(&[
        "simulate",
        model,
        "--cycle",
        "ece",
        "--dt",
        "1",
        "--gradient",
        "m,i_g[3],i_f",
        "--summary-json",
        json.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("gradient (d figure / d parameter):"),
        "{text}"
    );
    assert!(text.contains("  i_g[3]"), "{text}");
    let s = json_file(&json);
    let g = &s["gradient"];
    for f in ["fuel", "fuel_volume_per_100km", "headline.l_per_100km"] {
        let row = g[f].as_object().unwrap_or_else(|| panic!("a row {f}"));
        assert_eq!(row.len(), 3, "{f}");
    }
    let p = modal_plant(model, EngineChoice::Compiled);
    let parameters = p.parameters();
    let names: Vec<String> = ["m", "i_g[3]", "i_f"].map(String::from).to_vec();
    let params = resolve_modal(&parameters, p.gear_parameters(), &names).expect("known");
    let wrt = ModalWrt::new(
        params,
        &parameters,
        p.metas().map(|m| (m.gear, &m.own_parameters[..])),
    );
    let lib = run(
        &p,
        (&Cycle::builtin("ece").expect("built in"), 1.0),
        Some(&wrt),
    );
    let lib = &lib.gradient.expect("a gradient").figures;
    for name in &names {
        let want = lib["fuel"][name];
        assert!(want != 0.0 && want.is_finite(), "dfuel/d{name} = {want}");
        assert_eq!(g["fuel"][name].as_f64(), Some(want), "dfuel/d{name}");
    }
}

/// `--set 'i_g[3]=…'` sets the third gear's ratio alone (as `--gradient` names it): the central difference of
/// two such runs (h = 1e-4 of the ratio) equals d fuel/d i_g[3] within 1e-6 relative; `--set i_g=…` is still
/// refused with the per-gear names.
#[test]
fn set_names_one_gear_s_ratio_as_the_gradient_does() {
    let model = "models/si_engine_5speed.toml";
    let fuel_at = |tag: &str, extra: &[&str]| {
        let mut args = vec![model, "--cycle", "ece"];
        args.extend_from_slice(extra);
        simulate_summary(&args, &format!("gradient-modes-set-{tag}")).0
    };
    let base = fuel_at("base", &["--gradient", "i_g[3]"]);
    let g = base["gradient"]["fuel"]["i_g[3]"]
        .as_f64()
        .expect("a number");
    let (v, h) = (1.35, 1.35e-4);
    let plus = fuel_at("plus", &["--set", &format!("i_g[3]={}", v + h)]);
    let minus = fuel_at("minus", &["--set", &format!("i_g[3]={}", v - h)]);
    let f = |s: &serde_json::Value| s["integrals"]["fuel"].as_f64().expect("a number");
    let d = (f(&plus) - f(&minus)) / (2.0 * h);
    assert!((g - d).abs() <= 1e-6 * d.abs(), "{g:e} vs {d:e}");
    let o = invsim(&["simulate", model, "--cycle", "ece", "--set", "i_g=3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("i_g[1] … i_g[5]"), "{}", stderr(&o));
}
