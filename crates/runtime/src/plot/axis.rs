//! Axis ranges and ticks: "nice" tick steps (1, 2, 2.5 or 5 × 10^k, as Heckbert, *Nice numbers for graph
//! labels*, Graphics Gems 1990) placed inside the range, and tick labels with just the decimals the step needs.

/// An axis: its range [lo, hi], the tick values inside it and their labels.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Axis {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) ticks: Vec<f64>,
    pub(crate) labels: Vec<String>,
}

impl Axis {
    /// An axis over exactly [lo, hi] with about `target` ticks inside it.
    pub(crate) fn new(lo: f64, hi: f64, target: usize) -> Axis {
        let (lo, hi) = if hi > lo {
            (lo, hi)
        } else {
            (lo - 1.0, lo + 1.0)
        };
        // A nice step can leave only two ticks inside the range: halve the step until there are three.
        let mut step = nice_step((hi - lo) / target.max(1) as f64);
        let mut ticks = ticks_inside(lo, hi, step);
        for _ in 0..3 {
            if ticks.len() >= 3 {
                break;
            }
            step = nice_step(step / 2.0 * (1.0 - 1e-9));
            ticks = ticks_inside(lo, hi, step);
        }
        let labels = tick_labels(&ticks, step);
        Axis {
            lo,
            hi,
            ticks,
            labels,
        }
    }

    /// An axis over the finite `values` widened by 5 % of their span on both sides (margins), with `zero`
    /// included when given (a speed axis starts at 0).
    pub(crate) fn padded(values: impl Iterator<Item = f64>, zero: bool, target: usize) -> Axis {
        let (mut lo, mut hi) = finite_range(values);
        if zero {
            lo = lo.min(0.0);
            hi = hi.max(0.0);
        }
        let span = hi - lo;
        let (lo, hi) = if span > 0.0 {
            (lo - 0.05 * span, hi + 0.05 * span)
        } else {
            let d = if lo != 0.0 { 0.1 * lo.abs() } else { 1.0 };
            (lo - d, hi + d)
        };
        Axis::new(lo, hi, target)
    }

    /// Fraction of the way from lo to hi of `v`.
    pub(crate) fn frac(&self, v: f64) -> f64 {
        (v - self.lo) / (self.hi - self.lo)
    }
}

/// (min, max) of the finite values; (0, 1) if there are none.
pub(crate) fn finite_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo <= hi {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

/// The smallest of 1, 2, 2.5, 5 × 10^k that is ≥ `raw`.
pub(crate) fn nice_step(raw: f64) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let m = [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .find(|&m| m >= norm * (1.0 - 1e-12))
        .unwrap_or(10.0);
    m * mag
}

/// The multiples of `step` within [lo, hi] (a value within 1e-9 steps of an end counts as inside).
fn ticks_inside(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let eps = 1e-9;
    let first = (lo / step - eps).ceil() as i64;
    let last = (hi / step + eps).floor() as i64;
    (first..=last)
        .map(|k| {
            let v = k as f64 * step;
            if v.abs() < step * 1e-9 {
                0.0
            } else {
                v
            }
        })
        .collect()
}

/// Labels of `ticks` spaced by `step`: fixed-point with the decimals of the step (2.5 × 10^k needs one more),
/// or m.mmme±k when the values are very large or very small.
fn tick_labels(ticks: &[f64], step: f64) -> Vec<String> {
    let max = ticks.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let e_step = step.log10().floor() as i32;
    let half = ((step / 10f64.powi(e_step)) - 2.5).abs() < 1e-9;
    if max >= 1e5 || (max > 0.0 && max < 1e-3) {
        let e_max = max.log10().floor() as i32;
        let digits = (e_max - e_step + i32::from(half)).clamp(0, 6) as usize;
        return ticks
            .iter()
            .map(|&v| scientific(v, digits, e_max))
            .collect();
    }
    let decimals = (-e_step + i32::from(half)).max(0) as usize;
    ticks.iter().map(|v| format!("{v:.decimals$}")).collect()
}

/// `v` as m.mmm·10^e with `digits` decimals, written `m.mmme5` (the exponent `e` fixed for all ticks).
fn scientific(v: f64, digits: usize, e: i32) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let m = v / 10f64.powi(e);
    format!("{m:.digits$}e{e}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(0.3), 0.5);
        assert_eq!(nice_step(180.0), 200.0);
        assert_eq!(nice_step(22.0), 25.0);
        assert_eq!(nice_step(1.0), 1.0);
    }

    #[test]
    fn ticks_stay_inside_and_labels_fit_the_step() {
        let a = Axis::new(0.0, 1800.0, 10);
        assert_eq!(a.ticks.first(), Some(&0.0));
        assert_eq!(a.ticks.last(), Some(&1800.0));
        assert!(a.ticks.iter().all(|&t| (0.0..=1800.0).contains(&t)));
        assert_eq!(a.labels[1], "200");
        let b = Axis::new(-0.004, 0.083, 5);
        assert!(b.ticks.iter().all(|&t| (-0.004..=0.083).contains(&t)));
        assert_eq!(b.labels[0], "0.00");
        let c = Axis::new(0.95e5, 1.6e5, 5);
        assert!(c.labels.iter().all(|l| l.ends_with("e5")), "{:?}", c.labels);
        let d = Axis::padded([3.0, 3.0].into_iter(), false, 5);
        assert!(d.lo < 3.0 && d.hi > 3.0 && !d.ticks.is_empty());
    }
}
