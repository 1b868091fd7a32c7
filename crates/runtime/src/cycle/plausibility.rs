//! Plausibility checks on a cycle file's columns: a unit the header declares but the values do not fit. Each
//! finding is a warning ([`Implausible`]) naming the file, the column, the line where it applies, the likely
//! unit and the fix; the command line prints it, and `--strict` makes it an error.
//!
//! What can be detected, and what not:
//! - **Top speed.** No drive cycle reaches [`MAX_PLAUSIBLE_SPEED_MPS`] = 70 m/s (252 km/h): the fastest
//!   regulatory and test cycles stay below 42 m/s (WLTC class 3 extra-high 131.3 km/h, US06 129.2 km/h,
//!   Artemis motorway 150 km/h). A higher top speed whose number is plausible in another unit names it:
//!   km/h in an m/s column up to 252, mph up to 156.6. A km/h column holding m/s values (3.6 times too slow)
//!   or an urban cycle in km/h below 70 in an m/s column cannot be told from a slow cycle and is not reported.
//! - **Acceleration.** A road car's tyres give at most about 1 g (friction coefficient μ ≈ 1 on dry asphalt:
//!   full braking 8–10 m/s², the quickest production cars 0–100 km/h in 2.3 s ≈ 12 m/s² with launch
//!   aids); regulatory cycles stay below 4 m/s² (US06: 3.8 m/s²). A speed that changes faster than
//!   [`MAX_PLAUSIBLE_ACCEL_MPS2`] = 10 m/s², a = Δv/Δt between samples, over two or more consecutive
//!   intervals in the same direction is reported (one interval alone may be a glitch of a logged trace).
//! - **Time in milliseconds.** A cycle is sampled at 1 Hz or 10 Hz; a median time step ≥ 100 is 100 ms or
//!   1 s written in ms when the times read as ms give accelerations a car reaches (a = 1000 Δv/Δt within
//!   10 m/s²) and either the span exceeds a day (86 400 s) or there are at least 10 steps (a few waypoints
//!   far apart, `0,25` and `3600,25`, are a plausible cruise and not reported).

use crate::numfmt::num;

/// Highest top speed of a plausible drive cycle, m/s (252 km/h; see the module docs).
pub const MAX_PLAUSIBLE_SPEED_MPS: f64 = 70.0;
/// Largest plausible acceleration or deceleration of a road car, m/s² (about 1 g; see the module docs).
pub const MAX_PLAUSIBLE_ACCEL_MPS2: f64 = 10.0;
/// Median time step from which a time column may hold milliseconds (see the module docs).
pub const MS_MEDIAN_STEP: f64 = 100.0;
/// A day in seconds: a cycle file spanning more is not a drive cycle in seconds.
const DAY_S: f64 = 86_400.0;
/// Steps from which a median step ≥ [`MS_MEDIAN_STEP`] is a sampled trace rather than a few waypoints.
const MS_MIN_STEPS: usize = 10;

/// A column whose values do not fit the unit its header declares: a warning (see the module docs).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Implausible {
    /// A top speed no drive cycle reaches.
    #[error(
        "{file}: line {line}, column `{column}`: top speed {} {unit} ({} km/h) is beyond any drive cycle \
         (invsim's plausibility limit is 70 m/s = 252 km/h); {}",
        num((*value * 10.0).round() / 10.0), num((*value * factor(unit) * 3.6 * 10.0).round() / 10.0),
        top_speed_fix(*value, unit)
    )]
    TopSpeed {
        file: String,
        line: u64,
        column: String,
        /// The top speed as the file writes it, in `unit`.
        value: f64,
        /// The unit the header declares: "m/s", "km/h" or "mph".
        unit: &'static str,
    },
    /// Accelerations beyond what a car's tyres allow, over two or more consecutive intervals.
    #[error(
        "{file}: line {line}, column `{column}`: the speed changes by {} m/s² over {intervals} intervals from \
         t = {} s ({stretches} such stretch(es) in the file), beyond what a car's tyres allow (invsim's \
         plausibility limit is 10 m/s², about 1 g); {}",
        num((*acceleration * 100.0).round() / 100.0), num(*time), acceleration_fix(*acceleration, unit)
    )]
    Acceleration {
        file: String,
        line: u64,
        column: String,
        /// The stretch's mean acceleration, m/s² (negative: braking).
        acceleration: f64,
        /// Its first time, as the file writes it.
        time: f64,
        intervals: usize,
        /// How many stretches beyond the limit the file has.
        stretches: usize,
        /// The speed column's declared unit.
        unit: &'static str,
    },
    /// Time steps and a span that fit milliseconds, not seconds.
    #[error(
        "{file}: column `{column}`: the median time step is {} and the times span {} ({} days if seconds); \
         the column probably holds milliseconds: divide its times by 1000 (invsim reads time columns in \
         seconds)",
        num(*median_step), num(*span), num((*span / DAY_S * 10.0).round() / 10.0)
    )]
    TimeInMilliseconds {
        file: String,
        column: String,
        median_step: f64,
        span: f64,
    },
}

