//! Energy management of a hybrid (docs/hybrids.md): a model with modes whose `[hybrid]` table names the fuel
//! and battery chemical powers and the charge state, run with a strategy that decides, at every sample, the
//! mode (engine on or off, braking) and the inputs its modes leave to it (`decided`): ECMS ([`super::ecms`])
//! with its equivalence factor s given or found by [`super::equivalence`] so that the run ends
//! charge-sustaining, dynamic programming ([`super::dp`]) or rules ([`super::rule_based`]). The run's record
//! is summarised like any run with modes, plus the `hybrid` block: fuel, fuel corrected to ΔSOC = 0 (SAE
//! J1711), ΔSOC, engine starts, time with the engine on, s.

use super::dp::dynamic_programming;
use super::ecms::{candidates, Ecms, Outcome, Resolved, Samples};
use super::equivalence::{correction, fixed, search, Narrowing};
use super::gears::GearBox;
use super::hybrid_block::{DpBlock, HybridBlock};
use super::price_cache::PriceCache;
use super::record::{decided_slots, Ctx};
use super::reference::ModalReference;
use super::rows::Rows;
use super::rule_based::rule_based;
use super::rules::Rules;
use super::signals::record_signals;
use super::strategy::{Method, StrategyOptions};
use super::verify::replay;
use super::{charge_window, ModalError, ModalOptions, ModalResult, ModalSpec};
use crate::cycle::Cycle;
use crate::gradient::{Gradient, ModalWrt};
use crate::grid::Grid;
use crate::signals::SignalInput;
use crate::smoother::ZeroDynamicsReference;
use invsim_model_api::HybridSpec;

/// `config` against the modes of `spec`.
fn resolve(spec: &ModalSpec<'_>, config: &HybridSpec) -> Result<Resolved, ModalError> {
    let info = spec.modes[0].model.info();
    let output = |name: &str| {
        info.outputs[..spec.n_outputs]
            .iter()
            .position(|o| o.name == name)
            .ok_or_else(|| {
                ModalError::Setup(format!("[hybrid] names `{name}`, which is not an output"))
            })
    };
    let soc = info
        .states
        .iter()
        .position(|s| *s == config.soc)
        .ok_or_else(|| {
            ModalError::Setup(format!("[hybrid] `soc`: `{}` is not a state", config.soc))
        })?;
    Ok(Resolved {
        fuel: output(&config.fuel_power)?,
        battery: output(&config.battery_power)?,
        soc,
        engine_on: spec
            .modes
            .iter()
            .map(|m| config.engine_on.contains(&m.family))
            .collect(),
        start_penalty: config.start_penalty,
        grid: config.grid,
        rules: match &config.rules {
            Some(r) => Some((output(&r.request)?, output(&r.target)?, r.min_on)),
            None => None,
        },
    })
}

/// The run's start state: every internal state at its start value (`initial` in the model file, overridden by
/// `initial`, `--initial NAME=VALUE`), the others NaN until the first inverse sets them.
fn start_state(spec: &ModalSpec<'_>, initial: &[(String, f64)]) -> Result<Vec<f64>, ModalError> {
    let info = spec.modes[0].model.info();
    let mut x: Vec<f64> = info
        .state_initial
        .iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect();
    for (name, v) in initial {
        let i = info.states.iter().position(|s| s == name).ok_or_else(|| {
            ModalError::Setup(format!(
                "--initial {name}: not a state (the states are: {})",
                info.states.join(", ")
            ))
        })?;
        x[i] = *v;
    }
    for m in &spec.modes {
        for &j in &m.model.info().eta_states {
            if !x[j].is_finite() {
                return Err(ModalError::Setup(format!(
                    "state `{}` is internal in mode `{}` and needs a start value for the strategy: \
                     `initial = …` in the model file or --initial {}=VALUE",
                    info.states[j], m.name, info.states[j]
                )));
            }
        }
    }
    Ok(x)
}

