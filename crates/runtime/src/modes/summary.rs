//! The summary of a run with modes (time per mode, switches, transitions and impulses beside the figures of
//! an ordinary run) and the result's columns.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::record::{set_decided, Ctx, Impulse, ModeTime, Record, Transition};
use super::rows::Rows;
use super::rules::ModeRule;
use super::verify::Tracking;
use super::{ModalOptions, ModalResult};
use crate::cycle::Cycle;
use crate::headline::Headline;
use crate::operating_points::{OperatingPointTally, OperatingPoints};
use crate::provenance::Provenance;
use crate::reference_deviation::{DeviationTally, ReferenceDeviation};
use crate::report::{
    first_sentence, fmt_sig, integral_unit, unit_suffix, write_input_range, Column, CycleInfo,
    InputRange, Totals,
};

/// What `invsim simulate` prints and writes for a model with modes: the keys of the single-mode summary
/// ([`crate::Summary`], same names and meanings; the input block is the traction input's, see
/// [`ModalSpec::traction_input`](super::ModalSpec::traction_input)) with every input's range in `inputs` and the
/// modes' figures in the `modes` block (`docs/summary.schema.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModalSummary {
    /// The model's answer in the units people report (models with a `[headline]`; first in the JSON and the
    /// text).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub headline: Option<Headline>,
    /// Model, cycle, duration and distance (flattened: `model`, `description`, `cycle`, `duration_s`,
    /// `distance_m`).
    #[serde(flatten)]
    pub run: CycleInfo,
    /// The largest relative degree over the modes.
    pub relative_degree: usize,
    pub engine: String,
    pub samples: usize,
    pub lookahead_s: f64,
    /// How `--lookahead auto` chose `lookahead_s` (absent for a given look-ahead).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lookahead_choice: Option<crate::lookahead::LookaheadChoice>,
    pub dt_s: f64,
    /// How far the smoothed cycle departs from the legal trace (cycle speed, m/s: every mode's reference is a
    /// map of it).
    #[serde(flatten)]
    pub reference: ReferenceDeviation,
    /// Integrals (per 100 km, units), the traction input's range and bounds, and the intervals where the free
    /// input of the mode in force leaves its bounds and no mode absorbs it (flattened: `integrals` …
    /// `input_bound_violations`).
    #[serde(flatten)]
    pub totals: Totals,
    /// Every declared input: the range it took (free or fixed by the mode in force) and its bounds.
    pub inputs: Vec<InputRange>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_abs_tracking_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rms_tracking_error: Option<f64>,
    /// The modes' figures: switching, time per mode, switches, transitions, impulses, coupling resets.
    pub modes: ModesBlock,
    /// The time-weighted engine speed × torque histogram (models with an `[engine]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub engine_operating_points: Option<OperatingPoints>,
    /// The energy management's figures (runs with `--strategy`, docs/hybrids.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hybrid: Option<Box<super::HybridBlock>>,
    /// d figure/d parameter (`--gradient`, `modes/gradient.rs`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gradient: Option<crate::gradient::Gradient>,
    pub columns: Vec<Column>,
    /// Each signal, where it came from and that the run used it smoothed (models with signals).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub signals: Vec<crate::signals::SignalUse>,
    /// What produced the run (filled in by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    pub warnings: Vec<String>,
}

/// The `modes` block of a run with modes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModesBlock {
    /// `reentry` or `quasi_static`.
    pub switching: String,
    /// The re-entry's transition time, s.
    pub transition_time_s: f64,
    /// Time per mode (adding up to the duration) and each mode's relative degree, in the model's order.
    pub per_mode: Vec<ModeTime>,
    pub switches: usize,
    pub transitions: Vec<Transition>,
    /// The unit is the tracked output's (`output_unit`).
    pub max_transition_deviation: f64,
    pub impulses: Vec<Impulse>,
    /// The impulses' total booking per accumulated output.
    pub impulse_booked: BTreeMap<String, f64>,
    /// States set to their coupling on entering a mode that couples them (models with `couple`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub coupling_resets: Vec<super::CouplingReset>,
}

