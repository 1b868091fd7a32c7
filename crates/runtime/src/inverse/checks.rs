//! Checks of an inverse run's options against its cycle: a look-ahead too long for the cycle is refused, and a
//! smoothed reference whose distance differs from the cycle's by more than 1 % is warned about.

use super::error::SimulateError;
use crate::cycle::Cycle;
use crate::kernel::Kernel;
use crate::numfmt::num;
use crate::smoother::Smoother;

/// Largest look-ahead a as a fraction of the cycle's duration: with a = duration/4 the kernel's window 2a
/// already spans half the cycle; beyond it the reference no longer resembles the cycle (a = 5000 s on the
/// 1180 s NEDC gives a flat 1.8 m/s).
pub const MAX_LOOKAHEAD_FRACTION: f64 = 0.25;

/// Relative difference of the smoothed reference's distance from the cycle's above which the run warns.
pub const DISTANCE_WARNING: f64 = 0.01;

/// The shortest look-ahead, as a multiple of dt: the kernel's window [t − a, t + a] spans at least one output
/// step, else the grid samples the smoothed cycle too coarsely for its transitions (si_engine on the NEDC at
/// dt = 0.1 s: fuel +0.4 % at a = dt/2, +4 % at dt/10, +44 % at dt/100).
pub const MIN_LOOKAHEAD_PER_DT: f64 = 0.5;

