//! The sensitivity pass of a stable (non-causal) run: the derivative of the discrete bounded solution η of
//! the collocation equations with respect to the parameters, then the accumulated outputs' integrals
//! differentiated over the run's grid.
//!
//! The run's η at the collocation nodes solves F(η; p) = 0 (`crate::stable`): per interval j the
//! Hermite–Simpson residual and the boundary rows,
//!
//! ```text
//! R_j = η_{j+1} − η_j − h/6 (q_j + 4 q_{j+½} + q_{j+1}),   η_{j+½} = (η_j + η_{j+1})/2 + h/8 (q_j − q_{j+1}),
//! W_a (η_0 − η_a(p)) = 0,   W_b (η_K − η_b(p)) = 0,
//! ```
//!
//! η_a, η_b the equilibria q(η; p) = 0 for the constant reference before and after the smoother's support.
//!
//! By the implicit function theorem (Rudin, *Principles of Mathematical Analysis*, Thm. 9.28) the nodes'
//! sensitivities S = dη/dp solve (∂F/∂η) S = −∂F/∂p: the Newton matrix of the collocation equations (a
//! band matrix, factorised once, one right-hand side per parameter), here with the exact ∂q/∂η of the
//! model's symbolic partial derivatives instead of the solver's difference quotients. With A = ∂q/∂η and
//! B = ∂q/∂p (total through x = ψ⁻¹(ξ, η) and u, [`super::point`]) at the nodes and midpoints:
//!
//! ```text
//! ∂R_j/∂η_j     = −I − h/6 (A_j + 4 A_{j+½} (I/2 + h/8 A_j)),
//! ∂R_j/∂η_{j+1} =  I − h/6 (A_{j+1} + 4 A_{j+½} (I/2 − h/8 A_{j+1})),
//! −∂R_j/∂p      =  h/6 (B_j + 4 (B_{j+½} + h/8 A_{j+½} (B_j − B_{j+1})) + B_{j+1}),
//! −∂(W_a (η_0 − η_a))/∂p = W_a dη_a/dp,   dη_a/dp = −A(η_a)⁻¹ B(η_a)   (and likewise at the end).
//! ```
//!
//! The projections W_a, W_b move with p too, but their derivative multiplies η_0 − η_a (η_K − η_b), which the
//! pre- and post-actuation make smaller than the stable inversion's tolerance: it is neglected. Between the
//! nodes the run evaluates η by the cubic Hermite interpolant of (η_j, q_j); its derivative is the interpolant
//! of (S_j, Ṡ_j) with Ṡ_j = A_j S_j + B_j. The integrals ∫ o dt ≈ Σ dt·(o_k + o_{k+1})/2 over the run's
//! reported samples are differentiated term by term, do/dp from [`super::point`] as in the causal pass.

use invsim_model_api::InverseModel;
use nalgebra::DMatrix;

use super::pass::{Along, Wanted};
use super::point::Point;
use super::sample::{At, Block, Samples};
use crate::error::RunError;
use crate::inverse::SimulateError;
use crate::stable::{Band, Collocation, CollocationPoint, StableError, StableRun};

/// Samples per block of the reference's columns (the run's block size: the same numbers).
const BLOCK: usize = 4096;

/// A finished stable run: its stable inversion and the samples it reports, (k_lo, k_hi) (the cycle's, or the
/// whole extended grid with `include_extension`).
#[derive(Clone, Copy)]
pub(crate) struct StableFigures<'a> {
    pub run: &'a StableRun,
    pub window: (usize, usize),
}