/// What a hybrid run cannot do (yet): more than one decided input in a mode.
fn check_supported(
    spec: &ModalSpec<'_>,
    decided: &[Vec<(usize, usize)>],
    flag: &str,
) -> Result<(), ModalError> {
    for (m, d) in spec.modes.iter().zip(decided) {
        if d.len() > 1 {
            return Err(ModalError::Setup(format!(
                "{flag}: mode `{}` decides {} inputs; a strategy decides one input per mode",
                m.name,
                d.len()
            )));
        }
    }
    if decided.iter().all(Vec::is_empty) {
        return Err(ModalError::Setup(format!(
            "{flag}: no mode decides an input (`decided = [\"…\"]` in a [modes.NAME] table)"
        )));
    }
    Ok(())
}

/// Simulate a hybrid with modes inversely along `cycle` under ECMS, DP or rules (`initial`: start values of
/// internal states by name), its exogenous signals from `signals` first (`--signal`), then the cycle's
/// column, the cycle's elevation or the default, smoothed as in a run without a strategy
/// ([`super::simulate_modes_with_signals`]).
pub fn simulate_hybrid(
    spec: &ModalSpec<'_>,
    config: Option<&HybridSpec>,
    cycle: &Cycle,
    opts: &ModalOptions,
    (ecms, initial): (&StrategyOptions, &[(String, f64)]),
    signals: &[SignalInput],
) -> Result<ModalResult, ModalError> {
    simulate_hybrid_differentiated(spec, config, cycle, opts, (ecms, initial), (signals, None))
}

