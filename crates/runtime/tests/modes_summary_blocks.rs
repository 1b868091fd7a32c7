//! The modal summary's reference and engine blocks against independent computations: the smoothed cycle's
//! departure from the legal trace (max and RMS |y_d − y_c| at the grid's samples, y_c interpolated here) and its
//! distance (Simpson's rule here, the trapezoidal rule in the summary), and the engine operating-point
//! histogram's total time and time-weighted mean speed against the run's own n_e column.

use invsim_runtime::modes::{simulate_modes, ModalOptions, Switching};
use invsim_runtime::{Cycle, Smoother};

use crate::modes::support::{five_speed, spec, speed_schedule};

#[test]
fn five_speed_summary_has_the_reference_deviation_and_the_engine_operating_points() {
    let l = five_speed();
    let cycle = Cycle::builtin("nedc").expect("built-in NEDC");
    let dt = 0.1;
    let opts = ModalOptions {
        lookahead: 5.0,
        dt,
        switching: Switching::Reentry,
        transition_time: None,
        verify: false,
        keep_series: true,
        operating_points: true,
    };
    let res =
        simulate_modes(&spec(&l, speed_schedule(&l)), &cycle, &opts).expect("the run succeeds");
    let s = &res.summary;

    // |y_d − y_c| at every sample of the grid, y_c linear between the cycle's samples.
    let sm = Smoother::new(&cycle, 5.0).expect("smoother");
    let n = ((cycle.duration() / dt).round() as usize) + 1;
    let (mut max_abs, mut sum_sq, mut yd) = (0.0f64, 0.0, Vec::with_capacity(n));
    for k in 0..n {
        let t = cycle.time[0] + k as f64 * dt;
        let mut y = [0.0; 1];
        sm.eval(t, &mut y);
        let j = cycle
            .time
            .partition_point(|&tc| tc <= t)
            .clamp(1, cycle.time.len() - 1);
        let w = ((t - cycle.time[j - 1]) / (cycle.time[j] - cycle.time[j - 1])).clamp(0.0, 1.0);
        let yc = cycle.speed[j - 1] + w * (cycle.speed[j] - cycle.speed[j - 1]);
        max_abs = max_abs.max((y[0] - yc).abs());
        sum_sq += (y[0] - yc).powi(2);
        yd.push(y[0]);
    }
    let rms = (sum_sq / n as f64).sqrt();
    assert!(
        (s.reference.reference_max_abs_deviation - max_abs).abs() < 1e-12,
        "{max_abs} vs {s:?}"
    );
    assert!(
        (s.reference.reference_rms_deviation - rms).abs() < 1e-12,
        "{rms}"
    );
    assert!(
        max_abs > 0.5 && max_abs < 2.0,
        "the smoother rounds NEDC's corners: {max_abs} m/s"
    );
    // Simpson's rule over the even number of intervals, then the last one by the trapezoid.
    let m = (n - 1) / 2 * 2;
    let mut simpson = 0.0;
    for k in (0..m).step_by(2) {
        simpson += dt / 3.0 * (yd[k] + 4.0 * yd[k + 1] + yd[k + 2]);
    }
    simpson += (m..n - 1)
        .map(|k| 0.5 * dt * (yd[k] + yd[k + 1]))
        .sum::<f64>();
    let d = s.reference.reference_distance_m;
    assert!((d - simpson).abs() < 1e-3 * simpson, "{d} vs {simpson}");
    assert!(
        (d - s.run.distance_m).abs() < 0.01 * s.run.distance_m,
        "{d} vs the cycle's {}",
        s.run.distance_m
    );

    // The histogram covers the run's span and its mean speed is the run's time-mean n_e (within half a bin).
    let op = s
        .engine_operating_points
        .as_ref()
        .expect("si_engine_5speed declares its engine");
    assert_eq!((op.speed.as_str(), op.torque.as_str()), ("n_e", "T_e"));
    assert!(
        (op.total_time_s - cycle.duration()).abs() < 1e-6,
        "{}",
        op.total_time_s
    );
    let col = res
        .columns
        .iter()
        .position(|c| c == "n_e")
        .expect("an n_e column");
    let ne = &res.data[col];
    let mean_ne: f64 = (0..ne.len() - 1)
        .map(|k| 0.5 * dt * (ne[k] + ne[k + 1]))
        .sum::<f64>()
        / cycle.duration();
    let mut mean_bins = 0.0;
    for (i, row) in op.time_s.iter().enumerate() {
        let centre = 0.5 * (op.speed_edges[i] + op.speed_edges[i + 1]);
        mean_bins += centre * row.iter().sum::<f64>();
    }
    mean_bins /= op.total_time_s;
    let half_bin = 0.5 * (op.speed_edges[1] - op.speed_edges[0]);
    assert!(
        (mean_bins - mean_ne).abs() <= half_bin,
        "{mean_bins} vs {mean_ne} rpm (half bin {half_bin})"
    );
    let text = s.to_text();
    assert!(
        text.contains("reference vs cycle: |y_d - y_c| max 1.16 m/s"),
        "{text}"
    );
    assert!(text.contains("engine operating points:"), "{text}");
}
