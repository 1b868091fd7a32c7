//! The forward run's budgets: a number of integrator steps (scaled with the cycle's duration by default; a run
//! whose pace after 2 % of it projects more than four budgets over the cycle stops then) and an optional
//! wall-clock limit, and the diagnosis when one is exhausted — a closed loop made stiff (or fast) by
//! the driver's gains, named with the integrator's stiffness estimate.

use std::time::Instant;

use super::error::ForwardError;
use super::options::{default_step_budget, ForwardOptions, Method};
use crate::error::num;
use crate::ode::OdeStats;

/// How often (in steps) the clock and the pace are checked.
const CLOCK_EVERY: usize = 256;
/// Once this fraction of the budget is spent, the pace is extrapolated over the rest of the cycle ...
const PACE_AFTER: f64 = 0.02;
/// ... and a run whose projected steps exceed this many budgets stops there (it is on its way to exhaust
/// the budget 4 to 200 times over).
const PACE_MARGIN: f64 = 4.0;

/// The limits of one run and what is needed to explain them.
pub(super) struct Budget {
    max_steps: usize,
    limit: Option<(f64, Instant)>,
    t0: f64,
    t_end: f64,
    method: Method,
    gains: (f64, f64, f64),
    /// Whether the budget came from --max-steps (else the default).
    explicit: bool,
}

/// What the integrator tells about the steps it took: counters, the last step size and DOPRI5's estimate h·ρ.
pub(super) struct StepState {
    pub(super) stats: OdeStats,
    pub(super) h: f64,
    pub(super) h_rho: f64,
}

impl Budget {
    pub(super) fn new(opts: &ForwardOptions, duration: f64, (t0, t_end): (f64, f64)) -> Budget {
        Budget {
            max_steps: opts
                .max_steps
                .unwrap_or_else(|| default_step_budget(duration)),
            limit: opts.time_limit_s.map(|l| (l, Instant::now())),
            t0,
            t_end,
            method: opts.method,
            gains: (opts.kp, opts.ki, opts.response),
            explicit: opts.max_steps.is_some(),
        }
    }

    /// True once 2 % of the budget is spent and the pace so far, extrapolated to the cycle's end,
    /// exceeds [`PACE_MARGIN`] budgets: steps · (t_end − t0)/(t − t0) > 4 · max_steps.
    fn hopeless(&self, t: f64, steps: usize) -> bool {
        let (spent, max) = (steps as f64, self.max_steps as f64);
        spent >= PACE_AFTER * max
            && spent * (self.t_end - self.t0) > PACE_MARGIN * max * (t - self.t0)
    }

    /// `Err` once the steps so far exceed the budget (or are on a pace to exceed it many times) or the clock
    /// the limit, at time `t`.
    pub(super) fn check(&self, t: f64, s: &StepState) -> Result<(), ForwardError> {
        let steps = s.stats.accepted + s.stats.rejected;
        // CLOCK_EVERY is a power of two.
        let checkpoint = steps & (CLOCK_EVERY - 1) == 0;
        if steps >= self.max_steps || (checkpoint && self.hopeless(t, steps)) {
            let how = if self.explicit {
                "as given".to_string()
            } else {
                format!(
                    "by default {} per second of the cycle, at least {}",
                    num(super::options::STEPS_PER_CYCLE_SECOND),
                    super::options::MIN_STEP_BUDGET
                )
            };
            return Err(ForwardError::StepBudget {
                t,
                t_end: self.t_end,
                steps,
                max: self.max_steps,
                how,
                diagnosis: self.diagnosis(s, "--max-steps"),
            });
        }
        if let Some((limit, start)) = self.limit {
            if checkpoint && start.elapsed().as_secs_f64() > limit {
                return Err(ForwardError::TimeLimit {
                    limit,
                    t,
                    t_end: self.t_end,
                    steps,
                    diagnosis: self.diagnosis(s, "--time-limit"),
                });
            }
        }
        Ok(())
    }

    /// What the driver's gains do, for a message about a run that the integrator could not finish.
    pub(super) fn gains_hint(&self) -> String {
        let (kp, ki, w) = self.gains;
        format!(
            "the driver's gains kp = {}, ki = {} and response = {} rad/s set how fast the closed loop is (defaults \
             2, 1, 10): lower them",
            num(kp),
            num(ki),
            num(w)
        )
    }

    /// Why the steps are many: the stiffness estimate (DOPRI5) or the step size, and the driver's gains that
    /// set the closed loop's speed; `raise` names the option that lifts the limit.
    fn diagnosis(&self, s: &StepState, raise: &str) -> String {
        let gains = format!("{}, or raise {raise}", self.gains_hint());
        let accepted = s.stats.accepted.max(1);
        match self.method {
            Method::Dopri5 if s.stats.stability_limited * 2 >= accepted => format!(
                "the closed loop is stiff: {} of {} accepted steps were limited by stability (DOPRI5's estimate \
                 h·ρ = {} at the step size {} s, an eigenvalue of magnitude about {} 1/s); {gains}, or use \
                 --method rosenbrock23",
                s.stats.stability_limited,
                s.stats.accepted,
                num(s.h_rho),
                num(s.h),
                num(s.h_rho / s.h)
            ),
            _ => format!(
                "the steps have shrunk to {} s (the solution changes on that time scale); {gains}",
                num(s.h)
            ),
        }
    }
}