/// ∂(∫ o_a dt)/∂p_c for every accumulated output a and wanted parameter c (`[a][c]`), over the reported
/// samples of the stable run.
pub(crate) fn integral_gradients<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    along: &Along<'_>,
    StableFigures {
        run: stable,
        window,
    }: StableFigures<'_>,
) -> Result<Vec<Vec<f64>>, SimulateError> {
    let nodes = node_sensitivities(
        wanted,
        &Collocation::of(wanted.model, along.smoother, stable),
    )?;
    let info = wanted.model.info();
    let (r, nw) = (info.relative_degree, info.n_w());
    let grid = along.grid;
    let samples = grid.samples();
    let mut acc = Accumulator::new(wanted, stable, &nodes);
    let mut block = Block::new(BLOCK.min(samples), r, nw);
    let mut k0 = 0;
    while k0 < samples {
        let len = (k0 + BLOCK).min(samples) - k0;
        if k0 <= window.1 && k0 + len > window.0 {
            block.fill(along.smoother, grid, (k0, len));
            for i in (0..len).filter(|i| (window.0..=window.1).contains(&(k0 + i))) {
                let first = k0 + i == window.0;
                acc.sample(wanted, block.at(i), first, 0.5 * grid.dt)?;
            }
        }
        k0 += len;
    }
    Ok(acc.samples.sums.integrals())
}

/// ∂q/∂η (`a`, m × m row-major) and ∂q/∂p (`b`, m × P row-major) at one point, total through x = ψ⁻¹(ξ, η)
/// and u.
struct Partials {
    a: Vec<f64>,
    b: Vec<f64>,
}

/// The partials at `point` (`x`, `u_prev`: the last point's state and input, the guesses of a numerically
/// solved inverse, updated).
fn partials<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    point: &CollocationPoint<'_>,
    (x, u_prev): (&mut [f64], &mut f64),
) -> Result<Partials, SimulateError> {
    let model = wanted.model;
    let info = model.info();
    let (r, m) = (info.relative_degree, info.n_eta);
    let model_err = |source| SimulateError::from(RunError::Model { t: point.t, source });
    let (xi, yr) = (&point.yd[..r], point.yd[r]);
    let u = model
        .invert_from(xi, point.eta, point.w, yr, x, *u_prev)
        .map_err(model_err)?;
    *u_prev = u;
    let with = (&info.eta_states[..], wanted.grid);
    let at = Point::new(model, (x, point.w, u), with, Default::default()).map_err(model_err)?;
    let l = *at.layout();
    let mut e = vec![0.0; m];
    let mut a = vec![0.0; m * m];
    for c in 0..m {
        e[c] = 1.0;
        let dir = at.direction(&e, None);
        e[c] = 0.0;
        for i in 0..m {
            a[i * m + c] = at.row_change(l.eta(i), &dir, None);
        }
    }
    let np = wanted.params.len();
    let mut b = vec![0.0; m * np];
    let zero = vec![0.0; m];
    for (c, &p) in wanted.params.iter().enumerate() {
        let dir = at.direction(&zero, Some(p));
        for i in 0..m {
            b[i * np + c] = at.row_change(l.eta(i), &dir, Some(p));
        }
    }
    Ok(Partials { a, b })
}

/// dη_eq/dp = −(∂q/∂η)⁻¹ ∂q/∂p (m × P row-major) at the equilibrium `eta` of the constant reference of
/// `point` (implicit function theorem on q(η_eq; p) = 0).
fn equilibrium_sensitivity<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    point: &CollocationPoint<'_>,
) -> Result<DMatrix<f64>, SimulateError> {
    let info = wanted.model.info();
    let (m, np) = (info.n_eta, wanted.params.len());
    let (mut x, mut u) = (vec![0.0; info.n_states()], f64::NAN);
    let d = partials(wanted, point, (&mut x, &mut u))?;
    let a = DMatrix::from_row_slice(m, m, &d.a);
    let b = DMatrix::from_row_slice(m, np, &d.b);
    a.lu().solve(&(-b)).ok_or_else(|| {
        StableError::StableInversion {
            reason: format!(
                "∂q/∂η is singular at the equilibrium for t = {} s: its sensitivities are undefined",
                point.t
            ),
        }
        .into()
    })
}

/// S_j and Ṡ_j at every node (`[j][c][i]`: node j, parameter c, component i).
struct NodeSensitivities {
    m: usize,
    np: usize,
    s: Vec<f64>,
    sdot: Vec<f64>,
}

