//! Checks of an inverse run's options against its cycle: a look-ahead too long for the cycle is refused, and a
//! smoothed reference whose distance differs from the cycle's by more than 1 % is warned about.

use super::error::SimulateError;
use crate::cycle::Cycle;
use crate::numfmt::num;
use crate::smoother::Smoother;

/// Largest look-ahead a as a fraction of the cycle's duration: with a = duration/4 the kernel's window 2a
/// already spans half the cycle; beyond it the reference no longer resembles the cycle (a = 5000 s on the
/// 1180 s NEDC gives a flat 1.8 m/s).
pub const MAX_LOOKAHEAD_FRACTION: f64 = 0.25;

/// Relative difference of the smoothed reference's distance from the cycle's above which the run warns.
pub const DISTANCE_WARNING: f64 = 0.01;

/// `Err(LookaheadTooLong)` if a > [`MAX_LOOKAHEAD_FRACTION`] · duration.
pub(super) fn check_lookahead(lookahead: f64, duration: f64) -> Result<(), SimulateError> {
    let max = MAX_LOOKAHEAD_FRACTION * duration;
    if lookahead > max {
        return Err(SimulateError::LookaheadTooLong {
            lookahead,
            duration,
            max,
        });
    }
    Ok(())
}

/// 4-point Gauss–Legendre nodes on [−1, 1] and their weights (Abramowitz & Stegun, Table 25.4).
const GAUSS4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

/// A warning when ∫ y_d dt over the cycle differs from the cycle's distance by more than
/// [`DISTANCE_WARNING`] (`smoother` without a reference map, so y_d is the smoothed speed).
///
/// The convolution moves speed only across the cycle's ends: ∫_{t0}^{t1} (k * y_c) dt = ∫ y_c(s) W(s) ds with
/// W(s) = ∫_{t0}^{t1} k(t − s) dt = 1 except within a of an end, so |∫ y_d − ∫ y_c| ≤ 4 a v_max; below 1 % of
/// the distance nothing is computed. Otherwise ∫ y_d dt is taken by 4-point Gauss–Legendre on panels of
/// width a/2 (y_d is C∞ and varies on the scale a).
pub(super) fn reference_distance_warning(smoother: &Smoother, cycle: &Cycle) -> Option<String> {
    let (distance, a) = (cycle.distance(), smoother.lookahead());
    if 4.0 * a * cycle.max_speed() <= DISTANCE_WARNING * distance {
        return None;
    }
    let (t0, t1) = (cycle.time[0], cycle.time[cycle.time.len() - 1]);
    let panels = ((t1 - t0) / (0.5 * a)).ceil().clamp(1.0, 1e6);
    let h = (t1 - t0) / panels;
    let mut y = [0.0];
    let mut sum = 0.0;
    for p in 0..panels as usize {
        let mid = t0 + (p as f64 + 0.5) * h;
        for (x, w) in GAUSS4 {
            smoother.eval(mid + 0.5 * h * x, &mut y);
            sum += 0.5 * h * w * y[0];
        }
    }
    let rel = (sum - distance).abs() / distance.max(f64::MIN_POSITIVE);
    (rel > DISTANCE_WARNING).then(|| {
        format!(
            "the smoothed reference y_d covers {} m, the cycle {} m ({} % apart): the look-ahead {} s smooths \
             over the cycle's ends; the per-100-km figures use the cycle's distance",
            num(sum),
            num(distance),
            num((100.0 * rel * 10.0).round() / 10.0),
            num(a)
        )
    })
}