/// Column names and units: `t`, `mode`, `gear`, `yd_0` … `yd_R`, per signal S `S`, `S_d1` … `S_dR`
/// (contract §5, as the single-mode run), the inputs, the states, the `[outputs]`.
fn columns(ctx: &Ctx<'_, '_>) -> Vec<(String, Option<String>)> {
    let spec = ctx.spec;
    let info = spec.modes[0].model.info();
    let mut c: Vec<(String, Option<String>)> = vec![
        ("t".into(), Some("s".into())),
        ("mode".into(), None),
        ("gear".into(), None),
    ];
    c.extend((0..=ctx.r_max).map(|k| (format!("yd_{k}"), None)));
    for sig in super::reference::exogenous(spec, info) {
        c.push((sig.name.clone(), sig.unit.clone()));
        c.extend((1..=ctx.r_max).map(|k| (format!("{}_d{k}", sig.name), None)));
    }
    c.extend(spec.inputs.iter().map(|i| (i.name.clone(), i.unit.clone())));
    c.extend(
        info.states
            .iter()
            .cloned()
            .zip(info.state_units.iter().cloned()),
    );
    c.extend(
        info.outputs[..spec.n_outputs]
            .iter()
            .map(|o| (o.name.clone(), o.unit.clone())),
    );
    c
}

/// The value of every input at a sample of mode m, into `row`.
fn input_values(ctx: &Ctx<'_, '_>, m: usize, u: f64, outs: &[f64], row: &mut Vec<f64>) {
    let mode = &ctx.spec.modes[m];
    row.clear();
    row.extend((0..ctx.spec.inputs.len()).map(|i| {
        if i == mode.free_input {
            u
        } else {
            mode.fixed_outputs
                .iter()
                .find(|(j, _)| *j == i)
                .map_or(f64::NAN, |(_, o)| outs[*o])
        }
    }));
}

/// What one pass over the samples gathers: the table's columns, the integrals (trapezoids of each interval
/// in its own mode), the time per mode, the bound violations, the reference's deviation and the engine's
/// operating points.
struct Tally {
    /// Every input and the model's `[outputs]` at each sample (empty without `keep_series`), and each
    /// input's range (NaN where a mode neither frees nor reports it is skipped).
    inputs: Rows,
    outputs: Rows,
    ranges: Vec<[f64; 2]>,
    integrals: Vec<f64>,
    time: Vec<f64>,
    violations: Vec<[f64; 2]>,
    /// The sample whose free input lies farthest beyond its bounds.
    farthest: Option<Excursion>,
    deviation: DeviationTally,
    operating: Option<OperatingPointTally>,
}

/// A sample whose free input lies beyond its bounds: where, in which mode, the value and the bound it
/// crosses, the smoothed cycle's speed there (for the warning).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Excursion {
    t: f64,
    mode: usize,
    u: f64,
    bound: f64,
    /// The mode's bounds of its free input.
    bounds: (Option<f64>, Option<f64>),
    speed: f64,
}

/// Whether two slices hold the same numbers bit for bit (so that a function of them gives the same value).
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Whether samples k and k + 1 hold the same decided values bit for bit (a run without a strategy has none).
fn same_decided(rec: &Record, k: usize) -> bool {
    match (rec.decided.get(k), rec.decided.get(k + 1)) {
        (Some(a), Some(b)) => same_bits(a, b),
        (a, b) => a.is_none() && b.is_none(),
    }
}

