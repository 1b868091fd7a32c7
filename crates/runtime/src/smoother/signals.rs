//! The model's exogenous signals (contract §5) smoothed with the reference's kernel and look-ahead, so that
//! every derivative is exact (no numerical differentiation): each signal S is a piecewise-linear raw signal
//! S_c (linear between its samples, held outside its span), and S_d^(k) = ∫ k^(k)(t − τ) S_c(τ) dτ exactly as
//! for the cycle (see the parent module). The reference's [`Smoother`] carries them, so y_d and every signal
//! are evaluated on the same grid, block by block, in the same pass of the run.
//!
//! Layout of the signal values `w` (`InverseModel`): [S, S_d1, …, S_dr] per signal in model-file order.

use super::Smoother;

impl Smoother {
    /// The same smoother carrying the smoothed signals `signals` (in model-file order).
    pub fn with_signals(mut self, signals: Vec<Smoother>) -> Smoother {
        self.signals = signals;
        self
    }

    /// The smoothed signals (empty for a model without signals).
    pub fn signals(&self) -> &[Smoother] {
        &self.signals
    }

    /// Smoothed signal values and derivatives at `t` into `w` ([S, S_d1, …, S_dr] per signal, r = the
    /// relative degree, `w.len() = signals × (r + 1)`).
    pub fn eval_signals(&self, t: f64, w: &mut [f64]) {
        if self.signals.is_empty() {
            return;
        }
        let per = w.len() / self.signals.len();
        for (s, chunk) in self.signals.iter().zip(w.chunks_mut(per)) {
            s.eval(t, chunk);
        }
    }

    /// The raw (unsmoothed, linearly interpolated) signal values at `t` into `w`, derivative slots 0: what
    /// the forward simulation of the original model uses.
    pub fn raw_signals(&self, t: f64, w: &mut [f64]) {
        if self.signals.is_empty() {
            return;
        }
        w.fill(0.0);
        let per = w.len() / self.signals.len();
        for (s, chunk) in self.signals.iter().zip(w.chunks_mut(per)) {
            chunk[0] = s.raw(t);
        }
    }

    /// The smoothed signals on a grid of increasing times: `cols[i·(r+1) + k][j]` = S_i^(k)(times[j]) (same
    /// layout as `w`, one column per entry; see [`Smoother::eval_grid`]).
    pub fn eval_signals_grid(&self, times: &[f64], dt: Option<f64>, cols: &mut [&mut [f64]]) {
        if self.signals.is_empty() {
            return;
        }
        let per = cols.len() / self.signals.len();
        for (s, chunk) in self.signals.iter().zip(cols.chunks_mut(per)) {
            s.eval_grid(times, dt, chunk);
        }
    }

    /// The raw signal S_c(t): the line through the last corner at or before t (held outside the span).
    pub fn raw(&self, t: f64) -> f64 {
        let i = self.corners.partition_point(|&c| c <= t);
        match i.checked_sub(1) {
            Some(i) if self.slope_after[i] == 0.0 => self.value_at[i],
            Some(i) => self.value_at[i] + self.slope_after[i] * (t - self.corners[i]),
            None => self.first_value,
        }
    }
}
