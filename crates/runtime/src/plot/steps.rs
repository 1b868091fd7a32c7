//! Step curves: a piecewise-constant series (the gear, the mode, the engine's on/off band) drawn as held
//! values with vertical corners where it changes.

/// The points of a step curve of v over t: each value held until the next change.
pub(super) fn steps(t: &[f64], v: &[f64]) -> Vec<(f64, f64)> {
    let n = t.len().min(v.len());
    let mut pts = Vec::new();
    for k in 0..n {
        if k == 0 {
            pts.push((t[0], v[0]));
        } else if v[k] != v[k - 1] {
            pts.push((t[k], v[k - 1]));
            pts.push((t[k], v[k]));
        }
    }
    if n > 1 {
        pts.push((t[n - 1], v[n - 1]));
    }
    pts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_hold_each_value_until_it_changes() {
        let p = steps(&[0.0, 1.0, 2.0, 3.0], &[1.0, 1.0, 2.0, 2.0]);
        assert_eq!(p, vec![(0.0, 1.0), (2.0, 1.0), (2.0, 2.0), (3.0, 2.0)]);
    }
}
