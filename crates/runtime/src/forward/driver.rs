//! The closed loop of the forward run: the raw cycle segment by segment, the PI driver with anti-windup and the
//! engine management that realises its request through the model's normal form.

use invsim_model_api::InverseModel;

use super::error::ForwardError;
use crate::cycle::Cycle;
use crate::error::RunError;

/// The raw cycle as segments: segment j < m − 1 is [T_j, T_{j+1}] with y_c = V_j + s_j (t − T_j); segment
/// m − 1 holds the last speed for ever. Within a segment the formula is used also slightly outside it (an
/// integrator's stages), so the closed loop is smooth in t there.
pub(super) struct RawCycle<'a> {
    pub(super) time: &'a [f64],
    pub(super) speed: &'a [f64],
    pub(super) slope: Vec<f64>,
}

impl<'a> RawCycle<'a> {
    pub(super) fn new(cycle: &'a Cycle) -> Self {
        let (time, speed) = (&cycle.time[..], &cycle.speed[..]);
        let mut slope: Vec<f64> = time
            .windows(2)
            .zip(speed.windows(2))
            .map(|(t, v)| (v[1] - v[0]) / (t[1] - t[0]))
            .collect();
        slope.push(0.0);
        RawCycle { time, speed, slope }
    }
    pub(super) fn segments(&self) -> usize {
        self.slope.len()
    }
    /// The segment of t, right-continuous (a corner belongs to the segment it starts).
    pub(super) fn segment(&self, t: f64) -> usize {
        self.time
            .partition_point(|&x| x <= t)
            .saturating_sub(1)
            .min(self.segments() - 1)
    }
    /// End of segment j (∞ for the last).
    pub(super) fn end(&self, j: usize) -> f64 {
        if j + 1 < self.time.len() {
            self.time[j + 1]
        } else {
            f64::INFINITY
        }
    }
    pub(super) fn value(&self, j: usize, t: f64) -> f64 {
        self.speed[j] + self.slope[j] * (t - self.time[j])
    }
}

/// The closed loop: model, driver, engine management and the raw cycle, with scratch space.
pub(super) struct Loop<'a, M: InverseModel + ?Sized> {
    pub(super) model: &'a M,
    pub(super) raw: RawCycle<'a>,
    pub(super) kp: f64,
    pub(super) ki: f64,
    /// 1/T_t of the back-calculation.
    pub(super) k_aw: f64,
    /// ω of the engine management's response.
    pub(super) omega: f64,
    /// Coefficients C(r−1, j)·ω^(r−1−j), j = 0 … r − 2, of the inner loop.
    pub(super) inner: Vec<f64>,
    pub(super) feedforward: bool,
    pub(super) enforce: bool,
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) n: usize,
    pub(super) xi: Vec<f64>,
    pub(super) eta: Vec<f64>,
    pub(super) guess: Vec<f64>,
    /// Indices of the accumulated `[outputs]`, integrated as quadrature states, and their scratch buffer.
    pub(super) accumulate: Vec<usize>,
    pub(super) outs: Vec<f64>,
    /// The model's signals (the forward run uses their RAW values, linear between samples, derivative slots
    /// 0: the original model's rhs and outputs depend only on S) and the values `w` at the current point.
    pub(super) signals: Vec<crate::smoother::Smoother>,
    pub(super) w: Vec<f64>,
}

/// The raw signal values at `t` into `w` ([S, 0, …, 0] per signal).
pub(super) fn raw_signals(signals: &[crate::smoother::Smoother], t: f64, w: &mut [f64]) {
    if signals.is_empty() {
        return;
    }
    w.fill(0.0);
    let per = w.len() / signals.len();
    for (s, chunk) in signals.iter().zip(w.chunks_mut(per)) {
        chunk[0] = s.raw(t);
    }
}

/// The driver's and the engine management's output at one point.
#[derive(Debug, Clone, Copy)]
pub(super) struct Drive {
    /// The raw cycle y_c(t).
    pub(super) yc: f64,
    /// y = h(x).
    pub(super) y: f64,
    /// The input the engine management computes (before clipping).
    pub(super) demand: f64,
    /// The input applied u_a.
    pub(super) applied: f64,
}

impl<M: InverseModel + ?Sized> Loop<'_, M> {
    /// Driver: a_req = y_c' + K_p e + I. Engine management: ν = Σ_j C(r−1, j) ω^(r−1−j) (ref_j − ξ_(j+2)),
    /// ref_0 = a_req, ref_j = 0 otherwise (ν = a_req for r = 1), and u = (ν − α(ψ(x)))/β(ψ(x)) (paper eq. 26
    /// with the normal-form coordinates of the vehicle's state).
    pub(super) fn drive(&mut self, seg: usize, t: f64, z: &[f64]) -> Result<Drive, ForwardError> {
        let (x, integral) = (&z[..self.n], z[self.n]);
        let yc = self.raw.value(seg, t);
        raw_signals(&self.signals, t, &mut self.w);
        self.model.psi(x, &self.w, &mut self.xi, &mut self.eta);
        let y = self.xi[0];
        let ff = if self.feedforward {
            self.raw.slope[seg]
        } else {
            0.0
        };
        let request = ff + self.kp * (yc - y) + integral;
        let nu = if self.inner.is_empty() {
            request
        } else {
            let mut nu = self.inner[0] * (request - self.xi[1]);
            for (c, xi) in self.inner[1..].iter().zip(&self.xi[2..]) {
                nu -= c * xi;
            }
            nu
        };
        self.guess.copy_from_slice(x);
        let demand = self
            .model
            .invert(&self.xi, &self.eta, &self.w, nu, &mut self.guess)
            .map_err(|source| RunError::Model { t, source })?;
        let applied = if self.enforce {
            demand.max(self.lo).min(self.hi)
        } else {
            demand
        };
        Ok(Drive {
            yc,
            y,
            demand,
            applied,
        })
    }

    /// dz/dt of the closed loop, z = (x, I, Q_1 … Q_m, D): x' = f(x) + g(x) u_a and I' = K_i e + (Δa)/T_t,
    /// Δa = β (u_a − u) / ω^(r−1) the part of the request the clipped input cannot deliver (back-calculation);
    /// the quadrature states Q_i' = o_i(x, u_a) (the accumulated outputs) and D' = y = h(x) make the solver
    /// integrate ∫ o_i dt and ∫ y dt with its own steps (5th order for DOPRI5), independent of the output
    /// grid; they stay out of the error control, so the closed loop takes the steps it takes without them.
    pub(super) fn rhs(
        &mut self,
        seg: usize,
        t: f64,
        z: &[f64],
        dz: &mut [f64],
    ) -> Result<(), ForwardError> {
        let d = self.drive(seg, t, z)?;
        let (dx, rest) = dz.split_at_mut(self.n);
        let (di, dq) = rest.split_at_mut(1);
        let x = &z[..self.n];
        self.model.rhs(x, &self.w, d.applied, dx);
        if !self.accumulate.is_empty() {
            self.model.outputs(x, &self.w, d.applied, &mut self.outs);
            for (q, &o) in dq.iter_mut().zip(&self.accumulate) {
                *q = self.outs[o];
            }
        }
        dq[self.accumulate.len()] = d.y;
        let mut windup = 0.0;
        if d.applied != d.demand && self.k_aw > 0.0 {
            let beta = self.model.beta(&self.xi, &self.eta, &self.w);
            windup = self.k_aw * beta * (d.applied - d.demand)
                / self.omega.powi(self.inner.len() as i32);
        }
        di[0] = self.ki * (d.yc - d.y) + windup;
        Ok(())
    }
}
