//! The boundary-value problem of stable inversion discretised by Hermite–Simpson collocation and solved by
//! Newton's method on all nodes at once, refined until the Richardson error estimate meets the tolerance (see
//! the method in [`crate::stable`]).

use invsim_model_api::zero_dynamics::{newton, Linearization};
use invsim_model_api::InverseModel;

use super::band::Band;
use super::error::StableError;
use super::plan::Plan;
use crate::report::fmt_sig;
use crate::smoother::Smoother;

/// Largest number of collocation nodes (memory guard: about 100 bytes per node and internal state).
const MAX_NODES: usize = 20_000_000;

/// Newton iterations on the boundary-value problem before giving up.
const MAX_NEWTON: usize = 30;

/// Max over the nodes of |v_i|/scale_i (NaN propagates).
fn scaled_norm(v: &[f64], scale: &[f64]) -> f64 {
    v.chunks_exact(scale.len())
        .flat_map(|node| node.iter().zip(scale).map(|(v, s)| v.abs() / s))
        .fold(0.0_f64, |a, v| {
            if v.is_nan() || a.is_nan() {
                f64::NAN
            } else {
                a.max(v)
            }
        })
}

/// Settings of the stable inversion.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Settings {
    /// Tolerance: Newton stops when the scaled step is below it; the estimated discretisation error must be below
    /// it; the pre- and post-actuation run until the deviation from the equilibria has decayed to it.
    pub tol: f64,
    /// Initial node spacing in seconds (refined until the error estimate meets `tol`).
    pub h0: f64,
    /// Smallest node spacing tried, s.
    pub h_min: f64,
}

/// The stable inverse: η at the nodes t_a + j h and q = η̇ there, interpolated by cubic Hermite polynomials.
#[derive(Debug, Clone)]
pub(crate) struct Solution {
    pub t_a: f64,
    pub h: f64,
    pub m: usize,
    /// Number of intervals K (K + 1 nodes).
    pub k: usize,
    eta: Vec<f64>,
    q: Vec<f64>,
    /// Newton iterations on the finest grid.
    pub iterations: usize,
    /// Estimated discretisation error, scaled by each component's magnitude.
    pub estimated_error: f64,
    /// First node time where the frozen-time linearisation has a different number of unstable eigenvalues.
    pub dichotomy_change: Option<(f64, Vec<[f64; 2]>)>,
}

impl Solution {
    /// η(t) into `out`: the cubic Hermite interpolant of (η_j, η̇_j) (the collocation polynomial).
    pub fn eval(&self, t: f64, out: &mut [f64]) {
        let m = self.m;
        let (j, [h00, h10, h01, h11]) = self.hermite(t);
        let (a, b) = (j * m, (j + 1) * m);
        for (i, o) in out.iter_mut().enumerate().take(m) {
            *o = h00 * self.eta[a + i]
                + h10 * self.q[a + i]
                + h01 * self.eta[b + i]
                + h11 * self.q[b + i];
        }
    }

    /// The interval j of time t and the weights of η_j, η̇_j, η_{j+1}, η̇_{j+1} in the interpolant at t (the
    /// cubic Hermite basis, the derivative weights times h); outside [t_a, t_b] the end value is held.
    pub(crate) fn hermite(&self, t: f64) -> (usize, [f64; 4]) {
        let s = (t - self.t_a) / self.h;
        let j = if s.is_nan() {
            0
        } else {
            (s.floor().max(0.0) as usize).min(self.k - 1)
        };
        let th = (s - j as f64).clamp(0.0, 1.0);
        let (t2, t3) = (th * th, th * th * th);
        let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
        let h10 = (t3 - 2.0 * t2 + th) * self.h;
        let h01 = -2.0 * t3 + 3.0 * t2;
        let h11 = (t3 - t2) * self.h;
        (j, [h00, h10, h01, h11])
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.k + 1
    }

    /// η and q = η̇ at node j (the values the interpolant [`Solution::eval`] joins).
    pub(crate) fn node(&self, j: usize) -> (&[f64], &[f64]) {
        let range = j * self.m..(j + 1) * self.m;
        (&self.eta[range.clone()], &self.q[range])
    }
}