/// [`simulate_hybrid`] with the gradient of the charge-sustaining fuel with respect to `wrt`
/// (`super::gradient_strategy`: ECMS with its equivalence factor searched; the caller refuses the rest).
pub fn simulate_hybrid_differentiated(
    spec: &ModalSpec<'_>,
    config: Option<&HybridSpec>,
    cycle: &Cycle,
    opts: &ModalOptions,
    (ecms, initial): (&StrategyOptions, &[(String, f64)]),
    (signals, wrt): (&[SignalInput], Option<&ModalWrt>),
) -> Result<ModalResult, ModalError> {
    let Some(config) = config else {
        return Err(ModalError::Setup(format!(
            "{} needs the model's [hybrid] table (fuel_power, battery_power, soc)",
            ecms.method.flag()
        )));
    };
    if !(ecms.soc_tolerance > 0.0 && ecms.soc_tolerance.is_finite()) {
        return Err(ModalError::Setup(format!(
            "--soc-tolerance must be positive, got {}",
            ecms.soc_tolerance
        )));
    }
    if let Some(s) = ecms.equivalence.filter(|s| !s.is_finite()) {
        return Err(ModalError::Setup(format!(
            "--equivalence must be finite, got {s}"
        )));
    }
    let decided = decided_slots(spec);
    check_supported(spec, &decided, ecms.method.flag())?;
    let h = resolve(spec, config)?;
    let grid = Grid::new(cycle.time[0], cycle.duration(), opts.dt)?;
    crate::inverse::checks::check_lookahead(opts.lookahead, cycle.duration(), opts.dt)
        .map_err(|e| ModalError::Setup(e.to_string()))?;
    // The strategies' steps read the smoothed cycle pointwise (no sub-grid).
    let zd = ZeroDynamicsReference::Pointwise;
    let reference =
        ModalReference::kept_or_new((None, false), spec, (cycle, &grid), opts, (signals, zd))?;
    let r_max = spec.r_max();
    let ctx = Ctx {
        spec,
        rules: Rules::new(spec),
        reference,
        r_max,
        n: spec.modes[0].model.info().n_states(),
        transition: opts.lookahead,
        decided,
        maps: super::record::reference_maps(spec),
    };
    let x0 = start_state(spec, initial)?;
    let soc_name = &spec.modes[0].model.info().states[h.soc];
    charge_window::check_start(x0[h.soc], soc_name)?;
    crate::grid::check_record(grid.samples(), 2 * ctx.n + r_max + 8, opts.dt)?;
    let samples = samples(&ctx, &grid);
    // The search's runs share their grid points' prices where the state enters none (ECMS alone: DP and the
    // rules make one run, or evaluate on grids of their own).
    let prices = match ecms.method {
        Method::Ecms => PriceCache::new(&ctx, &samples.candidates, h.grid, (h.fuel, h.battery)),
        _ => PriceCache::default(),
    };
    let run = Ecms {
        ctx: &ctx,
        h: &h,
        samples: &samples,
        dt: opts.dt,
        prices,
    };
    let (best, mut block) = match &ecms.method {
        Method::Ecms => ecms_run(&run, (ecms, wrt.is_some()), &x0)?,
        Method::Dp(dp) => {
            let r = dynamic_programming(&run, dp, &x0, ecms.soc_tolerance)?;
            let dsoc = r.outcome.delta_soc();
            let mut block = block_of(&run, &r.outcome, ecms.soc_tolerance);
            block.strategy = "dp".into();
            block.equivalence_source = "none".into();
            block.fuel_energy_corrected_j = Some(r.outcome.fuel - dsoc * r.slope);
            block.correction_slope_j = Some(r.slope);
            block.grid = dp.split_grid;
            block.dp = Some(DpBlock {
                soc_grid: dp.soc_grid,
                split_grid: dp.split_grid,
                soc_window: r.window,
                terminal_penalty: r.mu,
            });
            (r.outcome, block)
        }
        Method::RuleBased(rb) => {
            let (first, second) = rule_based(&run, rb, &x0)?;
            let (corrected, slope) = correction(&first, &Some(second));
            let mut block = block_of(&run, &first, ecms.soc_tolerance);
            block.strategy = "rule-based".into();
            block.fuel_energy_corrected_j = corrected;
            block.correction_slope_j = slope;
            (first, block)
        }
    };
    charge_window::check_trace(&best.rec, h.soc, soc_name)?;
    let gradient = wrt
        .map(|wrt| -> Result<Gradient, ModalError> {
            let d = super::gradient_strategy::of_ecms(&run, &best, wrt)?;
            Ok(fuel_gradient(wrt, &d))
        })
        .transpose()?;
    // --verify: the chosen modes, free input and decided inputs replayed through the original equations.
    let verify = opts.verify.then(|| replay(&ctx, &best.rec)).transpose()?;
    block.soc_end_replayed = verify.as_ref().map(|v| v.x_end[h.soc]);
    let mut result = super::summary::assemble(&ctx, cycle, opts, best.rec, verify);
    result.summary.modes.switching = "strategy".into();
    result.summary.hybrid = Some(Box::new(block));
    result.summary.gradient = gradient;
    add_engine_on(&mut result, &h.engine_on);
    record_signals(&mut result, ctx.reference.resolved.clone());
    Ok(result)
}

/// The summary's `gradient` block of a strategy's run: the charge-sustaining fuel energy's derivatives `d`
/// (J per unit of each derivative of `wrt`), as the figure `fuel_energy_corrected_j`.
fn fuel_gradient(wrt: &ModalWrt, d: &[f64]) -> Gradient {
    let row = wrt
        .params
        .iter()
        .map(|p| p.name.clone())
        .zip(d.iter().copied());
    let mut figures = crate::gradient::Figures::new();
    figures.insert("fuel_energy_corrected_j".into(), row.collect());
    Gradient { figures }
}

/// The last column, `engine_on`: 1 at a sample whose chosen mode runs the engine (its family is in
/// `[hybrid] engine_on`), else 0 — the engine's on/off band beside the `mode` index. Its values where the
/// run kept its series (the other columns' length), none otherwise.
fn add_engine_on(result: &mut ModalResult, engine_on: &[bool]) {
    let kept = result.data.first().map_or(0, Vec::len);
    let band: Vec<f64> = if kept == result.mode.len() {
        let on = |m: &usize| if engine_on[*m] { 1.0 } else { 0.0 };
        result.mode.iter().map(on).collect()
    } else {
        Vec::new()
    };
    result.columns.push(ENGINE_ON.into());
    result.units.push(None);
    result.data.push(band);
    result.summary.columns.push(crate::report::Column {
        name: ENGINE_ON.into(),
        unit: None,
    });
}