/// m/s per unit of a speed unit's name.
fn factor(unit: &str) -> f64 {
    match unit {
        "km/h" => 1.0 / 3.6,
        "mph" => 0.44704,
        _ => 1.0,
    }
}

/// The likely unit of a top speed `value` that is implausible in `unit`, and the fix.
fn top_speed_fix(value: f64, unit: &str) -> String {
    let as_kmh = value / 3.6 <= MAX_PLAUSIBLE_SPEED_MPS;
    let as_mph = value * 0.44704 <= MAX_PLAUSIBLE_SPEED_MPS;
    match (unit, as_kmh, as_mph) {
        ("m/s", true, true) => format!(
            "as km/h it would be {} m/s and as mph {} m/s: the column probably holds km/h (or mph); name \
             it `speed_kmh` (or `speed_mph`), or convert its values to m/s",
            num((value / 3.6 * 10.0).round() / 10.0),
            num((value * 0.44704 * 10.0).round() / 10.0)
        ),
        ("m/s" | "mph", true, _) => format!(
            "as km/h it would be {} m/s: the column probably holds km/h; name it `speed_kmh`, or convert its \
             values to {unit}",
            num((value / 3.6 * 10.0).round() / 10.0)
        ),
        _ => format!("no unit invsim reads makes it plausible: check the column's values and its unit ({unit})"),
    }
}

/// The likely cause of an implausible `acceleration` (m/s²) read from a speed column in `unit`.
fn acceleration_fix(acceleration: f64, unit: &str) -> String {
    if unit == "m/s" && acceleration.abs() / 3.6 <= MAX_PLAUSIBLE_ACCEL_MPS2 {
        "as km/h the speeds would change 3.6 times slower: check whether the column holds km/h (name it \
         `speed_kmh`) and whether the time column is in seconds"
            .to_string()
    } else {
        format!("check the speed column's unit ({unit}) and that the time column is in seconds")
    }
}

/// Where the samples of a cycle file come from: for the messages.
pub(super) struct Source<'a> {
    pub file: &'a str,
    pub time_column: &'a str,
    pub speed_column: &'a str,
    /// The speed column's declared unit: "m/s", "km/h" or "mph".
    pub unit: &'static str,
    /// The 1-based line of each sample in the file.
    pub lines: &'a [u64],
}

/// Every plausibility warning of a cycle file's samples: times as read (s), speeds converted to m/s.
pub(super) fn check(src: &Source<'_>, time: &[f64], speed: &[f64]) -> Vec<Implausible> {
    let mut found = Vec::new();
    found.extend(top_speed(src, speed));
    found.extend(acceleration(src, time, speed));
    found.extend(milliseconds(src, time, speed));
    found
}

fn top_speed(src: &Source<'_>, speed: &[f64]) -> Option<Implausible> {
    // `max_by` keeps the last of equal maxima: over the reversed samples, the first at the top speed.
    let (i, &top) = speed
        .iter()
        .enumerate()
        .rev()
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    (top > MAX_PLAUSIBLE_SPEED_MPS).then(|| Implausible::TopSpeed {
        file: src.file.to_string(),
        line: src.lines.get(i).copied().unwrap_or(0),
        column: src.speed_column.to_string(),
        value: top / factor(src.unit),
        unit: src.unit,
    })
}

/// A run of consecutive intervals whose acceleration exceeds the limit in one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stretch {
    /// Index of its first sample.
    start: usize,
    intervals: usize,
    /// Δv/Δt over the whole stretch, m/s².
    mean: f64,
}

/// The stretches of two or more consecutive intervals with |Δv/Δt| > `limit` in one direction, with the
/// times scaled by `time_scale` (s per time unit of the file).
fn stretches(time: &[f64], speed: &[f64], time_scale: f64, limit: f64) -> Vec<Stretch> {
    let direction = |i: usize| {
        let a = (speed[i + 1] - speed[i]) / ((time[i + 1] - time[i]) * time_scale);
        if a > limit {
            1
        } else if a < -limit {
            -1
        } else {
            0
        }
    };
    let n = time.len().min(speed.len()).saturating_sub(1);
    let mut found = Vec::new();
    let mut i = 0;
    while i < n {
        let d = direction(i);
        let mut end = i + 1;
        while d != 0 && end < n && direction(end) == d {
            end += 1;
        }
        if d != 0 && end - i >= 2 {
            let mean = (speed[end] - speed[i]) / ((time[end] - time[i]) * time_scale);
            found.push(Stretch {
                start: i,
                intervals: end - i,
                mean,
            });
        }
        i = end;
    }
    found
}

