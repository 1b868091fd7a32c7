//! The minimum of a cost over one decided input's bounds [lo, hi], as the ECMS strategy needs it at every
//! sample: the cost at `n` evenly spaced points, then, around the best of them, safeguarded successive
//! parabolic interpolation (Brent, *Algorithms for Minimization without Derivatives*, 1973, ch. 5: the vertex
//! of the parabola through the three best points, a golden-section step where the vertex leaves the bracket
//! or cannot be formed). A cost that is a parabola is minimised exactly by the first vertex; the search stops
//! when a step moves less than tol = 10⁻⁹ of the bounds' range, when a vertex's cost differs from the best
//! point's by less than 10⁻¹⁴ of it (the cost's rounding: further vertices would only follow its noise, a
//! smooth minimum being located to about √ε of its curvature scale either way), or after [`MAX_REFINE`]
//! steps. An infeasible point (the free input beyond its bounds, no solution) costs +∞.
//!
//! Two places where the minimum commonly lies would make the golden-section steps creep, about 40 of them to
//! close a grid cell to tol, and are found directly instead:
//!
//! - **The feasible set's edge.** Where the best grid point's neighbour is infeasible and the cost tells by
//!   how much (a signed margin g(d), ≤ 0 feasible, the free input's excess over its bounds beyond: continuous
//!   in d), the edge g(d) = 0 between them is found by regula falsi with the Illinois modification (Dowell &
//!   Jarratt, BIT 1971) to tol, keeping the feasible side; it becomes the bracket's end.
//! - **A bracket's end.** Where the best point is an end of the bracket (a bound, or the edge), the cost one
//!   step 2 tol inwards decides: not below, the end is the minimum to tol (the cost is unimodal within its
//!   grid cell, as the refinement assumes everywhere); below, the refinement goes on from there.

/// Most refinement steps after the grid (and most steps of the search for the feasible edge).
pub(crate) const MAX_REFINE: usize = 60;

/// The relative change of the cost below which a parabolic step has converged: its rounding (a few hundred
/// units in the last place of a sum of a few terms).
const FLAT: f64 = 1e-14;

/// 2 − φ: the golden-section fraction.
const GOLDEN: f64 = 0.381_966_011_250_105_1;

/// The cost at a point and the signed margin of its feasibility: (cost, g), the cost +∞ where infeasible or
/// without a solution, g ≤ 0 where feasible and > 0 beyond (NaN where not known: no edge search).
pub(crate) type Probe = (f64, f64);

/// The minimiser of `f` over [lo, hi] from a grid of `n` ≥ 3 points and the refinement: (argument, cost), or
/// `None` where every grid point costs +∞. No feasibility margin: an infeasible neighbour is closed on by
/// the refinement's golden-section steps.
pub(crate) fn minimise(
    f: &mut dyn FnMut(f64) -> f64,
    bounds: (f64, f64),
    n: usize,
) -> Option<(f64, f64)> {
    minimise_probed(&mut |d| (f(d), f64::NAN), bounds, n)
}

/// [`minimise`] of a cost that also gives its feasibility margin ([`Probe`]): the feasible edge next to the
/// best grid point found by regula falsi on the margin.
pub(crate) fn minimise_probed(
    f: &mut dyn FnMut(f64) -> Probe,
    (lo, hi): (f64, f64),
    n: usize,
) -> Option<(f64, f64)> {
    let at = |i: usize| grid_point((lo, hi), n, i);
    let mut best: Option<(usize, f64)> = None;
    let mut probes = Vec::with_capacity(n);
    for i in 0..n {
        let p = f(at(i));
        probes.push(p);
        if p.0.is_finite() && best.is_none_or(|(_, b)| p.0 < b) {
            best = Some((i, p.0));
        }
    }
    let (i, fx) = best?;
    let tol = 1e-9 * (hi - lo).max(f64::MIN_POSITIVE);
    let x = (at(i), probes[i].1);
    // The bracket: the best point's neighbours (the best point itself at an end of the bounds), an
    // infeasible one moved onto the feasible edge.
    let mut side = |j: Option<usize>| match j.filter(|&j| j < n) {
        None => (at(i), fx),
        Some(j) => match probes[j] {
            (c, g) if !c.is_finite() && g > 0.0 && g.is_finite() && x.1 <= 0.0 => {
                edge(f, (x.0, x.1, fx), (at(j), g), tol)
            }
            (c, _) => (at(j), c),
        },
    };
    let a = side(i.checked_sub(1));
    let b = side(Some(i + 1));
    // The edge may be cheaper than the grid point: then it is the best point, an end of its bracket.
    let (a, x, b) = if a.1 < fx {
        (a, a, (at(i), fx))
    } else if b.1 < fx {
        ((at(i), fx), b, b)
    } else {
        (a, (at(i), fx), b)
    };
    Some(refine(f, a, x, b, tol))
}

/// Point i of the grid of `n` ≥ 2 evenly spaced points over [lo, hi] that [`minimise_probed`] evaluates
/// first (the last exactly hi).
pub(crate) fn grid_point((lo, hi): (f64, f64), n: usize, i: usize) -> f64 {
    if i + 1 == n {
        hi
    } else {
        lo + (hi - lo) / (n - 1) as f64 * i as f64
    }
}

/// The index of `d` in that grid where d is one of its points (bit for bit), else `None`.
pub(crate) fn grid_index(bounds: (f64, f64), n: usize, d: f64) -> Option<usize> {
    let (lo, hi) = bounds;
    let f = (d - lo) / (hi - lo) * (n - 1) as f64;
    if !(f > -0.5 && f < n as f64 - 0.5) {
        return None;
    }
    // The nearest index (f + 0.5 ≥ 0 truncated), then the point itself decides.
    let i = (f + 0.5) as usize;
    (grid_point(bounds, n, i).to_bits() == d.to_bits()).then_some(i)
}