/// The pass over the samples. The outputs at the end of an interval are those of the next sample where
/// the run stayed in its mode (the same state, input, decided inputs and time): evaluated once for both. The
/// decided inputs matter where the free input does not depend on them (a series hybrid's generator power,
/// which enters only the battery's and the fuel's equations): the end of an interval holds the interval's
/// value, the next sample its own.
fn walk(ctx: &Ctx<'_, '_>, cycle: &Cycle, opts: &ModalOptions, rec: &Record) -> Tally {
    let spec = ctx.spec;
    let ns = rec.t.len();
    let no = spec.n_outputs;
    let info0 = spec.modes[0].model.info();
    let kept = if opts.keep_series { ns } else { 0 };
    let mut tally = Tally {
        inputs: Rows::with_capacity(spec.inputs.len(), kept),
        outputs: Rows::with_capacity(no, kept),
        ranges: vec![[f64::INFINITY, f64::NEG_INFINITY]; spec.inputs.len()],
        integrals: vec![0.0; no],
        time: vec![0.0; spec.modes.len()],
        violations: Vec::new(),
        farthest: None,
        deviation: DeviationTally::new(
            invsim_model_api::ReferenceMap::IDENTITY,
            opts.dt,
            cycle.tolerance,
        ),
        // The engine's outputs are among those every mode shares (the first n_outputs).
        operating: OperatingPointTally::new(info0, ns).filter(|_| {
            info0
                .engine
                .as_ref()
                .is_some_and(|e| e.speed.max(e.torque) < no)
        }),
    };
    let mut outside = false;
    // Each mode's number of outputs and of signal values, and the accumulated outputs (asked once).
    let sizes: Vec<(usize, usize)> = spec
        .modes
        .iter()
        .map(|m| (m.model.info().outputs.len(), m.model.info().n_w()))
        .collect();
    let accumulated: Vec<usize> = (0..no).filter(|&i| info0.outputs[i].accumulate).collect();
    // Buffers of one sample, reused: the outputs at the sample and at the end of its interval, the signals,
    // the inputs; `ready`: the outputs of this sample are in `outs` already.
    let (mut outs, mut end, mut w, mut row) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut ready = false;
    for k in 0..ns {
        let (m, x, u) = (rec.mode[k], &rec.states[k], rec.free[k]);
        let model = spec.modes[m].model;
        let (n_out, n_w) = sizes[m];
        if !ready {
            outs.clear();
            outs.resize(n_out, 0.0);
            ctx.w_into(m, rec.t[k], n_w, &mut w);
            set_decided(ctx, rec, (m, k), &mut w);
            model.outputs(x, &w, u, &mut outs);
        }
        ready = false;
        if let Some(op) = tally.operating.as_mut() {
            op.push(|i| outs[i]);
        }
        input_values(ctx, m, u, &outs, &mut row);
        if let Some(values) = rec.decided.get(k) {
            for (&(i, _), &v) in ctx.decided[m].iter().zip(values) {
                row[i] = v;
            }
        }
        for (r, &v) in tally.ranges.iter_mut().zip(&row) {
            *r = [r[0].min(v), r[1].max(v)];
        }
        if opts.keep_series {
            tally.inputs.push(&row);
            tally.outputs.push(&outs[..no]);
        }
        let rule = &ctx.rules.modes[m];
        outside = track_violation(rule, (rec.t[k], u), outside, &mut tally.violations);
        if outside {
            let here = Excursion {
                t: rec.t[k],
                mode: m,
                u,
                bound: crossed_bound(rule, u),
                bounds: (rule.input_min, rule.input_max),
                speed: rec.speed[k],
            };
            tally.farthest = Some(farther(tally.farthest, here));
        }
        if k + 1 < ns {
            end.clear();
            end.resize(n_out, 0.0);
            ctx.w_into(m, rec.t[k + 1], n_w, &mut w);
            set_decided(ctx, rec, (m, k), &mut w);
            model.outputs(&rec.x_end[k], &w, rec.u_end[k], &mut end);
            let dt = rec.t[k + 1] - rec.t[k];
            for &i in &accumulated {
                tally.integrals[i] += 0.5 * dt * (outs[i] + end[i]);
            }
            tally.time[m] += dt;
            ready = rec.mode[k + 1] == m
                && rec.u_end[k].to_bits() == rec.free[k + 1].to_bits()
                && same_bits(&rec.x_end[k], &rec.states[k + 1])
                && same_decided(rec, k);
            if ready {
                std::mem::swap(&mut outs, &mut end);
            }
        }
    }
    // The reference's deviation, the samples as a block (the same operations as sample by sample).
    tally.deviation.push_block(cycle, &rec.t, &rec.speed);
    tally
}

/// The table's columns (see [`columns`]): t, mode, gear, y_d^(0 … R), the smoothed signals with their
/// derivatives at the samples, the inputs, the states, the `[outputs]`, each copied column by column from
/// the rows recorded.
fn table(ctx: &Ctx<'_, '_>, rec: &Record, tally: &Tally) -> Vec<Vec<f64>> {
    let spec = ctx.spec;
    let mut data = vec![
        rec.t.clone(),
        rec.mode.iter().map(|&m| m as f64).collect(),
        rec.mode
            .iter()
            .map(|&m| spec.modes[m].gear.unwrap_or(0) as f64)
            .collect(),
    ];
    data.extend(rec.yref.columns());
    data.extend(ctx.signal_rows(&rec.t).columns());
    for rows in [&tally.inputs, &rec.states, &tally.outputs] {
        data.extend(rows.columns());
    }
    data
}