/// Buffers of the Newton matrix's assembly (allocated once per Newton solve).
struct AssemblyWork {
    /// ∂q/∂η at the nodes (row-major m × m each) and at one midpoint.
    nodes: Vec<f64>,
    mid: Vec<f64>,
    work: Vec<f64>,
    qp: Vec<f64>,
    /// ∂R_j/∂η_j and ∂R_j/∂η_{j+1} of one interval.
    d: Vec<f64>,
    e: Vec<f64>,
}

impl AssemblyWork {
    fn new(m: usize, k: usize) -> AssemblyWork {
        AssemblyWork {
            nodes: vec![0.0; (k + 1) * m * m],
            mid: vec![0.0; m * m],
            work: vec![0.0; m],
            qp: vec![0.0; m],
            d: vec![0.0; m * m],
            e: vec![0.0; m * m],
        }
    }
}

/// One discretisation of the boundary-value problem: K intervals of length h from t_a.
pub(super) struct Bvp<'a, M: ?Sized> {
    model: &'a M,
    plan: &'a Plan,
    r: usize,
    m: usize,
    k: usize,
    h: f64,
    /// y_d … y_d^(r) at the nodes and the midpoints: half-node i at t_a + i h/2, row-wise (r + 1 per point).
    yd: Vec<f64>,
    /// The smoothed signal values at the same points, row-wise (`nw` per point).
    w: Vec<f64>,
    nw: usize,
    /// Scale of each component of η (for norms).
    scale: Vec<f64>,
}

