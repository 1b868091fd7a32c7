//! Exact parameter gradients (`SimulationOptions::gradient`, `invsim simulate --gradient`) against independent
//! references: central finite differences of the summary's own figures for every parameter of the built-in
//! models on NEDC and UDDS (the step chosen per parameter, the differences' error estimated from two steps),
//! causal, r = n and stable (non-causal) runs alike; the compiled engine against the interpreter; a linear
//! known-answer model whose fuel integral is a closed form of its parameters; and an unknown parameter refused
//! by name.

use invsim_inversion::{derive_file, Interpreter};
use invsim_model_api::InverseModel;
use invsim_runtime::headline::HeadlineFigures;
use invsim_runtime::{simulate, Cycle, SimulationOptions, Summary};
use std::collections::BTreeMap;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

pub(crate) fn interpreted(path: &str) -> Box<dyn InverseModel> {
    let path = root().join(path);
    let d = derive_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Box::new(Interpreter::new(&d).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

/// The compiled model `name`: a built-in one, or one of this crate's test models (`tests/models`).
pub(crate) fn compiled(name: &str) -> Box<dyn InverseModel> {
    invsim_models::builtin(name)
        .or_else(|| invsim_tests::extra::builtin(name))
        .unwrap_or_else(|| panic!("{name} is compiled"))
}

/// The model file of [`compiled`]'s `name`.
pub(crate) fn model_path(name: &str) -> String {
    let built_in = format!("models/{name}.toml");
    if root().join(&built_in).exists() {
        built_in
    } else {
        format!("tests/models/{name}.toml")
    }
}

fn opts(gradient: bool) -> SimulationOptions {
    opts_for(gradient.then(|| vec!["all".to_string()]))
}

/// Options of a run with the gradient with respect to `names` (none: no gradient).
pub(crate) fn opts_for(names: Option<Vec<String>>) -> SimulationOptions {
    SimulationOptions::builder()
        .keep_series(false)
        .gradient(names)
        .build()
        .expect("valid options")
}

fn run(model: &dyn InverseModel, cycle: &Cycle, gradient: bool) -> Summary {
    run_for(model, cycle, gradient.then(|| vec!["all".to_string()]))
}

/// A run's summary with the gradient with respect to `names`.
fn run_for(model: &dyn InverseModel, cycle: &Cycle, names: Option<Vec<String>>) -> Summary {
    simulate(model, cycle, &opts_for(names))
        .unwrap_or_else(|e| panic!("{} on {}: {e}", model.info().name, cycle.name))
        .summary
}

/// The figure the gradient block calls `name`, as the summary prints it.
pub(crate) fn figure(s: &Summary, name: &str) -> f64 {
    if let Some(field) = name.strip_prefix("headline.") {
        let h = s.headline.as_ref().expect("a headline");
        let v = match &h.figures {
            HeadlineFigures::Fuel(f) => match field {
                "litres" => Some(f.litres),
                "kg" => Some(f.kg),
                "co2_kg" => Some(f.co2_kg),
                "l_per_100km" => f.l_per_100km,
                "mpg_us" => f.mpg_us,
                "mpg_uk" => f.mpg_uk,
                "co2_g_per_km" => f.co2_g_per_km,
                _ => None,
            },
            HeadlineFigures::Electricity(e) => match field {
                "kwh" => Some(e.kwh),
                "kwh_per_100km" => e.kwh_per_100km,
                "wh_per_km" => e.wh_per_km,
                "wh_per_mi" => e.wh_per_mi,
                "mpgge" => e.mpgge,
                _ => None,
            },
        };
        return v.unwrap_or_else(|| panic!("no headline figure {name}"));
    }
    if let Some(output) = name.strip_suffix("_per_100km") {
        if let Some(v) = s.totals.integrals_per_100km.get(output) {
            return *v;
        }
    }
    s.totals.integrals[name]
}

pub(crate) type Block = BTreeMap<String, BTreeMap<String, f64>>;

pub(crate) fn block(s: &Summary) -> Block {
    s.gradient
        .as_ref()
        .expect("a gradient block")
        .figures
        .clone()
}

/// Every figure of the summary has its row: the integrals, their per-100-km figures, the headline's.
fn check_rows(s: &Summary, g: &Block, params: usize) {
    for name in s.totals.integrals.keys() {
        assert_eq!(g[name].len(), params, "{name}");
    }
    for name in s.totals.integrals_per_100km.keys() {
        assert!(g.contains_key(&format!("{name}_per_100km")), "{name}");
    }
    if s.headline.is_some() {
        assert!(g.keys().any(|k| k.starts_with("headline.")));
    }
}

/// Whether the exact derivative `g` agrees with the central differences `d` ± `err`: within 1e-6 relative, or
/// within twice the differences' own error estimate.
pub(crate) fn agrees(g: f64, d: f64, err: f64) -> bool {
    (g - d).abs() <= (1e-6 * g.abs().max(d.abs())).max(2.0 * err)
}

/// d figure/dp by central differences with step h and 2h: (D(h), an estimate of its error from
/// D(2h) − D(h) = 3·c·h² + O(h⁴) (the truncation error of D(h) is c·h²) and from the figure's rounding);
/// `exact` the derivatives they are compared with, by name (see [`central_along`]).
fn central(
    model: &mut dyn InverseModel,
    cycle: &Cycle,
    (k, h, noise): (usize, f64, f64),
    (names, exact): (&[&String], &[f64]),
) -> Vec<(f64, f64)> {
    central_with(model, (cycle, &opts(false)), (k, h, noise), (names, exact))
}

/// [`central`] of runs with the options `o`.
fn central_with(
    model: &mut dyn InverseModel,
    (cycle, o): (&Cycle, &SimulationOptions),
    (k, h, noise): (usize, f64, f64),
    (names, exact): (&[&String], &[f64]),
) -> Vec<(f64, f64)> {
    let p0 = model.params()[k];
    let name = model.info().parameters[k].clone();
    let mut set = |m: &mut dyn InverseModel, offset: f64| {
        m.set_param(&name, p0 + offset).expect("settable");
    };
    central_along(model, (cycle, o), &mut set, (h, noise), (names, exact))
}

/// [`central`] along any change of the model: `set(model, offset)` moves the quantity differentiated by
/// `offset` from its value (and back with 0). The runs at ±2h, which only estimate the error, are made only
/// where D(h) does not already [`agrees`] with `exact` for every name with the rounding part of the error
/// alone (the estimate only adds to it, so it cannot change a verdict reached without it).
pub(crate) fn central_along(
    model: &mut dyn InverseModel,
    (cycle, o): (&Cycle, &SimulationOptions),
    set: &mut dyn FnMut(&mut dyn InverseModel, f64),
    (h, noise): (f64, f64),
    (names, exact): (&[&String], &[f64]),
) -> Vec<(f64, f64)> {
    let mut at = |v: f64| {
        set(&mut *model, v);
        let s = simulate(&*model, cycle, o).expect("runs").summary;
        names.iter().map(|n| figure(&s, n)).collect::<Vec<f64>>()
    };
    let (p1, m1) = (at(h), at(-h));
    let d1: Vec<f64> = (0..names.len())
        .map(|i| (p1[i] - m1[i]) / (2.0 * h))
        .collect();
    // The figures' own noise (rounding, or the integrator's error), divided by the step.
    let rounding: Vec<f64> = (0..names.len())
        .map(|i| noise * p1[i].abs().max(m1[i].abs()) / h)
        .collect();
    let settled = (0..names.len()).all(|i| agrees(exact[i], d1[i], rounding[i]));
    let estimate = (!settled).then(|| (at(2.0 * h), at(-2.0 * h)));
    set(&mut *model, 0.0);
    (0..names.len())
        .map(|i| match &estimate {
            None => (d1[i], rounding[i]),
            Some((p2, m2)) => {
                let d2 = (p2[i] - m2[i]) / (4.0 * h);
                (d1[i], (d2 - d1[i]).abs() / 3.0 + rounding[i])
            }
        })
        .collect()
}

/// The step for parameter value p: `rel`·|p| (`rel` for p = 0).
fn step(p: f64, rel: f64) -> f64 {
    if p == 0.0 {
        rel
    } else {
        rel * p.abs()
    }
}

/// The relative step and the figures' relative noise for a run: r = n runs are sums of rounded terms (noise
/// ~1e-12 relative) but have kinks (fuel = max(m_at, 0)/… at standstill samples, where the input is 0 to
/// rounding), so a small step 1e-6 keeps the differences off them; causal runs carry the integrator's error
/// (rtol 1e-10, noise taken as 1e-9 relative), so a larger step 1e-3 keeps the noise/h term near 1e-6; stable
/// runs are sums of rounded terms too, with η from Newton's method converged far below its stopping test
/// (diesel_gasflow_flows' figures repeat to ~1e-15 relative; noise taken as 1e-12) and without kinks, so the
/// step 1e-4 keeps the noise/h term near 1e-8 and the truncation error (~h², estimated) as small.
pub(crate) fn fd_plan(s: &Summary) -> (f64, f64) {
    match s.inversion.as_str() {
        "causal" => (1e-3, 1e-9),
        "stable" => (1e-4, 1e-12),
        _ => (1e-6, 1e-12),
    }
}

/// Every figure's gradient with respect to every parameter of `name` on NEDC and UDDS: within 1e-6 relative of
/// the central differences, or within twice their own error estimate; the compiled engine equal to the
/// interpreter within 1e-12 of each figure (1e-7 for a causal run, see below) (compared as p·d figure/dp, the figure's change for a relative
/// change of p).
///
/// `skip`: figures that are only piecewise smooth in every parameter and so have no finite-difference
/// reference (a plain bilinear map's derivatives are piecewise constant, discontinuous on its grid lines).
fn check_model(name: &str, skip: &[&str]) {
    let path = model_path(name);
    // The two cycles side by side: a cycle's single-threaded phases (its gradient run) leave a core to the other.
    std::thread::scope(|scope| {
        for cycle in ["nedc", "udds"] {
            let path = &path;
            scope.spawn(move || {
                let cycle = Cycle::builtin(cycle).expect("built in");
                let comp = compiled(name);
                // Both engines' runs side by side (a causal run with its sensitivities takes seconds).
                let (si, sc) = std::thread::scope(|scope| {
                    let i = scope.spawn(|| run(interpreted(path).as_ref(), &cycle, true));
                    let c = run(comp.as_ref(), &cycle, true);
                    (i.join().expect("the interpreted run"), c)
                });
                let gc = block(&sc);
                let info = comp.info().clone();
                check_rows(&sc, &gc, info.parameters.len());
                // r = n and stable (diesel_gasflow_flows: 4e-15): within 1e-12 of the figure; causal: the figures
                // themselves differ between the engines at the adaptive integrator's tolerance (driveline's E_e by
                // 3e-10 relative) and so do the integrated sensitivities (p·dE_e/di_t by 6e-10 of E_e on NEDC):
                // held to 1e-7 of the figure.
                let equal = if sc.inversion == "causal" {
                    1e-7
                } else {
                    1e-12
                };
                let values = comp.params().to_vec();
                let gi = block(&si);
                for (f, row) in gc.iter().filter(|(f, _)| !skip.contains(&f.as_str())) {
                    let scale = figure(&sc, f).abs();
                    for (p, &v) in row {
                        let k = info
                            .parameters
                            .iter()
                            .position(|q| q == p)
                            .expect("a parameter");
                        let diff = (v - gi[f][p]).abs() * values[k].abs().max(f64::MIN_POSITIVE);
                        let size = (v.abs() * values[k].abs()).max(scale);
                        assert!(
                            diff <= equal * size,
                            "{name} {}: d{f}/d{p} compiled {v:e} interpreted {:e}",
                            cycle.name,
                            gi[f][p]
                        );
                    }
                }
                let (rel, noise) = fd_plan(&sc);
                let names: Vec<&String> = gc.keys().filter(|f| !skip.contains(&f.as_str())).collect();
                // The parameters' differences on every core (each thread with its own model): driveline's stiff zero
                // dynamics make each of its runs about a second.
                let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
                let indices: Vec<usize> = (0..info.parameters.len()).collect();
                std::thread::scope(|scope| {
                    for chunk in indices.chunks(indices.len().div_ceil(threads).max(1)) {
                        let (names, values, info, gc, cycle) = (&names, &values, &info, &gc, &cycle);
                        scope.spawn(move || {
                            let mut model = compiled(name);
                            for &k in chunk {
                                let p = &info.parameters[k];
                                let exact: Vec<f64> = names.iter().map(|f| gc[*f][p]).collect();
                                let fd = central(
                                    model.as_mut(),
                                    cycle,
                                    (k, step(values[k], rel), noise),
                                    (names, &exact),
                                );
                                for (f, (d, err)) in names.iter().zip(fd) {
                                    let g = gc[*f][p];
                                    assert!(
                                        agrees(g, d, err),
                                        "{name} {}: d{f}/d{p} = {g:e}, central differences {d:e} ± {err:e}",
                                        cycle.name
                                    );
                                }
                            }
                        });
                    }
                });
            });
        }
    });
}

#[test]
fn si_engine_against_finite_differences() {
    check_model("si_engine", &[]);
}

/// driveline's zero dynamics are stiff (an eigenvalue near −300/s, which the explicit integrator follows at
/// rtol 1e-10 with steps of about 10 ms): every parameter on the whole of NEDC and UDDS all the same (its runs
/// share the two cores).
#[test]
fn driveline_against_finite_differences() {
    check_model("driveline", &[]);
}

#[test]
fn si_engine_grade_against_finite_differences() {
    check_model("si_engine_grade", &[]);
}

#[test]
fn si_engine_maps_against_finite_differences() {
    // fuel_bsfc reads the plain bilinear BSFC map (`interp = "linear"`): on NEDC at t = 1104 s the smoothed
    // speed is 30 m/s, so w_e = i_t·v/r_w = 500 rad/s lies on one of the map's grid lines and d fuel_bsfc/d i_t
    // jumps at the default i_t: each engine returns one side's derivative (the cell the rounding of w_e
    // selects), the central differences their mean.
    check_model("si_engine_maps", &["fuel_bsfc", "fuel_bsfc_per_100km"]);
}

/// diesel_gasflow's zero dynamics are unstable: η is the bounded solution of the collocation equations (stable
/// inversion), differentiated by the implicit function theorem. The built-in model accumulates only the fuel
/// flow, which does not depend on η; diesel_gasflow_flows (tests/models, the built-in file with its mass flows
/// and turbine power accumulated, checked here) has integrals that do, every one against the differences for
/// every parameter on NEDC and the whole UDDS (a run takes a fraction of a second).
#[test]
fn diesel_gasflow_against_finite_differences() {
    let read = |p: &str| std::fs::read_to_string(root().join(p)).expect("readable");
    let strip = |text: String| -> Vec<String> {
        text.lines()
            .filter(|l| {
                !(l.starts_with('#') || l.starts_with("name =") || l.starts_with("description ="))
            })
            .map(|l| l.replace("accumulate = true, per_distance = false, ", ""))
            .collect()
    };
    assert_eq!(
        strip(read("models/diesel_gasflow.toml")),
        strip(read("tests/models/diesel_gasflow_flows.toml")),
        "the test model is the built-in one with its flows accumulated"
    );
    check_model("diesel_gasflow", &[]);
    check_model("diesel_gasflow_flows", &[]);
}

/// linear_nmp_effort (tests/models): stable inversion with 31 s of pre-actuation on NEDC, whose samples before
/// the cycle's start are left out of the integrals by default and summed with `include_extension`; both
/// against the differences for every parameter (the default on NEDC and UDDS by [`check_model`], the extension
/// on NEDC, within 1e-6 relative or twice the differences' error estimate).
#[test]
fn stable_runs_with_pre_actuation_against_finite_differences() {
    check_model("linear_nmp_effort", &[]);
    let cycle = Cycle::builtin("nedc").expect("built in");
    let mut model = compiled("linear_nmp_effort");
    let extended = |gradient: Option<Vec<String>>| {
        let mut o = opts_for(gradient);
        o.include_extension = true;
        o
    };
    let s = simulate(model.as_ref(), &cycle, &extended(Some(vec!["all".into()])))
        .expect("runs")
        .summary;
    assert!(s.pre_actuation_s > 30.0, "{}", s.pre_actuation_s);
    let g = block(&s);
    let names: Vec<&String> = g.keys().collect();
    let (rel, noise) = fd_plan(&s);
    let values = model.params().to_vec();
    let base = extended(None);
    for (k, p) in model.info().parameters.clone().iter().enumerate() {
        let h = step(values[k], rel);
        let exact: Vec<f64> = names.iter().map(|f| g[*f][p]).collect();
        let fd = central_with(
            model.as_mut(),
            (&cycle, &base),
            (k, h, noise),
            (&names, &exact),
        );
        for (f, (d, err)) in names.iter().zip(fd) {
            let v = g[*f][p];
            assert!(
                agrees(v, d, err),
                "extended d{f}/d{p} = {v:e}, central differences {d:e} ± {err:e}"
            );
        }
    }
}

#[test]
fn bev_against_finite_differences() {
    check_model("bev", &[]);
}

/// linear_fuel (tests/models/known): u = (y_d' + a y_d)/b, fuel = c u + d, so the run's fuel integral is
/// F = (c/b)(T₁ + a T₀) + d·T(1) with T₀, T₁ the trapezoidal sums of y_d, y_d' over the run's grid (from
/// the reference columns the run reports) and T(1) the duration: ∂F/∂a = (c/b) T₀, ∂F/∂b = −(c/b²)(T₁ + a T₀),
/// ∂F/∂c = (T₁ + a T₀)/b, ∂F/∂d = T(1); the per-100-km figure the same · 10⁵/distance. Exact to 1e-12.
#[test]
fn linear_fuel_gradient_is_the_closed_form() {
    let path = "tests/models/known/linear_fuel.toml";
    let models: Vec<Box<dyn InverseModel>> = vec![
        interpreted(path),
        invsim_tests::known::compiled::builtin("linear_fuel").expect("compiled"),
    ];
    for cycle in ["nedc", "udds"] {
        let cycle = Cycle::builtin(cycle).expect("built in");
        for m in &models {
            let o = SimulationOptions::builder()
                .gradient(Some(vec!["all".to_string()]))
                .build()
                .expect("valid");
            let r = simulate(m.as_ref(), &cycle, &o).expect("runs");
            let col = |name: &str| &r.data[r.columns.iter().position(|c| c == name).expect(name)];
            let trapezoid = |c: &[f64]| {
                c.windows(2)
                    .map(|w| 0.5 * o.dt * (w[0] + w[1]))
                    .sum::<f64>()
            };
            let (t0, t1) = (trapezoid(col("yd_0")), trapezoid(col("yd_1")));
            let duration = trapezoid(&vec![1.0; col("yd_0").len()]);
            let p = |n: &str| m.params()[m.info().parameters.iter().position(|q| q == n).expect(n)];
            let (a, b, c) = (p("a"), p("b"), p("c"));
            let exact = [
                ("a", c / b * t0),
                ("b", -c / (b * b) * (t1 + a * t0)),
                ("c", (t1 + a * t0) / b),
                ("d", duration),
            ];
            let g = block(&r.summary);
            let distance = r.summary.run.distance_m;
            for (name, e) in exact {
                let (v, w) = (g["fuel"][name], g["fuel_per_100km"][name]);
                assert!(
                    (v - e).abs() <= 1e-12 * e.abs(),
                    "dF/d{name} = {v:e}, exact {e:e}"
                );
                let e100 = e * 1e5 / distance;
                assert!(
                    (w - e100).abs() <= 1e-12 * e100.abs(),
                    "dF100/d{name} = {w:e}, exact {e100:e}"
                );
            }
        }
    }
}

/// An unknown parameter is refused, named.
#[test]
fn unknown_parameters_are_refused() {
    let cycle = Cycle::builtin("nedc").expect("built in");
    let m = compiled("si_engine");
    let mut o = opts(false);
    o.gradient = Some(vec!["m".to_string(), "no_such".to_string()]);
    let Err(e) = simulate(m.as_ref(), &cycle, &o) else {
        panic!("an unknown parameter is refused");
    };
    assert!(e.to_string().contains("unknown parameter `no_such`"), "{e}");
}

/// A gradient for some parameters equals those entries of the gradient for all of them, and asking for a
/// gradient leaves every other figure of the summary as it was.
#[test]
fn a_subset_of_parameters_and_the_rest_of_the_summary_unchanged() {
    let cycle = Cycle::builtin("udds").expect("built in");
    let m = compiled("bev");
    let all = run(m.as_ref(), &cycle, true);
    let mut o = opts(false);
    o.gradient = Some(vec!["m".to_string(), "C_d".to_string()]);
    let some = simulate(m.as_ref(), &cycle, &o).expect("runs").summary;
    for (f, row) in block(&some) {
        assert_eq!(row.len(), 2);
        for (p, v) in row {
            assert_eq!(v, block(&all)[&f][&p], "{f} {p}");
        }
    }
    let mut plain = run(m.as_ref(), &cycle, false);
    plain.gradient = all.gradient.clone();
    assert_eq!(plain, all);
}
