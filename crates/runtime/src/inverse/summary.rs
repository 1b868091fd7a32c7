//! What `invsim simulate` prints and writes with `--summary-json`.

use std::fmt::Write as _;

use serde::Serialize;

use crate::headline::Headline;
use crate::operating_points::OperatingPoints;
use crate::provenance::Provenance;
use crate::reference_deviation::ReferenceDeviation;
use crate::report::{fmt_sig, format_eigenvalues, unit_suffix, Column, CycleInfo, Totals};
use crate::stable::ZeroDynamicsClass;

/// What `invsim simulate` prints and writes with `--summary-json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// The model's answer in the units people report (models with a `[headline]`; first in the JSON and the
    /// text).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub headline: Option<Headline>,
    /// Model, cycle, duration and distance (flattened: the keys `model`, `cycle`, `duration_s`, `distance_m`).
    #[serde(flatten)]
    pub run: CycleInfo,
    pub relative_degree: usize,
    pub engine: String,
    pub samples: usize,
    pub lookahead_s: f64,
    /// How `--lookahead auto` chose `lookahead_s` (absent for a given look-ahead).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lookahead_choice: Option<crate::lookahead::LookaheadChoice>,
    pub dt_s: f64,
    /// How far y_d departs from the cycle and the distance it covers (flattened: `reference_distance_m`,
    /// `reference_max_abs_deviation`, `reference_rms_deviation`).
    #[serde(flatten)]
    pub reference: ReferenceDeviation,
    /// Integrals and the input's range, bounds and bound violations (flattened: `integrals` …
    /// `input_bound_violations`).
    #[serde(flatten)]
    pub totals: Totals,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_abs_tracking_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rms_tracking_error: Option<f64>,
    /// How η was obtained: `"none"` (r = n), `"causal"` (integrated forward) or `"stable"` (the bounded,
    /// non-causal solution of [`crate::stable`]).
    pub inversion: String,
    /// The zero dynamics at the equilibria the reference passes: `none` (r = n), `minimum_phase`,
    /// `non_minimum_phase`, `mixed` or `unknown`.
    pub zero_dynamics_class: ZeroDynamicsClass,
    /// Eigenvalues [re, im] of ∂q/∂η at the equilibrium for the reference's first value.
    pub zero_dynamics_eigenvalues: Vec<[f64; 2]>,
    /// Length of the grid before t_0 (pre-actuation) and after the cycle's end (post-actuation) that the stable
    /// inversion needed, s (0 for a causal run).
    pub pre_actuation_s: f64,
    pub post_actuation_s: f64,
    /// The input the stable inverse needs before t_0 (only where pre-actuation was needed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_before_start: Option<InputBeforeStart>,
    /// Numbers of the stable inversion (only for a stable run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_inversion: Option<StableInversionStats>,
    /// The time-weighted engine speed × torque histogram (models with an `[engine]`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub engine_operating_points: Option<OperatingPoints>,
    /// d figure/d parameter of the integrals, their per-100-km figures and the headline's figures
    /// (`--gradient`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gradient: Option<crate::gradient::Gradient>,
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

/// The input a stable inverse needs before the cycle starts (the pre-actuation, t_start ≤ t < t_0).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InputBeforeStart {
    /// First time of the extended grid, s (t_0 − pre-actuation).
    pub t_start: f64,
    /// The input at t_start: the equilibrium input for the reference's first value.
    pub u_initial: f64,
    /// The input at t_0.
    pub u_at_start: f64,
    /// Smallest and largest input before t_0.
    pub min: f64,
    pub max: f64,
    /// Largest |u − u_initial| before t_0.
    pub max_deviation: f64,
    /// ∫ |u − u_initial| dt over [t_start, t_0] (trapezoidal rule), in input unit · s.
    pub integral_abs_deviation: f64,
    /// First time the input departs from u_initial by more than 1e-4 of its range over the run (before t_0),
    /// or `None` if it does not before t_0: how early the actuator must start to move.
    pub departs_at: Option<f64>,
}

/// Numbers of a stable inversion.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StableInversionStats {
    /// Collocation nodes and their spacing, s.
    pub nodes: usize,
    pub node_spacing_s: f64,
    /// Newton iterations on the finest grid.
    pub newton_iterations: usize,
    /// Estimated discretisation error of η, relative to each component's magnitude.
    pub estimated_error: f64,
    /// Number of unstable eigenvalues of ∂q/∂η (the dimension integrated backward).
    pub unstable_dimension: usize,
}