/// The accumulated outputs' integrals, per 100 km (those per distance) and units, by name.
type Tables = (
    BTreeMap<String, f64>,
    BTreeMap<String, f64>,
    BTreeMap<String, String>,
);

fn totals(outputs: &[invsim_model_api::OutputInfo], integrals: &[f64], distance: f64) -> Tables {
    let mut ints = BTreeMap::new();
    let mut per = BTreeMap::new();
    let mut integral_units = BTreeMap::new();
    for (o, total) in outputs.iter().zip(integrals) {
        if o.accumulate {
            ints.insert(o.name.clone(), *total);
            if let Some(u) = o.unit.as_deref().and_then(integral_unit) {
                integral_units.insert(o.name.clone(), u);
            }
            if o.per_distance && distance > 0.0 {
                per.insert(o.name.clone(), total / distance * 1e5);
            }
        }
    }
    (ints, per, integral_units)
}

/// Build the result: columns, integrals (trapezoids of each interval in its own mode, plus the impulses'
/// bookings), time per mode, bound violations.
pub(super) fn assemble(
    ctx: &Ctx<'_, '_>,
    cycle: &Cycle,
    opts: &ModalOptions,
    rec: Record,
    verify: Option<Tracking>,
) -> ModalResult {
    let spec = ctx.spec;
    let cols = columns(ctx);
    let ns = rec.t.len();
    let info0 = spec.modes[0].model.info();
    let mut tally = walk(ctx, cycle, opts, &rec);
    let data = if opts.keep_series {
        table(ctx, &rec, &tally)
    } else {
        Vec::new()
    };
    let impulse_booked = book_impulses(&rec.impulses, &info0.outputs, &mut tally.integrals);
    let distance = cycle.distance();
    let (ints, per, integral_units) = totals(&info0.outputs, &tally.integrals, distance);
    let modes: Vec<ModeTime> = spec
        .modes
        .iter()
        .zip(&tally.time)
        .map(|(m, t)| ModeTime {
            name: m.name.clone(),
            time_s: *t,
            relative_degree: m.model.info().relative_degree,
        })
        .collect();
    let max_dev = rec
        .transitions
        .iter()
        .map(|t| t.max_deviation)
        .fold(0.0, f64::max);
    let mut warnings = warnings_of(spec, (&tally.violations, tally.farthest), &rec.impulses);
    let reference = tally.deviation.finish();
    warnings.extend(reference.tolerance_band.warning());
    let inputs = spec.input_ranges(&tally.ranges);
    let totals = Totals::of_modes(
        (ints, per, integral_units),
        info0.output_unit.clone(),
        &inputs[spec.traction_input()],
        tally.violations,
    );
    let headline = Headline::of(
        info0,
        spec.modes[0].model.params(),
        &totals.integrals,
        distance,
    );
    let summary = ModalSummary {
        headline,
        run: CycleInfo::new(info0, cycle, cycle.duration()),
        relative_degree: ctx.r_max,
        engine: "interpreted".into(),
        samples: ns,
        lookahead_s: opts.lookahead,
        lookahead_choice: None,
        dt_s: opts.dt,
        reference,
        totals,
        inputs,
        max_abs_tracking_error: verify.as_ref().map(|v| v.max_abs),
        rms_tracking_error: verify.as_ref().map(|v| v.rms),
        modes: ModesBlock {
            switching: opts.switching.as_str().into(),
            transition_time_s: ctx.transition,
            per_mode: modes,
            switches: rec.transitions.len(),
            transitions: rec.transitions,
            max_transition_deviation: max_dev,
            impulses: rec.impulses,
            impulse_booked,
            coupling_resets: rec.resets,
        },
        engine_operating_points: tally.operating.map(|op| op.finish(info0, opts.dt)),
        hybrid: None,
        gradient: None,
        columns: cols
            .iter()
            .map(|(n, u)| Column {
                name: n.clone(),
                unit: u.clone(),
            })
            .collect(),
        signals: Vec::new(),
        provenance: None,
        warnings,
    };
    ModalResult {
        summary,
        columns: cols.iter().map(|(n, _)| n.clone()).collect(),
        units: cols.into_iter().map(|(_, u)| u).collect(),
        data,
        mode: rec.mode,
        u_end: rec.u_end,
        x_end: rec.x_end,
        states: rec.states,
        free: rec.free,
        yref: rec.yref,
        impulse: rec.impulse,
        signals: Vec::new(),
    }
}

