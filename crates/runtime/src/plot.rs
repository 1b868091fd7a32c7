//! SVG plot of a run, as Figs. 5 and 7 of Fröberg & Nielsen (2004): the raw cycle speed and the smoothed
//! reference y_d over time (top), the computed input with its bounds (bottom).
//!
//! Long runs are thinned for drawing: each of at most [`MAX_BUCKETS`] time buckets keeps its smallest and
//! largest value, so peaks (e.g. of the input at gear-change corners) survive.

use std::path::Path;

use plotters::prelude::*;
use thiserror::Error;

use crate::cycle::Cycle;
use crate::inverse::SimulationResult;

/// Width and height of the SVG in pixels.
pub const SIZE: (u32, u32) = (1000, 750);

/// At most this many min/max buckets per series are drawn.
pub const MAX_BUCKETS: usize = 2000;

const MPS_TO_KMH: f64 = 3.6;

/// Why a plot could not be written.
#[derive(Debug, Error)]
pub enum PlotError {
    #[error("nothing to plot: the result has no samples")]
    Empty,
    #[error("cannot draw the plot {path}: {message}")]
    Draw { path: String, message: String },
}

/// Draw `result` (and the raw `cycle` it followed) into an SVG file at `path`.
pub fn plot_svg(result: &SimulationResult, cycle: &Cycle, path: &Path) -> Result<(), PlotError> {
    if result.is_empty() {
        return Err(PlotError::Empty);
    }
    let fail = |e: &dyn std::fmt::Display| PlotError::Draw {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let t = result.time();
    let (t0, t1) = (t[0], t[t.len() - 1]);
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    // A speed output is drawn in km/h; the reference of another output (a boost pressure) in its own unit, the
    // cycle mapped through the same offset and scale.
    let map = result.reference;
    let speed = map.is_identity();
    let raw_value = |s: f64| {
        if speed {
            s * MPS_TO_KMH
        } else {
            map.offset + map.scale * s
        }
    };
    let (y_label, raw_label, yd_label, quantity) = if speed {
        (
            "speed [km/h]",
            "cycle [km/h]",
            "y_d (smoothed) [km/h]",
            "speed",
        )
    } else {
        (
            "reference y_d",
            "cycle, as reference offset + scale * v",
            "y_d (smoothed)",
            "reference",
        )
    };

    // Top panel: raw cycle and y_d, in km/h.
    let raw = raw_points(cycle, (t0, t1), raw_value);
    let yd_kmh: Vec<f64> = result
        .yd(0)
        .unwrap_or(&[])
        .iter()
        .map(|v| if speed { v * MPS_TO_KMH } else { *v })
        .collect();
    let yd_pts = thin(t, &yd_kmh);
    let (lo, hi) = range(raw.iter().map(|p| p.1).chain(yd_pts.iter().map(|p| p.1)));
    let (lo, hi) = pad(if speed { lo.min(0.0) } else { lo }, hi);

    // Bottom panel: input and bounds.
    let u = result.input();
    let u_pts = thin(t, u);
    let [umin, umax] = result.input_bounds;
    let (ulo, uhi) = range(u.iter().copied().chain(umin).chain(umax));
    let (ulo, uhi) = pad(ulo, uhi);
    let input = &result.summary.totals.input;

    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let (top, bottom) = root.split_vertically(SIZE.1 / 2);

    let mut chart = ChartBuilder::on(&top)
        .caption(
            format!(
                "{} on {}: {quantity} (look-ahead a = {} s)",
                result.summary.run.model, result.summary.run.cycle, result.summary.lookahead_s
            ),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, lo..hi)
        .map_err(|e| fail(&e))?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(y_label)
        .draw()
        .map_err(|e| fail(&e))?;
    chart
        .draw_series(LineSeries::new(raw, BLACK.stroke_width(1)))
        .map_err(|e| fail(&e))?
        .label(raw_label)
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    chart
        .draw_series(LineSeries::new(yd_pts, RED.stroke_width(2)))
        .map_err(|e| fail(&e))?
        .label(yd_label)
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| fail(&e))?;

    let mut chart = ChartBuilder::on(&bottom)
        .caption(
            format!("input {input} (bounds reported, not clipped)"),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, ulo..uhi)
        .map_err(|e| fail(&e))?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(input.as_str())
        .draw()
        .map_err(|e| fail(&e))?;
    chart
        .draw_series(LineSeries::new(u_pts, BLUE.stroke_width(1)))
        .map_err(|e| fail(&e))?
        .label(input.as_str())
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    for (bound, name) in [(umin, "lower bound"), (umax, "upper bound")] {
        if let Some(b) = bound {
            chart
                .draw_series(LineSeries::new([(t0, b), (t1, b)], MAGENTA.stroke_width(1)))
                .map_err(|e| fail(&e))?
                .label(format!("{name} {b}"))
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MAGENTA));
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| fail(&e))?;
    root.present().map_err(|e| fail(&e))?;
    Ok(())
}