impl<'a, M: InverseModel + ?Sized> Bvp<'a, M> {
    pub(super) fn new(model: &'a M, smoother: &Smoother, plan: &'a Plan, k: usize) -> Bvp<'a, M> {
        let info = model.info();
        let (r, m) = (info.relative_degree, info.n_eta);
        let h = (plan.t_b - plan.t_a) / k as f64;
        let points = 2 * k + 1;
        let times: Vec<f64> = (0..points)
            .map(|i| plan.t_a + i as f64 * (h / 2.0))
            .collect();
        let mut cols = vec![vec![0.0; points]; r + 1];
        {
            let mut views: Vec<&mut [f64]> = cols.iter_mut().map(|c| c.as_mut_slice()).collect();
            smoother.eval_grid(&times, Some(h / 2.0), &mut views);
        }
        let mut yd = vec![0.0; points * (r + 1)];
        for (i, row) in yd.chunks_exact_mut(r + 1).enumerate() {
            for (o, c) in row.iter_mut().zip(&cols) {
                *o = c[i];
            }
        }
        let nw = info.n_w();
        let mut w_cols = vec![vec![0.0; points]; nw];
        {
            let mut views: Vec<&mut [f64]> = w_cols.iter_mut().map(|c| c.as_mut_slice()).collect();
            smoother.eval_signals_grid(&times, Some(h / 2.0), &mut views);
        }
        let mut w = vec![0.0; points * nw];
        for (i, row) in w.chunks_exact_mut(nw.max(1)).enumerate().take(points) {
            for (o, c) in row.iter_mut().zip(&w_cols) {
                *o = c[i];
            }
        }
        Bvp {
            model,
            plan,
            r,
            m,
            k,
            h,
            yd,
            w,
            nw,
            scale: vec![1.0; m],
        }
    }

    /// q at half-node i (even: node i/2, odd: a midpoint).
    #[inline]
    fn q(&self, i: usize, eta: &[f64], out: &mut [f64]) {
        let p = &self.yd[i * (self.r + 1)..(i + 1) * (self.r + 1)];
        self.model
            .zero_dynamics(&p[..self.r], eta, self.w_at(i), p[self.r], out);
    }

    /// The signal values at half-node i.
    #[inline]
    fn w_at(&self, i: usize) -> &[f64] {
        &self.w[i * self.nw..(i + 1) * self.nw]
    }

    /// y_d … y_d^(r) and the signal values at half-node i (even: node i/2, odd: a midpoint), as the
    /// collocation equations evaluate them.
    pub(super) fn reference_at(&self, i: usize) -> (&[f64], &[f64]) {
        (
            &self.yd[i * (self.r + 1)..(i + 1) * (self.r + 1)],
            self.w_at(i),
        )
    }

    /// ∂q/∂η at half-node i by forward differences from the value `q0` there, into `jac` (row-major m × m).
    fn jac(
        &self,
        i: usize,
        eta: &[f64],
        q0: &[f64],
        jac: &mut [f64],
        work: &mut [f64],
        qp: &mut [f64],
    ) {
        let m = self.m;
        work.copy_from_slice(eta);
        for c in 0..m {
            let d = 1e-7 * eta[c].abs().max(self.scale[c]);
            work[c] = eta[c] + d;
            self.q(i, work, qp);
            work[c] = eta[c];
            for row in 0..m {
                jac[row * m + c] = (qp[row] - q0[row]) / d;
            }
        }
    }

    /// Component scales from a trajectory: max |η_i| over the nodes, at least 1e-3 of the largest.
    fn set_scale(&mut self, eta: &[f64]) {
        let m = self.m;
        let mut s = vec![0.0_f64; m];
        for node in eta.chunks_exact(m) {
            for (a, v) in s.iter_mut().zip(node) {
                *a = a.max(v.abs());
            }
        }
        let big = s.iter().fold(0.0_f64, |a, v| a.max(*v));
        for v in &mut s {
            *v = if big > 0.0 && big.is_finite() {
                v.max(1e-3 * big)
            } else {
                1.0
            };
        }
        self.scale = s;
    }

    /// The quasi-static guess: the equilibrium of the frozen zero dynamics at every node, by continuation.
    fn quasi_static(&self) -> Vec<f64> {
        let (m, r) = (self.m, self.r);
        let mut eta = vec![0.0; (self.k + 1) * m];
        let mut previous = self.plan.eta_a.clone();
        for j in 0..=self.k {
            let p = &self.yd[2 * j * (r + 1)..(2 * j + 1) * (r + 1)];
            let w = self.w_at(2 * j);
            if let Ok(e) = newton(self.model, &p[..r], w, p[r], previous.clone(), 8) {
                previous = e;
            }
            eta[j * m..(j + 1) * m].copy_from_slice(&previous);
        }
        eta
    }

    /// Residual F(η) (scaled max norm returned) with q at the nodes and midpoints; `eta_mid` and the q's are
    /// filled for the Jacobian.
    fn residual(
        &self,
        eta: &[f64],
        q_nodes: &mut [f64],
        eta_mid: &mut [f64],
        q_mid: &mut [f64],
        f: &mut [f64],
    ) -> f64 {
        let (m, k, h) = (self.m, self.k, self.h);
        for j in 0..=k {
            self.q(
                2 * j,
                &eta[j * m..(j + 1) * m],
                &mut q_nodes[j * m..(j + 1) * m],
            );
        }
        for j in 0..k {
            for i in 0..m {
                let (a, b) = (j * m + i, (j + 1) * m + i);
                eta_mid[j * m + i] = 0.5 * (eta[a] + eta[b]) + h / 8.0 * (q_nodes[a] - q_nodes[b]);
            }
            self.q(
                2 * j + 1,
                &eta_mid[j * m..(j + 1) * m],
                &mut q_mid[j * m..(j + 1) * m],
            );
        }
        let ms = m - self.plan.unstable;
        let big = self.scale.iter().fold(0.0_f64, |a, v| a.max(*v));
        let mut norm = 0.0_f64;
        let mut put = |f: &mut [f64], row: usize, v: f64, s: f64| {
            f[row] = v;
            let x = v.abs() / s;
            norm = if x.is_nan() || norm.is_nan() {
                f64::NAN
            } else {
                norm.max(x)
            };
        };
        for a in 0..ms {
            let v: f64 = (0..m)
                .map(|i| self.plan.w_a[(a, i)] * (eta[i] - self.plan.eta_a[i]))
                .sum();
            put(f, a, v, big);
        }
        for j in 0..k {
            for c in 0..m {
                let (a, b) = (j * m + c, (j + 1) * m + c);
                let v =
                    eta[b] - eta[a] - h / 6.0 * (q_nodes[a] + 4.0 * q_mid[j * m + c] + q_nodes[b]);
                put(f, ms + j * m + c, v, self.scale[c]);
            }
        }
        for b in 0..self.plan.unstable {
            let v: f64 = (0..m)
                .map(|i| self.plan.w_b[(b, i)] * (eta[k * m + i] - self.plan.eta_b[i]))
                .sum();
            put(f, ms + k * m + b, v, big);
        }
        norm
    }

    /// Newton's method on the collocation equations from `eta` (in place); returns the iterations and the final
    /// q at the nodes.
    fn newton(&mut self, eta: &mut Vec<f64>, tol: f64) -> Result<(usize, Vec<f64>), String> {
        let (m, k) = (self.m, self.k);
        let ms = m - self.plan.unstable;
        let n = (k + 1) * m;
        self.set_scale(eta);
        let (kl, ku) = (ms + m - 1, 2 * m - 1 - ms);
        let mut band = Band::new(n, kl, ku);
        let mut q_nodes = vec![0.0; n];
        let mut eta_mid = vec![0.0; k * m];
        let mut q_mid = vec![0.0; k * m];
        let mut f = vec![0.0; n];
        let mut trial = vec![0.0; n];
        let (mut tq, mut tem, mut tqm, mut tf) = (
            vec![0.0; n],
            vec![0.0; k * m],
            vec![0.0; k * m],
            vec![0.0; n],
        );
        let mut jw = AssemblyWork::new(m, k);
        let mut norm = self.residual(eta, &mut q_nodes, &mut eta_mid, &mut q_mid, &mut f);
        if !norm.is_finite() {
            return Err("the zero dynamics are not finite along the starting guess (the quasi-static equilibria)".into());
        }
        // Newton stops two orders of magnitude below the tolerance, so that its error does not pollute the
        // discretisation error estimate; near convergence (scaled step below 1e-3) the factorised Jacobian is
        // kept (the chord method: linear convergence at a rate of the order of the step).
        let newton_tol = 0.01 * tol;
        let mut last_step = f64::INFINITY;
        for iteration in 1..=MAX_NEWTON {
            if last_step <= 1e-3 {
                let mut step: Vec<f64> = f.iter().map(|v| -v).collect();
                band.solve(&mut step);
                let step_norm = scaled_norm(&step, &self.scale);
                if !step_norm.is_finite() {
                    return Err("the Newton step is not finite".into());
                }
                for ((t, x), s) in trial.iter_mut().zip(eta.iter()).zip(&step) {
                    *t = x + s;
                }
                let tn = self.residual(&trial, &mut tq, &mut tem, &mut tqm, &mut tf);
                if tn.is_finite()
                    && (tn < norm || step_norm <= newton_tol)
                    && step_norm < 0.5 * last_step
                {
                    norm = tn;
                    std::mem::swap(eta, &mut trial);
                    std::mem::swap(&mut q_nodes, &mut tq);
                    std::mem::swap(&mut eta_mid, &mut tem);
                    std::mem::swap(&mut q_mid, &mut tqm);
                    std::mem::swap(&mut f, &mut tf);
                    last_step = step_norm;
                    if step_norm <= newton_tol {
                        return Ok((iteration, q_nodes));
                    }
                    continue;
                }
                // The old Jacobian no longer contracts: fall through to a fresh one.
            }
            self.assemble(&mut band, eta, (&q_nodes, &eta_mid, &q_mid), &mut jw);
            band.factor().map_err(|col| {
                format!(
                    "the Newton matrix of the collocation equations is singular (column {col} of {n}): the split \
                     into stable and unstable parts does not fit the zero dynamics along the trajectory"
                )
            })?;
            let mut step: Vec<f64> = f.iter().map(|v| -v).collect();
            band.solve(&mut step);
            let step_norm = scaled_norm(&step, &self.scale);
            if !step_norm.is_finite() {
                return Err("the Newton step is not finite".into());
            }
            // Backtracking: halve the step until the residual decreases (or the step is negligible).
            let mut lambda = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                for ((t, x), s) in trial.iter_mut().zip(eta.iter()).zip(&step) {
                    *t = x + lambda * s;
                }
                let tn = self.residual(&trial, &mut tq, &mut tem, &mut tqm, &mut tf);
                if tn.is_finite() && (tn < norm || lambda * step_norm <= newton_tol) {
                    norm = tn;
                    accepted = true;
                    break;
                }
                lambda *= 0.5;
            }
            if !accepted {
                return Err(format!(
                    "Newton's method stalled in iteration {iteration} (scaled residual {}): the line search found \
                     no decrease",
                    fmt_sig(norm, 3)
                ));
            }
            std::mem::swap(eta, &mut trial);
            std::mem::swap(&mut q_nodes, &mut tq);
            std::mem::swap(&mut eta_mid, &mut tem);
            std::mem::swap(&mut q_mid, &mut tqm);
            std::mem::swap(&mut f, &mut tf);
            last_step = lambda * step_norm;
            if last_step <= newton_tol {
                return Ok((iteration, q_nodes));
            }
        }
        Err(format!(
            "Newton's method did not converge in {MAX_NEWTON} iterations (scaled residual {})",
            fmt_sig(norm, 3)
        ))
    }

    /// The Newton matrix of the collocation equations at `eta` into `band`: the boundary rows W_a, W_b and per
    /// interval the derivatives of R_j by η_j and η_{j+1}, from ∂q/∂η at the nodes and the midpoints.
    fn assemble(
        &self,
        band: &mut Band,
        eta: &[f64],
        (q_nodes, eta_mid, q_mid): (&[f64], &[f64], &[f64]),
        jw: &mut AssemblyWork,
    ) {
        let (m, k, h) = (self.m, self.k, self.h);
        let ms = m - self.plan.unstable;
        // Jacobian: nodes, then per interval the midpoint, assembled into the band matrix.
        for j in 0..=k {
            let (lo, hi) = (j * m, (j + 1) * m);
            self.jac(
                2 * j,
                &eta[lo..hi],
                &q_nodes[lo..hi],
                &mut jw.nodes[j * m * m..(j + 1) * m * m],
                &mut jw.work,
                &mut jw.qp,
            );
        }
        band.clear();
        for a in 0..ms {
            for i in 0..m {
                band.set(a, i, self.plan.w_a[(a, i)]);
            }
        }
        for j in 0..k {
            let (lo, hi) = (j * m, (j + 1) * m);
            self.jac(
                2 * j + 1,
                &eta_mid[lo..hi],
                &q_mid[lo..hi],
                &mut jw.mid,
                &mut jw.work,
                &mut jw.qp,
            );
            let ja = &jw.nodes[j * m * m..(j + 1) * m * m];
            let jb = &jw.nodes[(j + 1) * m * m..(j + 2) * m * m];
            // ∂R_j/∂η_j = −I − h/6 (J_j + 4 J_mid (I/2 + h/8 J_j)),
            // ∂R_j/∂η_{j+1} = I − h/6 (J_{j+1} + 4 J_mid (I/2 − h/8 J_{j+1})).
            for c in 0..m {
                for i in 0..m {
                    let (mut sa, mut sb) = (0.0, 0.0);
                    for l in 0..m {
                        let delta = if l == i { 0.5 } else { 0.0 };
                        sa += jw.mid[c * m + l] * (delta + h / 8.0 * ja[l * m + i]);
                        sb += jw.mid[c * m + l] * (delta - h / 8.0 * jb[l * m + i]);
                    }
                    let id = if c == i { 1.0 } else { 0.0 };
                    jw.d[c * m + i] = -id - h / 6.0 * (ja[c * m + i] + 4.0 * sa);
                    jw.e[c * m + i] = id - h / 6.0 * (jb[c * m + i] + 4.0 * sb);
                }
            }
            let row0 = ms + j * m;
            for c in 0..m {
                for i in 0..m {
                    band.set(row0 + c, j * m + i, jw.d[c * m + i]);
                    band.set(row0 + c, (j + 1) * m + i, jw.e[c * m + i]);
                }
            }
        }
        for b in 0..self.plan.unstable {
            for i in 0..m {
                band.set(ms + k * m + b, k * m + i, self.plan.w_b[(b, i)]);
            }
        }
    }
}