/// The feasible edge g(d) = 0 between `inside` (d, g ≤ 0, its cost) and `outside` (d, g > 0) by regula falsi
/// with the Illinois modification (an end kept twice in a row has its g halved), until the two are within
/// `tol` (a secant point within tol of an end is moved tol from it towards the other, so that the bracket
/// closes once an end stands on the edge): the feasible end, (d, cost).
fn edge(
    f: &mut dyn FnMut(f64) -> Probe,
    (mut p, mut gp, mut cp): (f64, f64, f64),
    (mut q, mut gq): (f64, f64),
    tol: f64,
) -> (f64, f64) {
    let (mut wp, mut wq, mut last) = (1.0, 1.0, 0i8);
    for _ in 0..MAX_REFINE {
        if (q - p).abs() <= tol {
            break;
        }
        let mut d = p - wp * gp * (q - p) / (wq * gq - wp * gp);
        // The secant stands on an end (within tol): a step of tol from it towards the other, and where that
        // crosses the edge the bracket is closed.
        let near = if (d - p).abs() <= tol {
            d = p + tol.copysign(q - p);
            Some(false)
        } else if (d - q).abs() <= tol {
            d = q + tol.copysign(p - q);
            Some(true)
        } else {
            if !(d.is_finite() && (d - p) * (d - q) < 0.0) {
                d = 0.5 * (p + q);
            }
            None
        };
        let (c, g) = f(d);
        let feasible = c.is_finite() && g <= 0.0;
        if near == Some(feasible) {
            if feasible {
                (p, cp) = (d, c);
            }
            break;
        }
        if feasible {
            (p, gp, cp) = (d, g, c);
            wp = 1.0;
            if last == -1 {
                wq *= 0.5;
            }
            last = -1;
        } else {
            // Beyond the bounds, or no solution (g unknown: a bisection's end).
            (q, gq) = (
                d,
                if g.is_finite() {
                    g.max(f64::MIN_POSITIVE)
                } else {
                    gq
                },
            );
            wq = 1.0;
            if last == 1 {
                wp *= 0.5;
            }
            last = 1;
        }
    }
    (p, cp)
}

/// Safeguarded parabolic interpolation in the bracket [a, b] around x (f(x) ≤ f(a), f(b)).
fn refine(
    f: &mut dyn FnMut(f64) -> Probe,
    (mut a, mut fa): (f64, f64),
    (mut x, mut fx): (f64, f64),
    (mut b, mut fb): (f64, f64),
    tol: f64,
) -> (f64, f64) {
    if b - a > 4.0 * tol && (x == a || x == b) {
        // The best point is an end: one step 2 tol inwards decides.
        let u = if x == a { x + 2.0 * tol } else { x - 2.0 * tol };
        let fu = f(u).0;
        if fu.is_nan() || fu >= fx {
            return (x, fx);
        }
        (x, fx) = (u, fu);
    }
    for _ in 0..MAX_REFINE {
        if b - a <= 2.0 * tol {
            break;
        }
        let (u, parabolic) = match vertex((a, fa), (x, fx), (b, fb)) {
            Some(v) if v > a && v < b && (v - x).abs() > 0.0 => (v, true),
            // The larger side, at the golden-section fraction.
            _ if b - x > x - a => (x + GOLDEN * (b - x), false),
            _ => (x - GOLDEN * (x - a), false),
        };
        if (u - x).abs() <= tol {
            // The vertex is where we stand: the minimum, to the tolerance.
            let fu = f(u).0;
            return if fu <= fx { (u, fu) } else { (x, fx) };
        }
        let fu = f(u).0;
        if parabolic && (fu - fx).abs() <= FLAT * fx.abs() {
            // The vertex's cost is the best point's to rounding: the parabola has converged as far as the
            // cost can tell (further vertices would follow its rounding noise).
            return if fu <= fx { (u, fu) } else { (x, fx) };
        }
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
    use super::{grid_index, grid_point, minimise, minimise_probed};

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

    #[test]
    fn grid_points_are_found_by_their_bits_and_nothing_else() {
        for (bounds, n) in [((-200.0, 200.0), 11), ((0.0, 1.0), 41), ((-0.3, 7.7), 2)] {
            for i in 0..n {
                let d = grid_point(bounds, n, i);
                assert_eq!(grid_index(bounds, n, d), Some(i), "{bounds:?} {n} {i}");
                let beside = f64::from_bits(d.to_bits() + 1);
                assert_eq!(grid_index(bounds, n, beside), None, "{bounds:?} {n} {i}");
            }
            let (lo, hi) = bounds;
            for d in [lo - (hi - lo), hi + (hi - lo), f64::NAN, f64::INFINITY] {
                assert_eq!(grid_index(bounds, n, d), None);
            }
        }
        assert_eq!(grid_point((-200.0, 200.0), 11, 10), 200.0);
    }

    #[test]
    fn the_feasible_edge_is_found_by_its_margin_in_few_evaluations() {
        // Feasible where d ≥ 0.437 (margin 0.437 − d), the cost falling towards the edge: the edge, to 10⁻⁹
        // of the range, in the grid's 11 evaluations and a handful more (golden-section steps took about 40).
        let edge = 0.437;
        let mut calls = 0;
        let mut f = |d: f64| {
            calls += 1;
            let g = edge - d;
            (if g <= 0.0 { d * d } else { f64::INFINITY }, g)
        };
        let (x, fx) = minimise_probed(&mut f, (0.0, 1.0), 11).unwrap();
        assert!(x >= edge && x - edge <= 1e-9, "{x}");
        assert_eq!(fx, x * x);
        assert!(calls <= 11 + 8, "{calls} evaluations");
    }
}