impl Summary {
    /// Human-readable summary, one line per field (what `invsim simulate` prints).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        if let Some(h) = &self.headline {
            h.write_text(&mut s);
        }
        self.run.write_model(&mut s);
        let _ = writeln!(s, "engine: {}", self.engine);
        let _ = writeln!(s, "cycle: {}", self.run.cycle);
        let _ = writeln!(s, "duration: {} s", fmt_sig(self.run.duration_s, 6));
        let _ = writeln!(s, "distance: {} m", fmt_sig(self.run.distance_m, 6));
        let _ = writeln!(s, "relative degree: {}", self.relative_degree);
        let _ = writeln!(s, "samples: {}", self.samples);
        let _ = writeln!(s, "dt: {} s", fmt_sig(self.dt_s, 6));
        let _ = writeln!(s, "look-ahead: {} s", fmt_sig(self.lookahead_s, 6));
        if let Some(c) = &self.lookahead_choice {
            let _ = writeln!(s, "{}", c.text());
        }
        crate::signals::write_signal_uses(&mut s, &self.signals);
        let output_unit = self.totals.output_unit.as_deref();
        self.reference
            .write_text(&mut s, output_unit, self.run.distance_m);
        self.totals
            .write_text(&mut s, self.headline.as_ref().map(|h| h.output.as_str()));
        if let Some(g) = &self.gradient {
            g.write_text(&mut s);
        }
        if let Some(op) = &self.engine_operating_points {
            op.write_text(&mut s);
        }
        let u = unit_suffix(output_unit);
        if let Some(e) = self.max_abs_tracking_error {
            let _ = writeln!(s, "max abs tracking error: {}{u}", fmt_sig(e, 3));
        }
        if let Some(e) = self.rms_tracking_error {
            let _ = writeln!(s, "rms tracking error: {}{u}", fmt_sig(e, 3));
        }
        if self.zero_dynamics_class != ZeroDynamicsClass::None {
            let _ = write!(s, "zero dynamics: {}", self.zero_dynamics_class.as_str());
            if !self.zero_dynamics_eigenvalues.is_empty() {
                let _ = write!(
                    s,
                    " (eigenvalues at the start, 1/s: {})",
                    format_eigenvalues(&self.zero_dynamics_eigenvalues)
                );
            }
            let _ = writeln!(s, ", inversion: {}", self.inversion);
        }
        if let Some(st) = &self.stable_inversion {
            let _ = writeln!(
                s,
                "stable inversion: {} nodes at {} s, {} Newton iterations, estimated error {}, {} unstable dimension(s)",
                st.nodes,
                fmt_sig(st.node_spacing_s, 4),
                st.newton_iterations,
                fmt_sig(st.estimated_error, 2),
                st.unstable_dimension
            );
            let _ = writeln!(
                s,
                "pre-actuation: {} s, post-actuation: {} s",
                fmt_sig(self.pre_actuation_s, 4),
                fmt_sig(self.post_actuation_s, 4)
            );
        }
        if let Some(p) = &self.input_before_start {
            let iu = unit_suffix(self.totals.input_unit.as_deref());
            let ius = if iu.is_empty() {
                " s".to_string()
            } else {
                format!("{iu} s")
            };
            let _ = write!(
                s,
                "{} before t0: from {}{iu} (at {} s) to {}{iu} at t0, range [{}, {}]{iu}, integral of |u - u_initial| {}{ius}",
                self.totals.input,
                fmt_sig(p.u_initial, 4),
                fmt_sig(p.t_start, 6),
                fmt_sig(p.u_at_start, 4),
                fmt_sig(p.min, 4),
                fmt_sig(p.max, 4),
                fmt_sig(p.integral_abs_deviation, 3)
            );
            match p.departs_at {
                Some(t) => {
                    let _ = writeln!(
                        s,
                        "; it departs from its initial value at t = {} s",
                        fmt_sig(t, 4)
                    );
                }
                None => s.push('\n'),
            }
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

impl InputBeforeStart {
    /// From the samples [t, u] before t_0 (and at t_0, the last), given the input's range over the run and the
    /// grid step; `None` without pre-actuation.
    pub(crate) fn from_samples(
        before_start: &[[f64; 2]],
        [u_min, u_max]: [f64; 2],
        dt: f64,
    ) -> Option<InputBeforeStart> {
        let (&[_, u_at_start], earlier) = before_start.split_last()?;
        if earlier.is_empty() {
            return None;
        }
        let [t_start, u_initial] = earlier[0];
        let (mut lo, mut hi, mut max_deviation, mut integral) =
            (u_at_start, u_at_start, 0.0_f64, 0.0);
        // 1e-4 of the input's range over the run, and above rounding.
        let threshold = (1e-4 * (u_max - u_min).abs()).max(1e-9 * u_initial.abs().max(1.0));
        let mut departs_at = None;
        for (j, &[t, u]) in before_start.iter().enumerate() {
            lo = lo.min(u);
            hi = hi.max(u);
            let dev = (u - u_initial).abs();
            max_deviation = max_deviation.max(dev);
            if dev > threshold && departs_at.is_none() && j + 1 < before_start.len() {
                departs_at = Some(t);
            }
            if j > 0 {
                integral += 0.5 * dt * (dev + (before_start[j - 1][1] - u_initial).abs());
            }
        }
        Some(InputBeforeStart {
            t_start,
            u_initial,
            u_at_start,
            min: lo,
            max: hi,
            max_deviation,
            integral_abs_deviation: integral,
            departs_at,
        })
    }
}