/// The raw cycle's points within [t0, t1] (piecewise linear, its own breakpoints), through `value`, held
/// beyond its ends (as the smoother does).
fn raw_points(cycle: &Cycle, (t0, t1): (f64, f64), value: impl Fn(f64) -> f64) -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = cycle
        .time
        .iter()
        .zip(&cycle.speed)
        .filter(|(&ti, _)| ti >= t0 && ti <= t1)
        .map(|(&ti, &s)| (ti, value(s)))
        .collect();
    match v.first() {
        Some(p) if p.0 <= t0 => {}
        _ => v.insert(0, (t0, value(cycle.speed_at(t0)))),
    }
    match v.last() {
        Some(p) if p.0 >= t1 => {}
        _ => v.push((t1, value(cycle.speed_at(t1)))),
    }
    v
}

/// (min, max) of the finite values; (0, 1) if there are none.
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
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

/// Widen [lo, hi] by 5 % (or by 1 if it is a single point).
fn pad(lo: f64, hi: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 0.0 {
        (lo - 0.05 * span, hi + 0.05 * span)
    } else {
        (lo - 1.0, hi + 1.0)
    }
}

/// Points (t_k, v_k), thinned to the min and max of each of at most [`MAX_BUCKETS`] buckets, in time order.
fn thin(t: &[f64], v: &[f64]) -> Vec<(f64, f64)> {
    let n = t.len().min(v.len());
    if n <= 2 * MAX_BUCKETS {
        return t.iter().zip(v).map(|(&a, &b)| (a, b)).collect();
    }
    let mut out = Vec::with_capacity(2 * MAX_BUCKETS + 1);
    for b in 0..MAX_BUCKETS {
        let (s, e) = (b * n / MAX_BUCKETS, (b + 1) * n / MAX_BUCKETS);
        let (mut imin, mut imax) = (s, s);
        for i in s..e {
            if v[i] < v[imin] {
                imin = i;
            }
            if v[i] > v[imax] {
                imax = i;
            }
        }
        let (i, j) = if imin <= imax {
            (imin, imax)
        } else {
            (imax, imin)
        };
        out.push((t[i], v[i]));
        if j != i {
            out.push((t[j], v[j]));
        }
    }
    if out.last().is_some_and(|p| p.0 < t[n - 1]) {
        out.push((t[n - 1], v[n - 1]));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_extremes() {
        let t: Vec<f64> = (0..100_000).map(|k| k as f64 * 0.01).collect();
        let mut v: Vec<f64> = t.iter().map(|x| x.sin()).collect();
        v[54_321] = 10.0;
        let p = thin(&t, &v);
        assert!(p.len() <= 2 * MAX_BUCKETS + 1);
        assert!(p.iter().any(|&(a, b)| a == t[54_321] && b == 10.0));
        assert!(p.windows(2).all(|w| w[0].0 < w[1].0));
    }
}