/// The name of the engine's on/off column of a strategy's run.
pub const ENGINE_ON: &str = "engine_on";

/// The ECMS run: s given or searched, the J1711 correction through the second run.
fn ecms_run(
    run: &Ecms<'_, '_, '_>,
    (ecms, gradient): (&StrategyOptions, bool),
    x0: &[f64],
) -> Result<(Outcome, HybridBlock), ModalError> {
    // A gradient needs every decision at the flip's own price (`Narrowing::Multiplier`).
    let narrowing = if gradient {
        Narrowing::Multiplier
    } else {
        Narrowing::Figure
    };
    let (best, runs, other) = match ecms.equivalence {
        Some(s) => fixed(run, s, x0)?,
        None => search(run, (ecms.soc_tolerance, narrowing), x0)?,
    };
    let (corrected, slope) = correction(&best, &other);
    let mut block = block_of(run, &best, ecms.soc_tolerance);
    block.equivalence_factor = Some(best.s);
    block.equivalence_source = if ecms.equivalence.is_some() {
        "given"
    } else {
        "searched"
    }
    .into();
    block.search_runs = runs;
    block.fuel_energy_corrected_j = corrected;
    block.correction_slope_j = slope;
    Ok((best, block))
}

/// The `hybrid` block of a run (ECMS's fields, the equivalence factor left out).
fn block_of(run: &Ecms<'_, '_, '_>, best: &Outcome, tol: f64) -> HybridBlock {
    let (ctx, h) = (run.ctx, run.h);
    let spec = ctx.spec;
    let dsoc = best.delta_soc();
    HybridBlock {
        strategy: "ecms".into(),
        equivalence_factor: None,
        equivalence_source: "none".into(),
        search_runs: 1,
        dp: None,
        soc_tolerance: tol,
        soc_start: best.soc.0,
        soc_end: best.soc.1,
        soc_end_replayed: None,
        delta_soc: dsoc,
        charge_sustaining: dsoc.abs() <= tol,
        fuel_energy_j: best.fuel,
        fuel_energy_corrected_j: None,
        correction_slope_j: None,
        battery_energy_j: best.battery,
        engine_starts: best.starts,
        engine_on_s: best.engine_on,
        start_penalty_j: h.start_penalty,
        grid: h.grid,
        decided_inputs: {
            let mut names: Vec<String> = ctx
                .decided
                .iter()
                .flatten()
                .map(|(i, _)| spec.inputs[*i].name.clone())
                .collect();
            names.dedup();
            names
        },
    }
}

/// The reference and the exogenous signals at every sample and interval midpoint, and each sample's
/// candidate modes.
fn samples(ctx: &Ctx<'_, '_>, grid: &Grid) -> Samples {
    let spec = ctx.spec;
    let ns = grid.samples();
    let orders = ctx.r_max + 1;
    let mut base = Rows::with_capacity(orders, ns);
    let mut mid = Rows::with_capacity(orders, ns);
    let mut y = vec![0.0; orders];
    let mut gearbox = GearBox::new(spec.gear_source.clone(), spec.gears);
    let mut t = Vec::with_capacity(ns);
    let mut midpoints = Vec::with_capacity(ns);
    let mut cands = Vec::with_capacity(ns);
    for k in 0..ns {
        let tk = grid.time(k);
        ctx.reference.smoother.eval(tk, &mut y);
        base.push(&y);
        let gear = gearbox.gear(tk, y[0]);
        cands.push(candidates(ctx, gear, y[0]));
        t.push(tk);
        if k + 1 < ns {
            midpoints.push(0.5 * (tk + grid.time(k + 1)));
            ctx.reference.smoother.eval(midpoints[k], &mut y);
            mid.push(&y);
        }
    }
    Samples {
        signals: ctx.signal_rows(&t),
        signals_mid: ctx.signal_rows(&midpoints),
        t,
        base,
        mid,
        candidates: cands,
    }
}
