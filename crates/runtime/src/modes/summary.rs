//! The summary of a run with modes (time per mode, switches, transitions and impulses beside the figures of
//! an ordinary run) and the result's columns.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::record::{Ctx, Impulse, ModeTime, Record, Transition};
use super::tally::{walk, Excursion, Tally};
use super::verify::Tracking;
use super::{ModalOptions, ModalResult};
use crate::cycle::Cycle;
use crate::headline::Headline;
use crate::operating_points::OperatingPoints;
use crate::provenance::Provenance;
use crate::reference_deviation::ReferenceDeviation;
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