/// Whether the free input `u` at t is outside its bounds (up to the mode's tolerance, 1e-9 of its range);
/// an interval of `violations` opens or extends there (`outside`: whether the previous sample was).
fn track_violation(
    rule: &ModeRule,
    (t, u): (f64, f64),
    outside: bool,
    violations: &mut Vec<[f64; 2]>,
) -> bool {
    let tol = rule.tolerance;
    let out = rule.input_min.is_some_and(|lo| u < lo - tol)
        || rule.input_max.is_some_and(|hi| u > hi + tol);
    match (out, outside) {
        (true, false) => violations.push([t, t]),
        (true, true) => {
            if let Some(v) = violations.last_mut() {
                v[1] = t;
            }
        }
        _ => {}
    }
    out
}

/// The bound of `rule` that `u` lies beyond (the lower one below it, else the upper one).
fn crossed_bound(rule: &ModeRule, u: f64) -> f64 {
    match (rule.input_min, rule.input_max) {
        (Some(lo), _) if u < lo => lo,
        (_, Some(hi)) => hi,
        (lo, None) => lo.unwrap_or(u),
    }
}

/// Of the excursion so far and `here`, the one farther beyond its bound.
fn farther(so_far: Option<Excursion>, here: Excursion) -> Excursion {
    match so_far {
        Some(e) if (e.u - e.bound).abs() >= (here.u - here.bound).abs() => e,
        _ => here,
    }
}

/// Add each quasi-static impulse's booking to the accumulated outputs' integrals; returns the bookings per
/// output name.
fn book_impulses(
    impulses: &[Impulse],
    outputs: &[invsim_model_api::OutputInfo],
    integrals: &mut [f64],
) -> BTreeMap<String, f64> {
    let mut booked = BTreeMap::new();
    for imp in impulses {
        for ((total, o), b) in integrals.iter_mut().zip(outputs).zip(&imp.booked) {
            if o.accumulate {
                *total += b;
                *booked.entry(o.name.clone()).or_insert(0.0) += b;
            }
        }
    }
    booked
}

/// The run's warnings: input-bound intervals no mode absorbs (naming the farthest excursion's input, mode,
/// time, value and speed), and jumps no impulse realises.
fn warnings_of(
    spec: &super::ModalSpec<'_>,
    (violations, farthest): (&[[f64; 2]], Option<Excursion>),
    impulses: &[Impulse],
) -> Vec<String> {
    let mut warnings = Vec::new();
    if let Some(e) = farthest.filter(|_| !violations.is_empty()) {
        let mode = &spec.modes[e.mode];
        let input = &spec.inputs[mode.free_input];
        let unit = input
            .unit
            .as_deref()
            .map_or(String::new(), |u| format!(" {u}"));
        let bound = |b: Option<f64>, none: &str| b.map_or(none.to_string(), |b| fmt_sig(b, 6));
        warnings.push(format!(
            "{} interval(s), {} s in total, where a mode's free input leaves its bounds and no mode absorbs it; \
             the farthest at t = {} s: `{}` = {}{unit} in mode `{}` (bounds [{}, {}]), at a speed of {} m/s",
            violations.len(),
            fmt_sig(violations.iter().map(|[a, b]| b - a).sum(), 4),
            fmt_sig(e.t, 6),
            input.name,
            fmt_sig(e.u, 4),
            mode.name,
            bound(e.bounds.0, "-inf"),
            bound(e.bounds.1, "inf"),
            fmt_sig(e.speed, 3),
        ));
    }
    let unrealisable = impulses.iter().map(|i| i.unrealisable).fold(0.0, f64::max);
    if unrealisable > 1e-9 {
        warnings.push(format!(
            "a quasi-static jump has a part ({unrealisable:.3e} of the state) that no impulse of the free input realises"
        ));
    }
    warnings
}

/// The text line of the coupling resets, if any: how many entries set a coupled state, and the largest jump.
fn resets_line(resets: &[super::CouplingReset]) -> Option<String> {
    let big = resets
        .iter()
        .max_by(|a, b| a.jump.abs().total_cmp(&b.jump.abs()))?;
    Some(format!(
        "coupling resets: {} (entries that set a coupled state to its coupling: a gear shift, a clutch closing \
         with slip), largest {} {:+.4e} entering {} at t = {} s",
        resets.len(),
        big.state,
        big.jump,
        big.mode,
        big.t
    ))
}

