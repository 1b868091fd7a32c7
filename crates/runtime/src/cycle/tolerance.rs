//! The speed tolerance a regulation allows around a drive cycle's trace, and the band it makes.
//!
//! The regulations let the driven speed lie anywhere between two limits built from the trace `v_c` (linear
//! between its samples, held outside them):
//!
//! ```text
//! upper(t) = max { v_c(s) : |s − t| ≤ Δt } + Δv,      lower(t) = min { v_c(s) : |s − t| ≤ Δt } − Δv
//! ```
//!
//! with Δv = 2 mph and Δt = 1 s for the EPA's cycles (40 CFR 86.115-78(c): "the upper limit is 2 mph higher
//! than the highest point on the trace within 1 second of the given time; the lower limit is 2 mph lower than
//! the lowest point on the trace within 1 second"), and Δv = 2 km/h, Δt = 1 s for the NEDC (UNECE R83,
//! Annex 4a, 6.1.3.4) and the WLTC (UN GTR 15, Annex 6, 2.6.8.3).

/// The half-widths of a cycle's tolerance band: speed Δv (m/s) and time Δt (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Δv, m/s.
    pub speed_mps: f64,
    /// Δt, s.
    pub time_s: f64,
    /// Where it comes from: `EPA` (±2 mph, ±1 s), `UNECE` (±2 km/h, ±1 s) or `user`.
    pub source: &'static str,
}

/// Largest speed tolerance accepted, km/h: a band wider than the speeds of a car says nothing.
pub const MAX_TOLERANCE_KMH: f64 = 100.0;
/// Largest time tolerance accepted, s.
pub const MAX_TOLERANCE_S: f64 = 60.0;

/// A tolerance outside its range: what was given and what is accepted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "tolerance {what} = {value}: expected a finite number from 0 to {max} {unit} (the regulations use \
     ±2 km/h or ±2 mph and ±1 s)"
)]
pub struct ToleranceError {
    pub what: &'static str,
    pub value: String,
    pub max: f64,
    pub unit: &'static str,
}

impl Tolerance {
    /// ±2 mph, ±1 s: 40 CFR 86.115-78(c) (UDDS, HWFET, US06 and the other EPA schedules). 1 mph = 0.44704 m/s.
    pub const EPA: Tolerance = Tolerance {
        speed_mps: 2.0 * 0.44704,
        time_s: 1.0,
        source: "EPA",
    };
    /// ±2 km/h, ±1 s: UNECE R83 Annex 4a (NEDC) and UN GTR 15 Annex 6 (WLTC).
    pub const UNECE: Tolerance = Tolerance {
        speed_mps: 2.0 / 3.6,
        time_s: 1.0,
        source: "UNECE",
    };

    /// A user's tolerance, `speed_kmh` km/h and `time_s` s, each finite, ≥ 0 and at most
    /// [`MAX_TOLERANCE_KMH`] / [`MAX_TOLERANCE_S`].
    pub fn new(speed_kmh: f64, time_s: f64) -> Result<Tolerance, ToleranceError> {
        let check = |what, value: f64, max, unit| {
            if (0.0..=max).contains(&value) {
                Ok(())
            } else {
                Err(ToleranceError {
                    what,
                    value: crate::numfmt::num(value),
                    max,
                    unit,
                })
            }
        };
        check("speed", speed_kmh, MAX_TOLERANCE_KMH, "km/h")?;
        check("time", time_s, MAX_TOLERANCE_S, "s")?;
        Ok(Tolerance {
            speed_mps: speed_kmh / 3.6,
            time_s,
            source: "user",
        })
    }

    /// Text for messages: `EPA ±2 mph, ±1 s` or `user ±3 km/h, ±0.5 s`.
    pub fn describe(&self) -> String {
        let speed = if self.source == "EPA" {
            format!("±{} mph", crate::numfmt::num(self.speed_mps / 0.44704))
        } else {
            format!("±{} km/h", crate::numfmt::num(self.speed_mps * 3.6))
        };
        format!(
            "{} {speed}, ±{} s",
            self.source,
            crate::numfmt::num(self.time_s)
        )
    }
}