/// Solve the boundary-value problem of [`Plan`] to the tolerance (see the module documentation).
pub(crate) fn solve<M: InverseModel + ?Sized>(
    model: &M,
    smoother: &Smoother,
    plan: &Plan,
    settings: Settings,
) -> Result<Solution, StableError> {
    let m = model.info().n_eta;
    let span = plan.t_b - plan.t_a;
    let fail = |reason: String| StableError::StableInversion { reason };
    if !(span > 0.0 && span.is_finite()) {
        return Err(fail(format!(
            "the extended horizon [{}, {}] s is empty",
            plan.t_a, plan.t_b
        )));
    }
    let mut k = ((span / (2.0 * settings.h0)).ceil() as usize).max(2);
    if k > MAX_NODES {
        return Err(fail(format!(
            "{k} collocation nodes exceed the limit of {MAX_NODES}"
        )));
    }
    // Coarse grid from the quasi-static guess.
    let (mut eta, mut q) = {
        let mut bvp = Bvp::new(model, smoother, plan, k);
        let mut eta = bvp.quasi_static();
        let (_, q) = bvp
            .newton(&mut eta, settings.tol)
            .map_err(|r| fail(format!("on {} nodes: {r}", k + 1)))?;
        (eta, q)
    };
    loop {
        // Halve the spacing, start from the coarse solution (its Hermite interpolant at the new nodes).
        let coarse = Solution {
            t_a: plan.t_a,
            h: span / k as f64,
            m,
            k,
            eta,
            q,
            iterations: 0,
            estimated_error: f64::NAN,
            dichotomy_change: None,
        };
        let fine_k = 2 * k;
        if fine_k > MAX_NODES {
            return Err(fail(format!(
                "the discretisation error did not fall below {} before reaching {MAX_NODES} nodes",
                settings.tol
            )));
        }
        let mut fine = Bvp::new(model, smoother, plan, fine_k);
        let mut eta_f = vec![0.0; (fine_k + 1) * m];
        for (j, node) in eta_f.chunks_exact_mut(m).enumerate() {
            coarse.eval(plan.t_a + j as f64 * fine.h, node);
        }
        let (iterations, q_f) = fine
            .newton(&mut eta_f, settings.tol)
            .map_err(|r| fail(format!("on {} nodes: {r}", fine_k + 1)))?;
        // Richardson estimate for an order-4 method: error(fine) ≈ |fine − coarse|/15 at the common nodes.
        let mut diff = 0.0_f64;
        for j in 0..=k {
            for i in 0..m {
                let d = (eta_f[2 * j * m + i] - coarse.eta[j * m + i]).abs() / fine.scale[i];
                diff = if d.is_nan() || diff.is_nan() {
                    f64::NAN
                } else {
                    diff.max(d)
                };
            }
        }
        let estimated_error = diff / 15.0;
        if !estimated_error.is_finite() {
            return Err(fail("the solution is not finite".to_string()));
        }
        if estimated_error <= settings.tol || fine.h / 2.0 < settings.h_min {
            let dichotomy_change = dichotomy_check(&fine, &eta_f, plan.unstable);
            return Ok(Solution {
                t_a: plan.t_a,
                h: fine.h,
                m,
                k: fine_k,
                eta: eta_f,
                q: q_f,
                iterations,
                estimated_error,
                dichotomy_change,
            });
        }
        k = fine_k;
        eta = eta_f;
        q = q_f;
    }
}

/// The first node (checked about once a second) where the frozen-time linearisation ∂q/∂η has a number of
/// unstable eigenvalues other than `unstable` (a hint that the split may not fit; the bounded solution is
/// defined by the linear time-varying dichotomy, not by frozen eigenvalues, so this is only reported).
fn dichotomy_check<M: InverseModel + ?Sized>(
    bvp: &Bvp<'_, M>,
    eta: &[f64],
    unstable: usize,
) -> Option<(f64, Vec<[f64; 2]>)> {
    let (m, r) = (bvp.m, bvp.r);
    let every = ((1.0 / bvp.h).round() as usize).max(1);
    (0..=bvp.k).step_by(every).find_map(|j| {
        let p = &bvp.yd[2 * j * (r + 1)..(2 * j + 1) * (r + 1)];
        let w = bvp.w_at(2 * j);
        let lin = Linearization::at(bvp.model, &p[..r], w, &eta[j * m..(j + 1) * m], p[r]);
        (lin.eigenvalues.is_empty() || lin.unstable_count() != unstable)
            .then_some((bvp.plan.t_a + j as f64 * bvp.h, lin.eigenvalues))
    })
}
