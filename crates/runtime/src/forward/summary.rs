//! What `invsim forward` prints and writes with `--summary-json`.

use std::fmt::Write as _;

use serde::Serialize;

use super::options::{Bounds, Method};
use crate::headline::Headline;
use crate::ode::OdeStats;
use crate::operating_points::OperatingPoints;
use crate::provenance::Provenance;
use crate::report::{fmt_sig, unit_suffix, write_intervals, Column, CycleInfo, Totals};

/// The driver as run: gains, feed-forward, anti-windup.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriverSummary {
    pub kp: f64,
    pub ki: f64,
    /// Bandwidth of the engine management's response, rad/s.
    pub response_rad_s: f64,
    pub feedforward: bool,
    /// Tracking time constant T_t of the back-calculation anti-windup, s (`None` without integral action).
    pub anti_windup_tracking_time_s: Option<f64>,
}

/// The integrator as run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IntegratorSummary {
    /// `dopri5` or `rosenbrock23`.
    pub method: Method,
    pub rtol: f64,
    pub atol: f64,
    #[serde(flatten)]
    pub stats: OdeStats,
}

/// What `invsim forward` prints and writes with `--summary-json`; the fields shared with
/// [`crate::Summary`] mean the same.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForwardSummary {
    /// The model's answer in the units people report (models with a `[headline]`; first in the JSON and the
    /// text).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub headline: Option<Headline>,
    /// Model, cycle, duration and the raw cycle's distance (the per-100-km figures use it, as the inverse
    /// simulation does); flattened.
    #[serde(flatten)]
    pub run: CycleInfo,
    /// ∫ y dt over the run (the distance the vehicle drove, when y is its speed).
    pub distance_driven_m: f64,
    pub relative_degree: usize,
    pub engine: String,
    pub samples: usize,
    pub dt_s: f64,
    /// `ignore` or `enforce`.
    pub bounds: Bounds,
    pub driver: DriverSummary,
    pub integrator: IntegratorSummary,
    /// Integrals (by the solver: quadrature states appended to the ODE, independent of the output grid) and
    /// the input applied:
    /// its range, bounds and the intervals where the driver's demand is outside them (applied as it is with
    /// `ignore`, clipped with `enforce`); flattened.
    #[serde(flatten)]
    pub totals: Totals,
    /// Maximal intervals [t_start, t_end] of samples outside the trace tolerance band.
    pub trace_misses: Vec<[f64; 2]>,
    pub trace_miss_speed_tolerance: f64,
    pub trace_miss_time_tolerance_s: f64,
    /// max |y − y_c| and rms (y − y_c) over the samples, y_c the raw cycle.
    pub max_abs_tracking_error: f64,
    pub rms_tracking_error: f64,
    /// The time-weighted engine speed × torque histogram (models with an `[engine]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub engine_operating_points: Option<OperatingPoints>,
    /// The CSV's columns with their units, in order.
    pub columns: Vec<Column>,
    /// Each signal, where it came from and whether the run used it smoothed or raw (models with signals).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub signals: Vec<crate::signals::SignalUse>,
    /// What produced the run (filled in by the command line).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    pub warnings: Vec<String>,
}

impl ForwardSummary {
    /// Human-readable summary, one line per field (what `invsim forward` prints).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        if let Some(h) = &self.headline {
            h.write_text(&mut s);
        }
        self.run.write_model(&mut s);
        let _ = writeln!(s, "engine: {}", self.engine);
        let _ = writeln!(s, "cycle: {}", self.run.cycle);
        let _ = writeln!(s, "duration: {} s", fmt_sig(self.run.duration_s, 6));
        let _ = writeln!(
            s,
            "distance: {} m (driven {} m)",
            fmt_sig(self.run.distance_m, 6),
            fmt_sig(self.distance_driven_m, 6)
        );
        let _ = writeln!(s, "relative degree: {}", self.relative_degree);
        let _ = writeln!(s, "samples: {}", self.samples);
        let _ = writeln!(s, "dt: {} s", fmt_sig(self.dt_s, 6));
        crate::signals::write_signal_uses(&mut s, &self.signals);
        let d = &self.driver;
        let _ = writeln!(
            s,
            "driver: PI on the error to the raw cycle, kp {}, ki {}, response {} rad/s, feed-forward {}, bounds {}",
            fmt_sig(d.kp, 4),
            fmt_sig(d.ki, 4),
            fmt_sig(d.response_rad_s, 4),
            if d.feedforward { "on" } else { "off" },
            self.bounds.as_str()
        );
        let g = &self.integrator;
        let _ = write!(
            s,
            "integrator: {} (rtol {:e}, atol {:e}), {} steps ({} limited by stability), {} rejected, {} evaluations",
            g.method.as_str(),
            g.rtol,
            g.atol,
            g.stats.accepted,
            g.stats.stability_limited,
            g.stats.rejected,
            g.stats.evaluations
        );
        s.push('\n');
        self.totals
            .write_text(&mut s, self.headline.as_ref().map(|h| h.output.as_str()));
        if let Some(op) = &self.engine_operating_points {
            op.write_text(&mut s);
        }
        write_intervals(&mut s, "trace misses", &self.trace_misses);
        let u = unit_suffix(self.totals.output_unit.as_deref());
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
