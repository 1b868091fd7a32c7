//! The minimum of a cost over one decided input's bounds [lo, hi], as the ECMS strategy needs it at every
//! sample: the cost at `n` evenly spaced points, then, around the best of them, safeguarded successive
//! parabolic interpolation (Brent, *Algorithms for Minimization without Derivatives*, 1973, ch. 5: the vertex
//! of the parabola through the three best points, a golden-section step where the vertex leaves the bracket
//! or cannot be formed). A cost that is a parabola is minimised exactly by the first vertex; the search stops
//! when a step moves less than 10⁻⁹ of the bounds' range, or after [`MAX_REFINE`] steps. An infeasible point
//! (the free input beyond its bounds, no solution) costs +∞.

/// Most refinement steps after the grid.
pub(crate) const MAX_REFINE: usize = 60;

/// 2 − φ: the golden-section fraction.
const GOLDEN: f64 = 0.381_966_011_250_105_1;

/// The minimiser of `f` over [lo, hi] from a grid of `n` ≥ 3 points and the refinement: (argument, cost), or
/// `None` where every grid point costs +∞.
pub(crate) fn minimise(
    f: &mut dyn FnMut(f64) -> f64,
    (lo, hi): (f64, f64),
    n: usize,
) -> Option<(f64, f64)> {
    let step = (hi - lo) / (n - 1) as f64;
    let at = |i: usize| if i + 1 == n { hi } else { lo + step * i as f64 };
    let mut best: Option<(usize, f64)> = None;
    let mut costs = Vec::with_capacity(n);
    for i in 0..n {
        let c = f(at(i));
        costs.push(c);
        if c.is_finite() && best.is_none_or(|(_, b)| c < b) {
            best = Some((i, c));
        }
    }
    let (i, fx) = best?;
    // The bracket: the best point's neighbours (the best point itself at an end of the bounds).
    let (a, fa) = if i > 0 {
        (at(i - 1), costs[i - 1])
    } else {
        (at(i), fx)
    };
    let (b, fb) = if i + 1 < n {
        (at(i + 1), costs[i + 1])
    } else {
        (at(i), fx)
    };
    Some(refine(f, (a, fa), (at(i), fx), (b, fb), hi - lo))
}

/// Safeguarded parabolic interpolation in the bracket [a, b] around x (f(x) ≤ f(a), f(b)).
fn refine(
    f: &mut dyn FnMut(f64) -> f64,
    (mut a, mut fa): (f64, f64),
    (mut x, mut fx): (f64, f64),
    (mut b, mut fb): (f64, f64),
    range: f64,
) -> (f64, f64) {
    let tol = 1e-9 * range.max(f64::MIN_POSITIVE);
    for _ in 0..MAX_REFINE {
        if b - a <= 2.0 * tol {
            break;
        }
        let u = match vertex((a, fa), (x, fx), (b, fb)) {
            Some(v) if v > a && v < b && (v - x).abs() > 0.0 => v,
            // The larger side, at the golden-section fraction.
            _ if b - x > x - a => x + GOLDEN * (b - x),
            _ => x - GOLDEN * (x - a),
        };
        if (u - x).abs() <= tol {
            // The vertex is where we stand: the minimum, to the tolerance.
            let fu = f(u);
            return if fu <= fx { (u, fu) } else { (x, fx) };
        }
        let fu = f(u);
        if fu <= fx {
            if u < x {
                (b, fb) = (x, fx);
            } else {
                (a, fa) = (x, fx);
            }
            (x, fx) = (u, fu);
        } else if u < x {
            (a, fa) = (u, fu);
        } else {
            (b, fb) = (u, fu);
        }
    }
    (x, fx)
}

/// The vertex of the parabola through three points (none where they are collinear or a value is infinite).
fn vertex((a, fa): (f64, f64), (x, fx): (f64, f64), (b, fb): (f64, f64)) -> Option<f64> {
    if !(fa.is_finite() && fx.is_finite() && fb.is_finite()) || a == x || x == b {
        return None;
    }
    let p = (x - a) * (x - a) * (fx - fb) - (x - b) * (x - b) * (fx - fa);
    let q = 2.0 * ((x - a) * (fx - fb) - (x - b) * (fx - fa));
    let v = x - p / q;
    (q != 0.0 && v.is_finite()).then_some(v)
}

#[cfg(test)]
mod tests {
    use super::minimise;

    #[test]
    fn a_parabola_is_minimised_exactly() {
        let x0 = 0.123_456_789;
        let mut f = |x: f64| 3.0 * (x - x0) * (x - x0) + 7.0;
        let (x, fx) = minimise(&mut f, (-2.0, 5.0), 11).unwrap();
        assert!((x - x0).abs() < 1e-12, "{x}");
        assert!((fx - 7.0).abs() < 1e-12);
    }

    #[test]
    fn a_smooth_convex_cost_and_a_bound_minimum() {
        // exp(x) − 2x: minimum at ln 2.
        let mut f = |x: f64| x.exp() - 2.0 * x;
        let (x, _) = minimise(&mut f, (-1.0, 3.0), 9).unwrap();
        assert!((x - 2f64.ln()).abs() < 1e-7, "{x}");
        // Increasing on the bounds: the lower bound.
        let mut g = |x: f64| x;
        assert_eq!(minimise(&mut g, (1.0, 2.0), 5).unwrap().0, 1.0);
    }

    #[test]
    fn infeasible_points_are_avoided() {
        // Feasible only on [0.5, 1]; the unconstrained minimum 0 is not: the feasible edge.
        let mut f = |x: f64| if x < 0.5 { f64::INFINITY } else { x * x };
        let (x, _) = minimise(&mut f, (0.0, 1.0), 11).unwrap();
        assert!((x - 0.5).abs() < 1e-9, "{x}");
        let mut none = |_x: f64| f64::INFINITY;
        assert!(minimise(&mut none, (0.0, 1.0), 5).is_none());
    }
}
