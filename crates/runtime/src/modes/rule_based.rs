//! A rule-based energy management (docs/hybrids.md, "Rule-based"), after FASTSim's greedy RESGreedy
//! control of the hybrid (Brooker et al., "FASTSim: A Model to Estimate Vehicle Efficiency, Cost and
//! Performance", SAE 2015-01-0973): no optimisation, a fixed priority per sample.
//!
//! 1. At standstill (below `standstill_below`) the standstill mode, where it holds the car within its bounds.
//! 2. Where the brake mode is feasible without recuperation (the wheels need braking), the brake mode with its
//!    decided input at the value of least battery power (the most recuperation its bounds allow).
//! 3. Electric drive where its battery power P_batt ≤ P_on (`--rb-engine-power`) and the charge is at least
//!    SOC(0) − ΔSOC_low (`--rb-soc-low`).
//! 4. Otherwise the engine: the mode with the engine on, its decided input at the value whose battery power is
//!    nearest −P_chg (`--rb-charge-power`) below SOC(0) and nearest 0 at or above it (the engine drives alone,
//!    the motor covering only its own losses and the auxiliaries' load).
//!
//! Where the chosen mode is infeasible the next rule's mode is taken, and where none is, the candidate nearest
//! its bounds (as in ECMS). The run is not charge-sustaining by construction: its fuel is corrected to
//! ΔSOC = 0 by SAE J1711's line through a second run whose target (SOC(0) in rules 3 and 4) is
//! [`SHIFT`] higher, so that it ends about that much higher.

use super::ecms::{Ecms, Eval, Outcome};
use super::minimise::minimise;
use super::strategy::RuleOptions;
use super::{ModalError, Role};

/// The target's shift in the J1711 correction's second run.
const SHIFT: f64 = 0.02;

/// The rule-based run at the options and the second run of the J1711 correction (target + [`SHIFT`]).
pub(super) fn rule_based(
    run: &Ecms<'_, '_, '_>,
    opts: &RuleOptions,
    x0: &[f64],
) -> Result<(Outcome, Outcome), ModalError> {
    check(opts)?;
    if let Some(rules) = run.h.rules {
        let first = model_rules(run, rules, x0, 0.0)?;
        let second = model_rules(run, rules, x0, SHIFT)?;
        return Ok((first, second));
    }
    let soc0 = x0[run.h.soc];
    let first = run.run_policy(f64::NAN, x0, &[], &mut |k, x, _| {
        choose(run, opts, (k, x), soc0)
    })?;
    let second = run.run_policy(f64::NAN, x0, &[], &mut |k, x, _| {
        choose(run, opts, (k, x), soc0 + SHIFT)
    })?;
    Ok((first, second))
}

/// The thresholds: finite, the powers and the SOC margin not negative.
fn check(opts: &RuleOptions) -> Result<(), ModalError> {
    for (name, v) in [
        ("--rb-engine-power", opts.engine_power),
        ("--rb-soc-low", opts.soc_low),
        ("--rb-charge-power", opts.charge_power),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(ModalError::Setup(format!(
                "{name} must be a number ≥ 0, got {v}"
            )));
        }
    }
    Ok(())
}

/// The first candidate of sample k for which `pred` holds.
fn find(run: &Ecms<'_, '_, '_>, k: usize, pred: &dyn Fn(usize) -> bool) -> Option<usize> {
    run.samples.candidates[k].iter().copied().find(|&m| pred(m))
}

/// Mode m at sample k with its decided input at the value of least `cost` (free input within its bounds), or
/// `None` where no value is feasible.
fn at_least(
    run: &Ecms<'_, '_, '_>,
    (m, k, x): (usize, usize, &[f64]),
    cost: &dyn Fn(&Eval) -> f64,
) -> Option<Eval> {
    let Some(&(i, _)) = run.ctx.decided[m].first() else {
        return run.eval((m, k), x, 0.0);
    };
    let input = &run.ctx.spec.inputs[i];
    let bounds = (input.min.unwrap_or(0.0), input.max.unwrap_or(0.0));
    let mut f = |d: f64| match run.eval((m, k), x, d) {
        Some(e) if e.excess <= 1e-9 => cost(&e),
        _ => f64::INFINITY,
    };
    let (d, _) = minimise(&mut f, bounds, run.h.grid.max(3))?;
    run.eval((m, k), x, d)
}

/// The rules' choice at sample k from state x, charging towards `target_soc`.
fn choose(
    run: &Ecms<'_, '_, '_>,
    opts: &RuleOptions,
    (k, x): (usize, &[f64]),
    target_soc: f64,
) -> Result<Eval, ModalError> {
    let spec = run.ctx.spec;
    let role = |m: usize| spec.modes[m].role;
    let feasible = |e: Option<Eval>| e.filter(|e| e.excess <= 1e-9);
    let soc = x[run.h.soc];
    if let Some(m) = find(run, k, &|m| role(m) == Role::Standstill) {
        if let Some(e) = feasible(run.eval((m, k), x, 0.0)) {
            return Ok(e);
        }
    }
    if let Some(m) = find(run, k, &|m| role(m) == Role::Brake) {
        if feasible(run.eval((m, k), x, 0.0)).is_some() {
            if let Some(e) = feasible(at_least(run, (m, k, x), &|e| e.p_batt)) {
                return Ok(e);
            }
        }
    }
    let electric = find(run, k, &|m| {
        role(m) == Role::Traction && !run.h.engine_on[m] && run.ctx.decided[m].is_empty()
    })
    .and_then(|m| feasible(run.eval((m, k), x, 0.0)));
    if let Some(e) = electric.as_ref() {
        if e.p_batt <= opts.engine_power && soc >= target_soc - opts.soc_low {
            return Ok(e.clone());
        }
    }
    let target = if soc < target_soc {
        -opts.charge_power
    } else {
        0.0
    };
    let engine = find(run, k, &|m| role(m) == Role::Traction && run.h.engine_on[m])
        .and_then(|m| feasible(at_least(run, (m, k, x), &|e| (e.p_batt - target).powi(2))));
    if let Some(e) = engine.or(electric) {
        return Ok(e);
    }
    nearest(run, (k, x))
}