impl NodeSensitivities {
    /// S_c and Ṡ_c at node j.
    fn at(&self, j: usize, c: usize) -> (&[f64], &[f64]) {
        let o = (j * self.np + c) * self.m;
        (&self.s[o..o + self.m], &self.sdot[o..o + self.m])
    }
}

/// The nodes' sensitivities by the implicit function theorem on the collocation equations (module docs).
fn node_sensitivities<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    colloc: &Collocation<'_, M>,
) -> Result<NodeSensitivities, SimulateError> {
    let info = wanted.model.info();
    let (m, np, k) = (info.n_eta, wanted.params.len(), colloc.intervals());
    let mut x = vec![0.0; info.n_states()];
    let mut u = f64::NAN;
    let nodes = (0..=k)
        .map(|j| partials(wanted, &colloc.node(j), (&mut x, &mut u)))
        .collect::<Result<Vec<Partials>, SimulateError>>()?;
    let (band, mut rhs) = assemble(wanted, colloc, &nodes)?;
    let mut s = vec![0.0; (k + 1) * np * m];
    let mut sdot = vec![0.0; (k + 1) * np * m];
    for (c, col) in rhs.iter_mut().enumerate() {
        band.solve(col);
        for (j, d) in nodes.iter().enumerate() {
            let o = (j * np + c) * m;
            s[o..o + m].copy_from_slice(&col[j * m..(j + 1) * m]);
            for i in 0..m {
                let a_s: f64 = (0..m).map(|l| d.a[i * m + l] * col[j * m + l]).sum();
                sdot[o + i] = a_s + d.b[i * np + c];
            }
        }
    }
    Ok(NodeSensitivities { m, np, s, sdot })
}

/// The factorised ∂F/∂η and the right-hand sides −∂F/∂p (one column of F's rows per parameter).
fn assemble<M: InverseModel + ?Sized>(
    wanted: &Wanted<'_, M>,
    colloc: &Collocation<'_, M>,
    nodes: &[Partials],
) -> Result<(Band, Vec<Vec<f64>>), SimulateError> {
    let info = wanted.model.info();
    let (m, np, k, h) = (
        info.n_eta,
        wanted.params.len(),
        colloc.intervals(),
        colloc.h(),
    );
    let plan = colloc.plan();
    let ms = m - plan.unstable;
    let n = (k + 1) * m;
    let mut band = Band::new(n, ms + m - 1, 2 * m - 1 - ms);
    let mut rhs = vec![vec![0.0; n]; np];
    let ends = [(&plan.w_a, 0, 0), (&plan.w_b, k, ms + k * m)];
    for (end, (rows, j, row0)) in ends.into_iter().enumerate() {
        let deq = equilibrium_sensitivity(wanted, &colloc.equilibrium(end))?;
        for a in 0..rows.nrows() {
            for i in 0..m {
                band.set(row0 + a, j * m + i, rows[(a, i)]);
            }
            for (c, col) in rhs.iter_mut().enumerate() {
                col[row0 + a] = (0..m).map(|i| rows[(a, i)] * deq[(i, c)]).sum();
            }
        }
    }
    let mut eta_mid = vec![0.0; m];
    let mut x = vec![0.0; info.n_states()];
    let mut u = f64::NAN;
    for j in 0..k {
        let mid = partials(wanted, &colloc.midpoint(j, &mut eta_mid), (&mut x, &mut u))?;
        interval(
            &mut band,
            &mut rhs,
            (&nodes[j], &mid, &nodes[j + 1]),
            (j, m, ms, h),
        );
    }
    band.factor().map_err(|col| {
        SimulateError::from(StableError::StableInversion {
            reason: format!(
                "the collocation equations' matrix is singular (column {col} of {n}): the solution's \
                 sensitivities are undefined"
            ),
        })
    })?;
    Ok((band, rhs))
}

