//! What `invsim forward` prints and writes for a model with modes: the forward summary's figures (driver,
//! integrator, integrals, trace misses, tracking error to the raw cycle) with every input's range, and the
//! time per mode and the switches as in the inverse's modal summary.

use std::fmt::Write as _;

use serde::Serialize;

use super::anti_windup_rate;
use super::driver::Drive;
use super::options::{Bounds, ForwardOptions};
use super::summary::{DriverSummary, IntegratorSummary};
use crate::cycle::Cycle;
use crate::cycle::Tolerance;
use crate::headline::Headline;
use crate::modes::{ModalSpec, ModeTime};
use crate::ode::OdeStats;
use crate::operating_points::{OperatingPointTally, OperatingPoints};
use crate::provenance::Provenance;
use crate::report::{
    describe_intervals, fmt_sig, integral_tables, unit_suffix, write_input_range, write_integrals,
    write_intervals, Column, CycleInfo, Intervals, Totals,
};

/// One switch of the forward run: its time and the modes left and entered (indices into the spec's modes).
pub(super) type SwitchAt = (f64, usize, usize);

pub use crate::report::InputRange;

/// One switch: its time and the modes left and entered.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeSwitch {
    pub t: f64,
    pub from: String,
    pub to: String,
}

/// What `invsim forward` prints and writes with `--summary-json` for a model with modes: the keys of
/// [`super::ForwardSummary`] (same names and meanings; the input block is the traction input's, see
/// [`ModalSpec::traction_input`]) with every input's range in `inputs` and the modes' figures in the `modes`
/// block (`docs/summary.schema.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModalForwardSummary {
    /// The model's answer in the units people report (models with a `[headline]`; first in the JSON and the
    /// text).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub headline: Option<Headline>,
    #[serde(flatten)]
    pub run: CycleInfo,
    /// ∫ y dt over the run (the distance the vehicle drove, when y is its speed).
    pub distance_driven_m: f64,
    /// The largest relative degree over the modes.
    pub relative_degree: usize,
    pub engine: String,
    pub samples: usize,
    pub dt_s: f64,
    pub bounds: Bounds,
    pub driver: DriverSummary,
    pub integrator: IntegratorSummary,
    /// Integrals (by the solver's quadrature states), per 100 km and their units, the traction input's range
    /// and bounds, and the intervals where the free input's demand of the mode in force leaves that mode's
    /// bounds (no mode absorbs it); flattened.
    #[serde(flatten)]
    pub totals: Totals,
    /// Every declared input: the range applied and its bounds.
    pub inputs: Vec<InputRange>,
    /// Time per mode, the switches and their times.
    pub modes: ForwardModes,
    pub trace_misses: Vec<[f64; 2]>,
    pub trace_miss_speed_tolerance: f64,
    pub trace_miss_time_tolerance_s: f64,
    /// max |y − y_c| and rms (y − y_c) over the samples, y_c the raw cycle.
    pub max_abs_tracking_error: f64,
    pub rms_tracking_error: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub engine_operating_points: Option<OperatingPoints>,
    pub columns: Vec<Column>,
    /// Each signal, where it came from and that the run used it raw (models with signals).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub signals: Vec<crate::signals::SignalUse>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    pub warnings: Vec<String>,
}

/// The `modes` block of a forward run with modes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForwardModes {
    /// Time per mode (over the intervals each was in force; they add up to the run's span).
    pub per_mode: Vec<ModeTime>,
    pub switches: usize,
    pub transitions: Vec<ModeSwitch>,
}

/// The bookkeeping of a forward run with modes over its samples.
pub(super) struct Tally {
    /// ∫ o dt of the accumulated outputs and ∫ y dt from t_0 to the last sample, by the solver.
    integrals: Vec<f64>,
    distance_driven: f64,
    /// Each input's [min, max] applied.
    ranges: Vec<[f64; 2]>,
    violations: Intervals,
    farthest: Option<Demand>,
    pub(super) misses: Intervals,
    max_err: f64,
    sum_sq: f64,
    pub(super) operating: Option<OperatingPointTally>,
    /// Seconds in each mode.
    pub(super) time: Vec<f64>,
    samples: usize,
}

/// The demand farthest beyond its mode's bounds: time, mode, demand, bound crossed.
type Demand = (f64, usize, f64, f64);

impl Tally {
    pub(super) fn new(spec: &ModalSpec<'_>, operating: Option<OperatingPointTally>) -> Tally {
        let info = spec.modes[0].model.info();
        let n_acc = info.outputs.iter().filter(|o| o.accumulate).count();
        Tally {
            integrals: vec![0.0; n_acc],
            distance_driven: 0.0,
            ranges: vec![[f64::INFINITY, f64::NEG_INFINITY]; spec.inputs.len()],
            violations: Intervals::default(),
            farthest: None,
            misses: Intervals::default(),
            max_err: 0.0,
            sum_sq: 0.0,
            operating,
            time: vec![0.0; spec.modes.len()],
            samples: 0,
        }
    }