/// `v` with `decimals` decimals (`0.563233`) below 1e15 in magnitude, else six significant digits with an
/// exponent (`1.79769e308`, not 309 digits).
fn fixed(v: f64, decimals: usize) -> String {
    if v.abs() < 1e15 {
        format!("{v:.decimals$}")
    } else {
        fmt_sig(v, 6)
    }
}

impl ModalSummary {
    /// The printed summary.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        if let Some(h) = &self.headline {
            h.write_text(&mut s);
        }
        let _ = writeln!(s, "model: {} (modes)", self.run.model);
        if !self.run.description.trim().is_empty() {
            let _ = writeln!(s, "description: {}", first_sentence(&self.run.description));
        }
        let _ = writeln!(
            s,
            "cycle: {}  duration: {} s  distance: {:.1} m  samples: {}  dt: {} s  look-ahead: {} s",
            self.run.cycle,
            self.run.duration_s,
            self.run.distance_m,
            self.samples,
            self.dt_s,
            self.lookahead_s
        );
        if let Some(c) = &self.lookahead_choice {
            let _ = writeln!(s, "{}", c.text());
        }
        let _ = writeln!(
            s,
            "engine: {}  switching: {}",
            self.engine, self.modes.switching
        );
        crate::signals::write_signal_uses(&mut s, &self.signals);
        let t = &self.totals;
        for (k, v) in &t.integrals {
            let unit = t.integral_units.get(k);
            let per = t
                .integrals_per_100km
                .get(k)
                .map(|p| match unit {
                    Some(u) => format!("  ({} {u}/100 km)", fixed(*p, 4)),
                    None => format!("  ({} per 100 km)", fixed(*p, 4)),
                })
                .unwrap_or_default();
            let u = unit.map(|u| format!(" {u}")).unwrap_or_default();
            let answer = match &self.headline {
                Some(h) if &h.output == k => "  (the model's answer: the headline)",
                _ => "",
            };
            let _ = writeln!(s, "integral {k}: {}{u}{per}{answer}", fixed(*v, 6));
        }
        if let Some(g) = &self.gradient {
            g.write_text(&mut s);
        }
        for i in &self.inputs {
            write_input_range(
                &mut s,
                (&i.name, i.unit.as_deref()),
                [i.min, i.max],
                [i.lower_bound, i.upper_bound],
            );
        }
        let yu = unit_suffix(t.output_unit.as_deref());
        if let Some(h) = &self.hybrid {
            h.write_text(&mut s);
        }
        let m = &self.modes;
        let _ = writeln!(s, "time per mode:");
        for mode in m.per_mode.iter().filter(|m| m.time_s > 0.0) {
            let _ = writeln!(
                s,
                "  {:<16} {:>10.2} s  (r = {})",
                mode.name, mode.time_s, mode.relative_degree
            );
        }
        let _ = writeln!(
            s,
            "switches: {}  largest transition deviation: {:.4e}{yu}",
            m.switches, m.max_transition_deviation
        );
        if !m.impulses.is_empty() {
            for (k, v) in &m.impulse_booked {
                let u = t
                    .integral_units
                    .get(k)
                    .map(|u| format!(" {u}"))
                    .unwrap_or_default();
                let _ = writeln!(s, "impulses: {} booked, {k}: {v:.6e}{u}", m.impulses.len());
            }
        }
        if let Some(line) = resets_line(&m.coupling_resets) {
            let _ = writeln!(s, "{line}");
        }
        self.reference
            .write_text(&mut s, Some("m/s"), self.run.distance_m);
        if let Some(op) = &self.engine_operating_points {
            op.write_text(&mut s);
        }
        if t.input_bound_violations.is_empty() {
            let _ = writeln!(s, "input bound violations: none");
        } else {
            let _ = writeln!(s, "input bound violations: {:?}", t.input_bound_violations);
        }
        if let (Some(m), Some(r)) = (self.max_abs_tracking_error, self.rms_tracking_error) {
            let _ = writeln!(
                s,
                "tracking error (replay): max {m:.3e}{yu}, rms {r:.3e}{yu}"
            );
        }
        if let Some(p) = &self.provenance {
            p.write_text(&mut s);
        }
        for w in &self.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        s
    }
}
