//! `--window T0:T1`: a figure cut to the seconds T0…T1 of its run (T0 < T1, both inside the run); every
//! curve keeps its points inside the window and one on either side, so that it reaches the window's edges,
//! and each panel's scale comes from the points inside.

use super::error::PlotError;
use super::figure::{Figure, Series};

/// `T0:T1` in seconds, finite with T0 < T1.
pub fn parse_window(given: &str) -> Result<(f64, f64), PlotError> {
    let bad = |why: &str| PlotError::Window {
        given: given.to_string(),
        why: why.to_string(),
    };
    let (a, b) = given
        .split_once(':')
        .ok_or_else(|| bad("expected T0:T1 in seconds, e.g. 200:400"))?;
    let number = |t: &str| t.trim().parse::<f64>().ok().filter(|v| v.is_finite());
    let (Some(t0), Some(t1)) = (number(a), number(b)) else {
        return Err(bad(
            "T0 and T1 must be finite numbers of seconds, e.g. 200:400",
        ));
    };
    if t0 >= t1 {
        return Err(bad("T0 must be less than T1"));
    }
    Ok((t0, t1))
}

/// Refuse a window that leaves the run's span `(start, end)`.
pub fn check_window((t0, t1): (f64, f64), (start, end): (f64, f64)) -> Result<(), PlotError> {
    let slack = 1e-9 * (end - start).abs().max(1.0);
    if t0 < start - slack || t1 > end + slack {
        return Err(PlotError::Window {
            given: format!("{t0}:{t1}"),
            why: format!("the run spans {start} … {end} s; choose a window inside it"),
        });
    }
    Ok(())
}

impl Figure {
    /// The figure cut to `window` (see the module docs); a window outside the figure's run is an error.
    pub fn windowed(mut self, window: (f64, f64)) -> Result<Figure, PlotError> {
        check_window(window, self.x_range)?;
        self.x_range = window;
        for panel in &mut self.panels {
            for s in &mut panel.series {
                cut(s, window);
            }
        }
        if let Some(sc) = &mut self.scatter {
            sc.points.retain(|p| p.t >= window.0 && p.t <= window.1);
            sc.note_window(window);
        }
        Ok(self)
    }
}

/// Keep the points of `s` inside `(t0, t1)` and the nearest one outside on each side.
fn cut(s: &mut Series, (t0, t1): (f64, f64)) {
    let first = s.points.partition_point(|p| p.0 < t0).saturating_sub(1);
    let end = (s.points.partition_point(|p| p.0 <= t1) + 1).min(s.points.len());
    if first >= end {
        s.points.clear();
        return;
    }
    s.points = s.points[first..end].to_vec();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_are_checked() {
        assert_eq!(parse_window("200:400").unwrap(), (200.0, 400.0));
        for bad in ["400:200", "5:5", "a:3", "200", "0:inf"] {
            assert!(parse_window(bad).is_err(), "{bad}");
        }
        assert!(check_window((0.0, 1180.0), (0.0, 1180.0)).is_ok());
        assert!(check_window((-1.0, 10.0), (0.0, 1180.0)).is_err());
        assert!(check_window((10.0, 1200.0), (0.0, 1180.0)).is_err());
    }

    #[test]
    fn a_cut_curve_keeps_one_point_beyond_each_edge() {
        let mut s = Series {
            label: String::new(),
            color: "#000",
            width: 1.0,
            dashed: false,
            points: (0..10).map(|k| (k as f64, k as f64)).collect(),
        };
        cut(&mut s, (2.5, 5.0));
        assert_eq!(s.points.first(), Some(&(2.0, 2.0)));
        assert_eq!(s.points.last(), Some(&(6.0, 6.0)));
    }
}
