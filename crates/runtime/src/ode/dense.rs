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
    /// An empty log that holds at most `limit` values (its steps' coefficients, and five per step).
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
        // A step's own record counts as five values (its time, size, place, terms and n).
        let used = self.values.len() + 5 * self.steps.len();
        if used + len + 5 > self.limit {
            return Err(StepFailure {
                t,
                reason: format!(
                    "the run's integrator steps need more than {} values to be kept for its gradient \
                     (a shorter cycle or a larger output step needs fewer)",
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The nested form is the polynomial it abbreviates: with r = (1, 2, 3, 4, 5) at θ = 0.3,
    /// 1 + θ(2 + θ'(3 + θ(4 + 5θ'))) written out; a logged step reads its own coefficients (two components, a
    /// second step after it), and the log refuses a step beyond its budget with the time of the step.
    #[test]
    fn a_logged_step_evaluates_its_extension_and_the_log_keeps_its_budget() {
        let (th, th1) = (0.3, 0.7);
        let expected = 1.0 + th * (2.0 + th1 * (3.0 + th * (4.0 + th1 * 5.0)));
        let mut out = [0.0];
        nested(&[1.0, 2.0, 3.0, 4.0, 5.0], 1, th, &mut out);
        assert_eq!(out[0], expected);
        let mut log = StepLog::new(40);
        let first: Vec<f64> = (1..=10).map(f64::from).collect();
        log.push((2.0, 0.5), 2, &[&first])
            .expect("within the budget");
        let second = [7.0; 10];
        log.push((2.5, 0.5), 2, &[&second[..4], &second[4..]])
            .expect("within the budget");
        assert_eq!((log.len(), log.step(1).order(), log.step(0).t), (2, 5, 2.0));
        let mut y = [0.0; 2];
        log.eval(&log.step(0), 2.15, &mut y);
        let (a, b) = (
            1.0 + th * (3.0 + th1 * (5.0 + th * (7.0 + th1 * 9.0))),
            2.0 + th * (4.0 + th1 * (6.0 + th * (8.0 + th1 * 10.0))),
        );
        assert!(
            (y[0] - a).abs() < 1e-14 && (y[1] - b).abs() < 1e-14,
            "{y:?}"
        );
        let refused = log
            .push((3.0, 0.5), 2, &[&first])
            .expect_err("over the budget");
        assert_eq!(refused.t, 3.0);
        assert!(
            refused.reason.contains("more than 40 values"),
            "{}",
            refused.reason
        );
        assert_eq!(log.len(), 2);
    }
}