/// Interval j's rows: ∂R_j/∂η_j, ∂R_j/∂η_{j+1} into `band` and −∂R_j/∂p into `rhs` (module docs).
fn interval(
    band: &mut Band,
    rhs: &mut [Vec<f64>],
    (pa, pm, pb): (&Partials, &Partials, &Partials),
    (j, m, ms, h): (usize, usize, usize, f64),
) {
    let np = rhs.len();
    let row0 = ms + j * m;
    for c in 0..m {
        for i in 0..m {
            let (mut sa, mut sb) = (0.0, 0.0);
            for l in 0..m {
                let delta = if l == i { 0.5 } else { 0.0 };
                sa += pm.a[c * m + l] * (delta + h / 8.0 * pa.a[l * m + i]);
                sb += pm.a[c * m + l] * (delta - h / 8.0 * pb.a[l * m + i]);
            }
            let id = if c == i { 1.0 } else { 0.0 };
            band.set(
                row0 + c,
                j * m + i,
                -id - h / 6.0 * (pa.a[c * m + i] + 4.0 * sa),
            );
            band.set(
                row0 + c,
                (j + 1) * m + i,
                id - h / 6.0 * (pb.a[c * m + i] + 4.0 * sb),
            );
        }
        for (p, col) in rhs.iter_mut().enumerate() {
            let dmid: f64 = (0..m)
                .map(|l| pm.a[c * m + l] * h / 8.0 * (pa.b[l * np + p] - pb.b[l * np + p]))
                .sum();
            col[row0 + c] =
                h / 6.0 * (pa.b[c * np + p] + 4.0 * (pm.b[c * np + p] + dmid) + pb.b[c * np + p]);
        }
    }
}

/// The grid pass's state: η and S (ne × P, column-major) at the sample, and what every pass carries ([`Samples`]: the last sample's
/// state and input, the integrals' derivatives).
struct Accumulator<'s> {
    stable: &'s StableRun,
    nodes: &'s NodeSensitivities,
    eta: Vec<f64>,
    s: Vec<f64>,
    samples: Samples,
}

impl<'s> Accumulator<'s> {
    fn new<M: InverseModel + ?Sized>(
        wanted: &Wanted<'_, M>,
        stable: &'s StableRun,
        nodes: &'s NodeSensitivities,
    ) -> Accumulator<'s> {
        let info = wanted.model.info();
        let (na, np) = (wanted.accumulate.len(), wanted.params.len());
        Accumulator {
            stable,
            nodes,
            eta: vec![0.0; info.n_eta],
            s: vec![0.0; info.n_eta * np],
            samples: Samples::new(info.n_states(), na, np),
        }
    }

    /// The sample at time t (column i of the block's `yd` and `w`): η and S by the Hermite interpolants, the
    /// inverse, the outputs' derivatives and the trapezoidal rule's term dt·(do_(k−1) + do_k)/2 (`half`:
    /// dt/2; none at the `first` reported sample).
    fn sample<M: InverseModel + ?Sized>(
        &mut self,
        wanted: &Wanted<'_, M>,
        at: At<'_>,
        first: bool,
        half: f64,
    ) -> Result<(), SimulateError> {
        let t = at.0;
        self.stable.solution.eval(t, &mut self.eta);
        let point = self
            .samples
            .point((wanted.model, wanted.grid), at, &self.eta)?;
        let half = (!first).then_some(half);
        let (j, weights) = self.stable.solution.hermite(t);
        for c in 0..wanted.params.len() {
            self.interpolate(j, c, weights);
        }
        self.samples
            .add_outputs(&point, (wanted.params, wanted.accumulate), &self.s, half);
        self.samples.recycle(point);
        Ok(())
    }

    /// S_c(t) into column c of `self.s` (ne × P, column-major): the Hermite interpolant of (S_j, Ṡ_j),
    /// (S_{j+1}, Ṡ_{j+1}) with `weights`.
    fn interpolate(&mut self, j: usize, c: usize, [h00, h10, h01, h11]: [f64; 4]) {
        let ((sa, da), (sb, db)) = (self.nodes.at(j, c), self.nodes.at(j + 1, c));
        let ne = sa.len();
        for (i, v) in self.s[c * ne..(c + 1) * ne].iter_mut().enumerate() {
            *v = h00 * sa[i] + h10 * da[i] + h01 * sb[i] + h11 * db[i];
        }
    }
}
