//! The continuous extensions of the explicit pairs in their common nested form (Hairer I, §II.6: DOPRI5's of
//! order 4 with five coefficient vectors, DOP853's of order 7 with eight), and a log of a run's accepted steps
//! with their extensions: a run differentiated afterwards reads η between its own steps from it instead of
//! integrating the zero dynamics again.
//!
//! ```text
//! y(t + θh) ≈ r1 + θ(r2 + θ'(r3 + θ(r4 + θ'(r5 + θ(r6 + …))))),   θ' = 1 − θ.
//! ```

use super::StepFailure;

/// y(t + θh) into `out` from the K coefficient vectors of n components in `r` (r_i's component c at
/// `(i − 1)·n + c`), innermost first: v = r_K, v ← r_i + (θ for odd i, θ' for even i)·v.
pub(crate) fn nested(r: &[f64], n: usize, theta: f64, out: &mut [f64]) {
    let terms = r.len() / n;
    let theta1 = 1.0 - theta;
    for (c, o) in out.iter_mut().enumerate() {
        let mut v = r[(terms - 1) * n + c];
        for i in (1..terms).rev() {
            let factor = if i % 2 == 1 { theta } else { theta1 };
            v = r[(i - 1) * n + c] + factor * v;
        }
        *o = v;
    }
}

/// One logged step: [t, t + h], its extension's coefficients at `values[at .. at + terms·n]`.
#[derive(Debug, Clone, Copy)]
pub struct LoggedStep {
    pub t: f64,
    pub h: f64,
    at: usize,
    terms: usize,
    n: usize,
}

impl LoggedStep {
    /// The order of the continuous extension's pair: 8 for DOP853's (eight vectors), 5 for DOPRI5's.
    pub fn order(&self) -> usize {
        if self.terms == 8 {
            8
        } else {
            5
        }
    }
}

/// The accepted steps of a run, in order, with their continuous extensions, within a budget of values.
#[derive(Debug, Clone)]
pub struct StepLog {
    steps: Vec<LoggedStep>,
    values: Vec<f64>,
    limit: usize,
}

impl StepLog {
    /// An empty log that holds at most `limit` coefficient values.
    pub fn new(limit: usize) -> StepLog {
        StepLog {
            steps: Vec::new(),
            values: Vec::new(),
            limit,
        }
    }

    /// Steps logged so far (the index of the next one).
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Step i.
    pub fn step(&self, i: usize) -> LoggedStep {
        self.steps[i]
    }

    /// Log the step [t, t + h] of n components with the extension's coefficients r1, r2, … (`parts`, one
    /// slice of several of them or one per vector, in order); an error where the log would exceed its budget.
    pub fn push(
        &mut self,
        (t, h): (f64, f64),
        n: usize,
        parts: &[&[f64]],
    ) -> Result<(), StepFailure> {
        let len: usize = parts.iter().map(|p| p.len()).sum();
        if self.values.len() + len > self.limit {
            return Err(StepFailure {
                t,
                reason: format!(
                    "the run's integrator steps need more than {} values to be kept for its gradient",
                    self.limit
                ),
            });
        }
        let at = self.values.len();
        for p in parts {
            self.values.extend_from_slice(p);
        }
        let terms = len / n.max(1);
        self.steps.push(LoggedStep { t, h, at, terms, n });
        Ok(())
    }

    /// y at time s of step `step`'s extension into `out`.
    pub fn eval(&self, step: &LoggedStep, s: f64, out: &mut [f64]) {
        let r = &self.values[step.at..step.at + step.terms * step.n];
        nested(r, step.n, (s - step.t) / step.h, out);
    }
}