/// `Err(LookaheadTooLong)` if a > [`MAX_LOOKAHEAD_FRACTION`] · duration, `Err(LookaheadTooShort)` if
/// a < [`MIN_LOOKAHEAD_PER_DT`] · dt (checked once the grid is known to fit the cycle).
pub(crate) fn check_lookahead(lookahead: f64, duration: f64, dt: f64) -> Result<(), SimulateError> {
    let min = MIN_LOOKAHEAD_PER_DT * dt;
    if lookahead < min {
        return Err(SimulateError::LookaheadTooShort { lookahead, dt, min });
    }
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

/// Panels of the Gauss–Legendre rule over the kernel's support [−a, a] in [`smoothed_distance`].
const DISTANCE_PANELS: usize = 64;

/// ∫_{t0}^{t1} y_d dt for y_d = k * y_c, the cycle's speed y_c held at its end values outside [t0, t1].
///
/// The integral of a convolution is the convolution of the integral: with Y(t) = ∫_{t0}^{t} y_c ds (the
/// distance covered by t, piecewise quadratic), ∫_{t0}^{t1} (k * y_c) dt = (k * Y)(t1) − (k * Y)(t0)
/// = ∫_{−a}^{a} k(τ) (Y(t1 − τ) − Y(t0 − τ)) dτ — one integral over the kernel's support, whatever the
/// cycle's length, by 4-point Gauss–Legendre on [`DISTANCE_PANELS`] panels (Y is C¹, k is C∞).
pub(crate) fn smoothed_distance(cycle: &Cycle, kernel: &Kernel) -> f64 {
    let (time, speed) = (&cycle.time, &cycle.speed);
    let n = time.len().min(speed.len());
    if n == 0 {
        return f64::NAN;
    }
    let mut cumulative = Vec::with_capacity(n);
    let mut d = 0.0;
    cumulative.push(0.0);
    for i in 1..n {
        d += 0.5 * (speed[i - 1] + speed[i]) * (time[i] - time[i - 1]);
        cumulative.push(d);
    }
    // Y(t): the held end speeds outside the cycle, the trapezoid of the partial segment inside.
    let covered = |t: f64| -> f64 {
        let i = time[..n].partition_point(|&x| x <= t);
        if i == 0 {
            return speed[0] * (t - time[0]);
        }
        if i == n {
            return cumulative[n - 1] + speed[n - 1] * (t - time[n - 1]);
        }
        let (ta, tb, va, vb) = (time[i - 1], time[i], speed[i - 1], speed[i]);
        let dt = t - ta;
        let v = va + (vb - va) * (dt / (tb - ta));
        cumulative[i - 1] + 0.5 * (va + v) * dt
    };
    let (t0, t1, a) = (time[0], time[n - 1], kernel.half_width());
    let h = 2.0 * a / DISTANCE_PANELS as f64;
    let mut sum = 0.0;
    for p in 0..DISTANCE_PANELS {
        let mid = -a + (p as f64 + 0.5) * h;
        for (x, w) in GAUSS4 {
            let tau = mid + 0.5 * h * x;
            sum += 0.5 * h * w * kernel.value(tau) * (covered(t1 - tau) - covered(t0 - tau));
        }
    }
    sum
}

/// A warning when ∫ y_d dt over the cycle differs from the cycle's distance by more than
/// [`DISTANCE_WARNING`] (`smoother` without a reference map, so y_d is the smoothed speed).
///
/// The convolution moves speed only across the cycle's ends: ∫_{t0}^{t1} (k * y_c) dt = ∫ y_c(s) W(s) ds with
/// W(s) = ∫_{t0}^{t1} k(t − s) dt, and W − 1_{[t0, t1]} is zero except within a of an end, where it is at most
/// 1 in size, so |∫ y_d − ∫ y_c| ≤ 2 a (v_0 + v_1), v_0 and v_1 the largest |y_c| within a of either end
/// ([`end_speeds`]); below 1 % of the distance nothing is computed (a cycle that starts and ends at rest for
/// a). Otherwise ∫ y_d dt comes from [`smoothed_distance`].
pub(super) fn reference_distance_warning(smoother: &Smoother, cycle: &Cycle) -> Option<String> {
    let (distance, a) = (cycle.distance(), smoother.lookahead());
    let [v0, v1] = end_speeds(cycle, a);
    if 2.0 * a * (v0 + v1) <= DISTANCE_WARNING * distance {
        return None;
    }
    let sum = smoothed_distance(cycle, &Kernel::new(a));
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

/// The largest |y_c| on [t0 − a, t0 + a] and on [t1 − a, t1 + a] (y_c held at its end values outside the
/// cycle): the piecewise-linear y_c takes its extremes on an interval at its samples or at the interval's
/// ends, so the samples inside with the one on either side bound it.
fn end_speeds(cycle: &Cycle, a: f64) -> [f64; 2] {
    let (time, speed) = (&cycle.time, &cycle.speed);
    let n = time.len().min(speed.len());
    let (Some(&t0), Some(&t1)) = (time.first(), time[..n].last()) else {
        return [f64::NAN; 2];
    };
    let largest = |c: f64| {
        let lo = time[..n].partition_point(|&x| x < c - a).saturating_sub(1);
        let hi = (time[..n].partition_point(|&x| x <= c + a) + 1).min(n);
        speed[lo..hi].iter().fold(0.0_f64, |m, v| m.max(v.abs()))
    };
    [largest(t0), largest(t1)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_{t0}^{t1} y_d dt by 4-point Gauss–Legendre on panels of a/8 over the whole cycle, y_d evaluated by the
    /// smoother itself: the independent reference for [`smoothed_distance`].
    fn quadrature_of_the_smoother(cycle: &Cycle, a: f64) -> f64 {
        let smoother = Smoother::new(cycle, a).expect("valid cycle");
        let (t0, t1) = (cycle.time[0], cycle.time[cycle.time.len() - 1]);
        let panels = ((t1 - t0) / (a / 8.0)).ceil() as usize;
        let h = (t1 - t0) / panels as f64;
        let mut y = [0.0];
        let mut sum = 0.0;
        for p in 0..panels {
            let mid = t0 + (p as f64 + 0.5) * h;
            for (x, w) in GAUSS4 {
                smoother.eval(mid + 0.5 * h * x, &mut y);
                sum += 0.5 * h * w * y[0];
            }
        }
        sum
    }

    #[test]
    fn the_smoothed_distance_equals_quadrature_of_the_smoothed_speed() {
        let nedc = Cycle::builtin("nedc").expect("built in");
        // Speeds that do not start or end at rest: the held end values enter both sides.
        let csv = "time_s,speed_mps\n0,3\n10,10\n30,8\n40,5\n";
        let moving = Cycle::from_csv_str("moving", csv).expect("valid cycle");
        for (cycle, a) in [
            (&nedc, 5.0),
            (&nedc, 60.0),
            (&nedc, 0.3),
            (&moving, 4.0),
            (&moving, 1.0),
        ] {
            let exact = smoothed_distance(cycle, &Kernel::new(a));
            let reference = quadrature_of_the_smoother(cycle, a);
            let rel = (exact - reference).abs() / reference;
            assert!(rel < 1e-9, "a = {a}: {exact} vs {reference} ({rel:e})");
        }
        // The smoothing moves distance only near the ends: on the NEDC (at rest at both ends) with a = 5 s
        // the two agree with the cycle's own distance to far better than the 1 % the warning looks for.
        let d = smoothed_distance(&nedc, &Kernel::new(5.0));
        assert!((d - nedc.distance()).abs() < 1e-6 * nedc.distance(), "{d}");
    }

    /// The bound that skips the quadrature holds: |∫ y_d − ∫ y_c| ≤ 2a (v_0 + v_1) with the speeds near the
    /// ends, on cycles at rest and moving at their ends, and it is 0 for the NEDC (at rest for 5 s at both).
    #[test]
    fn the_end_speeds_bound_the_distance_the_smoothing_moves() {
        let nedc = Cycle::builtin("nedc").expect("built in");
        let csv = "time_s,speed_mps\n0,3\n10,10\n30,8\n40,5\n";
        let moving = Cycle::from_csv_str("moving", csv).expect("valid cycle");
        assert_eq!(end_speeds(&moving, 4.0), [10.0, 8.0]);
        assert_eq!(end_speeds(&moving, 12.0), [10.0, 10.0]);
        assert_eq!(end_speeds(&nedc, 5.0), [0.0, 0.0]);
        for (cycle, a) in [
            (&moving, 4.0),
            (&moving, 1.0),
            (&moving, 15.0),
            (&nedc, 60.0),
        ] {
            let moved = (smoothed_distance(cycle, &Kernel::new(a)) - cycle.distance()).abs();
            let [v0, v1] = end_speeds(cycle, a);
            assert!(
                moved <= 2.0 * a * (v0 + v1),
                "a = {a}: {moved} > {}",
                2.0 * a * (v0 + v1)
            );
            assert!(moved > 0.0 || v0 + v1 == 0.0);
        }
    }
}