fn acceleration(src: &Source<'_>, time: &[f64], speed: &[f64]) -> Option<Implausible> {
    let all = stretches(time, speed, 1.0, MAX_PLAUSIBLE_ACCEL_MPS2);
    let worst = all
        .iter()
        .max_by(|a, b| a.mean.abs().total_cmp(&b.mean.abs()))?;
    Some(Implausible::Acceleration {
        file: src.file.to_string(),
        line: src.lines.get(worst.start).copied().unwrap_or(0),
        column: src.speed_column.to_string(),
        acceleration: worst.mean,
        time: time[worst.start],
        intervals: worst.intervals,
        stretches: all.len(),
        unit: src.unit,
    })
}

fn milliseconds(src: &Source<'_>, time: &[f64], speed: &[f64]) -> Option<Implausible> {
    let mut steps: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    let median = steps[(steps.len() - 1) / 2];
    let span = time[time.len() - 1] - time[0];
    let trace = span > DAY_S || steps.len() >= MS_MIN_STEPS;
    let as_ms_plausible = stretches(time, speed, 1e-3, MAX_PLAUSIBLE_ACCEL_MPS2).is_empty();
    (median >= MS_MEDIAN_STEP && trace && as_ms_plausible).then(|| {
        Implausible::TimeInMilliseconds {
            file: src.file.to_string(),
            column: src.time_column.to_string(),
            median_step: median,
            span,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn source(lines: &[u64]) -> Source<'_> {
        Source {
            file: "c.csv",
            time_column: "time_s",
            speed_column: "speed_mps",
            unit: "m/s",
            lines,
        }
    }

    /// Stretches need two intervals in one direction beyond the limit; their mean is Δv/Δt over them.
    #[test]
    fn stretches_of_two_or_more_intervals() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        // One interval of +12 (a glitch), then +11, +13 (a stretch of mean 12), then −11 alone.
        let v = [0.0, 12.0, 12.0, 23.0, 36.0, 25.0, 25.0];
        let s = stretches(&t, &v, 1.0, 10.0);
        assert_eq!(
            s,
            vec![Stretch {
                start: 2,
                intervals: 2,
                mean: 12.0
            }]
        );
        // Read in ms the same samples accelerate 1000 times faster.
        assert_eq!(
            stretches(&t, &[0.0, 0.02, 0.04, 0.04, 0.02, 0.0, 0.0], 1e-3, 10.0).len(),
            2
        );
    }

    /// A 1 Hz trace written in milliseconds is found; waypoints an hour apart are not.
    #[test]
    fn milliseconds_need_a_trace() {
        let lines: Vec<u64> = (2..30).collect();
        let t: Vec<f64> = (0..20).map(|k| 1000.0 * k as f64).collect();
        let v: Vec<f64> = (0..20).map(|k| 0.5 * k as f64).collect();
        let found = milliseconds(&source(&lines), &t, &v).expect("ms");
        assert_eq!(
            found,
            Implausible::TimeInMilliseconds {
                file: "c.csv".into(),
                column: "time_s".into(),
                median_step: 1000.0,
                span: 19000.0
            }
        );
        assert_eq!(
            milliseconds(&source(&lines), &[0.0, 3600.0], &[25.0, 25.0]),
            None
        );
        // A cruise logged every 100 s that starts from rest: read as ms it would accelerate at 125 m/s².
        let t: Vec<f64> = (0..20).map(|k| 100.0 * k as f64).collect();
        let v: Vec<f64> = (0..20).map(|k| (12.5 * k as f64).min(25.0)).collect();
        assert_eq!(milliseconds(&source(&lines), &t, &v), None);
    }

    /// The likely units of a top speed by its value and declared unit.
    #[test]
    fn top_speed_units() {
        assert!(top_speed_fix(131.3, "m/s").contains("km/h (or mph)"));
        assert!(top_speed_fix(200.0, "m/s").contains("probably holds km/h; name it `speed_kmh`"));
        assert!(top_speed_fix(200.0, "mph").contains("probably holds km/h"));
        assert!(top_speed_fix(300.0, "km/h").contains("no unit invsim reads"));
        assert!(top_speed_fix(300.0, "m/s").contains("no unit invsim reads"));
    }
}