    /// The sample at t: `quadrature` is z's tail (the integrals, then ∫ y dt), `inputs` every input applied,
    /// `(m, lo, hi)` the mode and the bounds of its free input, which the demand may leave.
    pub(super) fn count(
        &mut self,
        t: f64,
        quadrature: &[f64],
        d: Drive,
        inputs: &[f64],
        (m, lo, hi): (usize, f64, f64),
    ) {
        let outside = d.demand < lo || d.demand > hi;
        let bound = if d.demand < lo { lo } else { hi };
        let farther = match self.farthest {
            Some((_, _, u, b)) => (d.demand - bound).abs() > (u - b).abs(),
            None => true,
        };
        if outside && farther {
            self.farthest = Some((t, m, d.demand, bound));
        }
        let m = self.integrals.len();
        self.integrals.copy_from_slice(&quadrature[..m]);
        self.distance_driven = quadrature[m];
        for (r, &u) in self.ranges.iter_mut().zip(inputs) {
            *r = [r[0].min(u), r[1].max(u)];
        }
        self.violations.push(t, outside);
        self.samples += 1;
        let e = d.y - d.yc;
        self.max_err = self.max_err.max(e.abs());
        self.sum_sq += e * e;
    }
}

/// The summary of a finished forward run with modes.
pub(super) fn summarise(
    (spec, switches): (&ModalSpec<'_>, &[SwitchAt]),
    cycle: &Cycle,
    opts: &ForwardOptions,
    (tally, stats): (Tally, OdeStats),
    (names, units): (&[String], &[Option<String>]),
) -> ModalForwardSummary {
    let info = spec.modes[0].model.info();
    let samples = tally.samples.max(1);
    let accumulate: Vec<usize> = (0..info.outputs.len())
        .filter(|&i| info.outputs[i].accumulate)
        .collect();
    let tables = integral_tables(info, &accumulate, &tally.integrals, cycle.distance());
    let violations = tally.violations.finish();
    let trace_misses = tally.misses.finish();
    let warnings = warnings(
        (spec, opts),
        (&violations, tally.farthest),
        (opts.trace_band(cycle), &trace_misses),
    );
    let name = |m: usize| spec.modes[m].name.clone();
    let inputs = spec.input_ranges(&tally.ranges);
    let totals = Totals::of_modes(
        (tables.integrals, tables.per_100km, tables.units),
        info.output_unit.clone(),
        &inputs[spec.traction_input()],
        violations,
    );
    ModalForwardSummary {
        headline: Headline::of(
            info,
            spec.modes[0].model.params(),
            &totals.integrals,
            cycle.distance(),
        ),
        run: CycleInfo::new(info, cycle, cycle.duration()),
        distance_driven_m: tally.distance_driven,
        relative_degree: spec.r_max(),
        engine: opts.engine.clone(),
        samples,
        dt_s: opts.dt,
        bounds: opts.bounds,
        driver: DriverSummary {
            kp: opts.kp,
            ki: opts.ki,
            response_rad_s: opts.response,
            feedforward: opts.feedforward,
            anti_windup_tracking_time_s: Some(anti_windup_rate(opts.kp, opts.ki))
                .filter(|k| *k > 0.0)
                .map(|k| 1.0 / k),
        },
        integrator: IntegratorSummary {
            method: opts.method,
            rtol: opts.rtol,
            atol: opts.atol,
            stats,
        },
        totals,
        inputs,
        modes: ForwardModes {
            per_mode: spec
                .modes
                .iter()
                .zip(&tally.time)
                .map(|(m, t)| ModeTime {
                    name: m.name.clone(),
                    time_s: *t,
                    relative_degree: m.model.info().relative_degree,
                })
                .collect(),
            switches: switches.len(),
            transitions: switches
                .iter()
                .map(|&(t, a, b)| ModeSwitch {
                    t,
                    from: name(a),
                    to: name(b),
                })
                .collect(),
        },
        trace_misses,
        trace_miss_speed_tolerance: opts.trace_band(cycle).speed_mps,
        trace_miss_time_tolerance_s: opts.trace_band(cycle).time_s,
        max_abs_tracking_error: tally.max_err,
        rms_tracking_error: (tally.sum_sq / samples as f64).sqrt(),
        engine_operating_points: tally.operating.map(|op| op.finish(info, opts.dt)),
        columns: names
            .iter()
            .zip(units)
            .map(|(n, u)| Column {
                name: n.clone(),
                unit: u.clone(),
            })
            .collect(),
        signals: Vec::new(),
        provenance: None,
        warnings,
    }
}

/// The warnings of a forward run with modes: demands no mode absorbs (naming the farthest one's input, value,
/// mode and time), trace misses.
fn warnings(
    (spec, opts): (&ModalSpec<'_>, &ForwardOptions),
    (violations, farthest): (&[[f64; 2]], Option<Demand>),
    (band, misses): (Tolerance, &[[f64; 2]]),
) -> Vec<String> {
    let mut warnings = Vec::new();
    if let Some((t, m, demand, bound)) = farthest.filter(|_| !violations.is_empty()) {
        let what = match opts.bounds {
            Bounds::Enforce => "clipped",
            Bounds::Ignore => "applied as demanded, not clipped",
        };
        let mode = &spec.modes[m];
        let input = &spec.inputs[mode.free_input];
        let unit = input
            .unit
            .as_deref()
            .map_or(String::new(), |u| format!(" {u}"));
        warnings.push(format!(
            "the driver's demand leaves the bounds of the mode's free input, and no mode absorbs it, in {}; \
             {what}; the farthest at t = {} s: `{}` = {}{unit} demanded in mode `{}` (bound {})",
            describe_intervals(violations),
            fmt_sig(t, 6),
            input.name,
            fmt_sig(demand, 4),
            mode.name,
            fmt_sig(bound, 4)
        ));
    }
    warnings.extend(super::trace::miss_warning(band, misses));
    warnings
}

impl ModalForwardSummary {
    /// Human-readable summary (what `invsim forward` prints for a model with modes).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        if let Some(h) = &self.headline {
            h.write_text(&mut s);
        }
        self.run.write_model(&mut s);
        let _ = writeln!(s, "engine: {} (modes)", self.engine);
        crate::signals::write_signal_uses(&mut s, &self.signals);
        let _ = writeln!(s, "cycle: {}", self.run.cycle);
        let _ = writeln!(s, "duration: {} s", fmt_sig(self.run.duration_s, 6));
        let _ = writeln!(
            s,
            "distance: {} m (driven {} m)",
            fmt_sig(self.run.distance_m, 6),
            fmt_sig(self.distance_driven_m, 6)
        );
        let _ = writeln!(
            s,
            "samples: {}  dt: {} s",
            self.samples,
            fmt_sig(self.dt_s, 6)
        );
        let d = &self.driver;
        let _ = writeln!(
            s,
            "driver: PI on the error to the raw cycle, kp {}, ki {}, response {} rad/s, feed-forward {}, bounds {}; \
             its request goes to the free input of the mode in force",
            fmt_sig(d.kp, 4),
            fmt_sig(d.ki, 4),
            fmt_sig(d.response_rad_s, 4),
            if d.feedforward { "on" } else { "off" },
            self.bounds.as_str()
        );
        let g = &self.integrator;
        let _ = writeln!(
            s,
            "integrator: {} (rtol {:e}, atol {:e}), {} steps, {} rejected, {} evaluations",
            g.method.as_str(),
            g.rtol,
            g.atol,
            g.stats.accepted,
            g.stats.rejected,
            g.stats.evaluations
        );
        let t = &self.totals;
        write_integrals(
            &mut s,
            (
                &t.integrals,
                self.headline.as_ref().map(|h| h.output.as_str()),
            ),
            &t.integral_units,
            &t.integrals_per_100km,
        );
        for i in &self.inputs {
            write_input_range(
                &mut s,
                (&i.name, i.unit.as_deref()),
                [i.min, i.max],
                [i.lower_bound, i.upper_bound],
            );
        }
        let _ = writeln!(s, "time per mode:");
        for m in self.modes.per_mode.iter().filter(|m| m.time_s > 0.0) {
            let _ = writeln!(
                s,
                "  {:<16} {:>10.2} s  (r = {})",
                m.name, m.time_s, m.relative_degree
            );
        }
        let _ = writeln!(s, "switches: {}", self.modes.switches);
        write_intervals(&mut s, "input bound violations", &t.input_bound_violations);
        if let Some(op) = &self.engine_operating_points {
            op.write_text(&mut s);
        }
        write_intervals(&mut s, "trace misses", &self.trace_misses);
        let u = unit_suffix(t.output_unit.as_deref());
        let _ = writeln!(
            s,
            "max abs tracking error: {}{u}",
            fmt_sig(self.max_abs_tracking_error, 3)
        );
        let _ = writeln!(
            s,
            "rms tracking error: {}{u}",
            fmt_sig(self.rms_tracking_error, 3)
        );
        if let Some(p) = &self.provenance {
            p.write_text(&mut s);
        }
        for w in &self.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        s
    }
}