/// Where no rule's mode is feasible: the candidate nearest its bounds (decided inputs at 0).
fn nearest(run: &Ecms<'_, '_, '_>, (k, x): (usize, &[f64])) -> Result<Eval, ModalError> {
    run.samples.candidates[k]
        .iter()
        .filter_map(|&m| run.eval((m, k), x, 0.0))
        .min_by(|a, b| a.excess.total_cmp(&b.excess))
        .ok_or_else(|| run.no_candidate(k))
}

/// The model's own rules (`[hybrid]` `rule_request`, `rule_target`, `rule_min_on`; FASTSim's hybrid
/// controller as its import writes them): the engine runs where the output `rule_request` is positive, read
/// with the charge `shift` lower (the J1711 correction's second run: it ends about that much higher), and for
/// `rule_min_on` seconds after each start.
fn model_rules(
    run: &Ecms<'_, '_, '_>,
    (_, _, min_on): (usize, usize, f64),
    x0: &[f64],
    shift: f64,
) -> Result<Outcome, ModalError> {
    let mut started = f64::NEG_INFINITY;
    run.run_policy(f64::NAN, x0, &[], &mut |k, x, on| {
        let t = run.samples.t[k];
        let hold = on && t - started < min_on;
        let e = choose_by_model(run, (k, x), shift, hold)?;
        if run.h.engine_on[e.m] && !on {
            started = t;
        }
        Ok(e)
    })
}

/// The model's rules at sample k: at a standstill the standstill mode with the engine as requested; braking
/// (where the engine-off brake mode is feasible without recuperation), with the engine requested the brake
/// mode with the engine on where the model has one, else the engine-off brake mode with the most
/// recuperation; driving, with the engine requested (or `hold`), the engine's mode, else electric drive.
/// A mode with the engine on has its decided input at the value bringing `rule_target` nearest zero; where
/// a rule's mode is infeasible the next one.
fn choose_by_model(
    run: &Ecms<'_, '_, '_>,
    (k, x): (usize, &[f64]),
    shift: f64,
    hold: bool,
) -> Result<Eval, ModalError> {
    let spec = run.ctx.spec;
    let role = |m: usize| spec.modes[m].role;
    let on = |m: usize| run.h.engine_on[m];
    let feasible = |e: Option<Eval>| e.filter(|e| e.excess <= 1e-9);
    let wants = hold || requested(run, (k, x), shift);
    // The mode of a role with the engine on, its decided input bringing `rule_target` nearest zero.
    let target = |r: Role| {
        find(run, k, &|m| role(m) == r && on(m))
            .and_then(|m| feasible(at_least(run, (m, k, x), &|e| e.rule.1.powi(2))))
    };
    let standstill = |engine: bool| match engine {
        true => target(Role::Standstill),
        false => find(run, k, &|m| role(m) == Role::Standstill && !on(m))
            .and_then(|m| feasible(run.eval((m, k), x, 0.0))),
    };
    if let Some(e) = standstill(wants).or_else(|| standstill(!wants)) {
        return Ok(e);
    }
    if let Some(m) = find(run, k, &|m| role(m) == Role::Brake && !on(m)) {
        if feasible(run.eval((m, k), x, 0.0)).is_some() {
            let charging = if wants { target(Role::Brake) } else { None };
            if let Some(e) = charging.or_else(|| feasible(at_least(run, (m, k, x), &|e| e.p_batt)))
            {
                return Ok(e);
            }
        }
    }
    let engine = || target(Role::Traction);
    let electric = || {
        find(run, k, &|m| {
            role(m) == Role::Traction && !on(m) && run.ctx.decided[m].is_empty()
        })
        .and_then(|m| feasible(run.eval((m, k), x, 0.0)))
    };
    let pick = if wants {
        engine().or_else(electric)
    } else {
        electric().or_else(engine)
    };
    match pick {
        Some(e) => Ok(e),
        None => nearest(run, (k, x)),
    }
}

/// Whether the output `rule_request` is positive at sample k (in the first candidate with an inverse), the
/// charge read `shift` lower.
fn requested(run: &Ecms<'_, '_, '_>, (k, x): (usize, &[f64]), shift: f64) -> bool {
    let mut xs = x.to_vec();
    xs[run.h.soc] -= shift;
    run.samples.candidates[k]
        .iter()
        .find_map(|&m| run.eval((m, k), &xs, 0.0))
        .is_some_and(|e| e.rule.0 > 0.0)
}
