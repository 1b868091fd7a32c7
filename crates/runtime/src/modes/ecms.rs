//! One run of the equivalent consumption minimisation strategy (ECMS; Paganelli et al., "Equivalent
//! consumption minimization strategy for parallel hybrid powertrains", IEEE VTC 2002) at a fixed equivalence
//! factor s: at every sample t_k, over every candidate mode (the gear's modes, and the standstill mode below
//! `standstill_below`) and, in a mode that decides an input, over that input's bounds, the inverse gives the
//! free input and the state, and the strategy takes the feasible candidate of least cost over its interval,
//! as the run books it ([`Ecms::price`]):
//!
//!   J = Δt/2 (P_fuel(t_k) + P_fuel(t_k+1)) + s · Δt/6 (P_batt,1 + 2 P_batt,2 + 2 P_batt,3 + P_batt,4)
//!   (+ E_start where the engine starts),
//!
//! P_fuel and P_batt the model's fuel and battery chemical powers (`[hybrid]`), at t_k+1 with the decided
//! value held, P_batt,i at the stages of the Runge–Kutta step that moves the charge (so s prices the charge
//! the search sustains), E_start its start penalty: DP's stage cost, s pricing the battery's energy. (Weighing the
//! powers at t_k alone, P_fuel + s P_batt, cost ECMS O(Δt): 5.3 % above DP on hev_p2 over UDDS at Δt = 1 s.)
//! A candidate is feasible where its free input is within its bounds (10⁻⁹ of the range) at t_k and t_k+1;
//! where none is, the one nearest its bounds is taken and the summary reports the violation. The decided value is held over
//! [t_k, t_k+1]; η (the charge among it) follows the chosen mode's zero dynamics by one classical Runge–Kutta
//! step per interval (the reference at t_k, the midpoint and t_k+1), and the next sample's state is that mode's
//! ψ⁻¹ there (every mode shares the state, so a switch keeps it; a mode whose ξ differs starts from the
//! reference at once, as `--switching quasi-static` does).

use super::minimise::minimise_probed;
use super::price_cache::{Parts, PriceCache};
use super::record::{Ctx, Record, Solved, Transition};
use super::rows::Rows;
use super::scratch::{Point, Scratch};
use super::{ModalError, Role};

/// The end of an interval: the internal states, the state and free input, the fuel and battery powers.
#[derive(Clone)]
pub(super) struct End {
    pub(super) eta: Vec<f64>,
    pub(super) x: Vec<f64>,
    pub(super) u: f64,
    pub(super) p_fuel: f64,
    pub(super) p_batt: f64,
}

/// The relaxed choice at sample k where ΔSOC(s) jumps at s (one sample's choice flips there, both
/// choices equally cheap): the interval [t_k, t_k+1] is shared, θ with the run's own choice and 1 − θ with
/// the `other` choice, every integral and the internal states taken in those shares. The relaxed control of
/// the time-shared problem (a chattering engine on/off within the interval) is what makes the
/// charge-sustaining optimum exist where ΔSOC jumps.
pub(super) struct Share {
    pub(super) k: usize,
    /// The run's own choice in this mode alone (`None`: among every candidate).
    pub(super) own: Option<usize>,
    pub(super) other: Other,
    pub(super) theta: f64,
}

/// The other choice of a shared sample.
#[derive(Clone, Copy)]
pub(super) enum Other {
    /// The choice at another equivalence factor (the other side of the jump in s).
    Factor(f64),
    /// The best candidate in this mode at the run's own s.
    Mode(usize),
}

/// The reference of every sample and interval midpoint, and each sample's candidate modes (independent of s:
/// computed once for the search).
pub(super) struct Samples {
    pub(super) t: Vec<f64>,
    /// y_c^(0 … r_max) at t_k.
    pub(super) base: Rows,
    /// y_c^(0 … r_max) at (t_k + t_k+1)/2.
    pub(super) mid: Rows,
    /// The exogenous signals [S, S_d1, …, S_dR] per signal (R = r_max) at t_k and at (t_k + t_k+1)/2 (no
    /// rows without signals; [`super::record::Ctx::signal_rows`]).
    pub(super) signals: Rows,
    pub(super) signals_mid: Rows,
    pub(super) candidates: Vec<Vec<usize>>,
}

impl Samples {
    /// The exogenous signals at t_k (empty without signals).
    pub(super) fn signals_at(&self, k: usize) -> &[f64] {
        row_or_empty(&self.signals, k)
    }

    /// The exogenous signals at (t_k + t_k+1)/2 (empty without signals).
    pub(super) fn signals_mid_at(&self, k: usize) -> &[f64] {
        row_or_empty(&self.signals_mid, k)
    }
}

/// Row k of `rows`, or none where there are no rows (a run without signals).
fn row_or_empty(rows: &Rows, k: usize) -> &[f64] {
    if rows.is_empty() {
        &[]
    } else {
        &rows[k]
    }
}

/// A sample whose interval the run shared ([`Share`]): θ with the recorded choice, 1 − θ with the other
/// choice (mode, decided value) from the same state.
#[derive(Clone, Copy)]
pub(super) struct Shared {
    pub(super) k: usize,
    pub(super) other: Choice,
    pub(super) theta: f64,
}

/// What one run at a fixed s gives.
pub(super) struct Outcome {
    pub(super) s: f64,
    pub(super) rec: Record,
    /// The samples whose interval was shared, in order.
    pub(super) shared: Vec<Shared>,
    pub(super) soc: (f64, f64),
    /// ∫ P_fuel dt and ∫ P_batt dt, J (trapezoids of each interval in its mode).
    pub(super) fuel: f64,
    pub(super) battery: f64,
    pub(super) starts: usize,
    /// Time with the engine on, s.
    pub(super) engine_on: f64,
}

impl Outcome {
    pub(super) fn delta_soc(&self) -> f64 {
        self.soc.1 - self.soc.0
    }
}

/// `[hybrid]` resolved against the modes: output and state indices, the engine per mode.
pub(super) struct Resolved {
    pub(super) fuel: usize,
    pub(super) battery: usize,
    pub(super) soc: usize,
    pub(super) engine_on: Vec<bool>,
    pub(super) start_penalty: f64,
    pub(super) grid: usize,
    /// The model's own rules (`rule_request`, `rule_target` as output indices, `rule_min_on` in s).
    pub(super) rules: Option<(usize, usize, f64)>,
}

/// One evaluated candidate.
#[derive(Clone)]
pub(super) struct Eval {
    /// How far the free input lies beyond its bounds, as a fraction of its range (0 within).
    pub(super) excess: f64,
    pub(super) m: usize,
    pub(super) d: f64,
    pub(super) u: f64,
    pub(super) x: Vec<f64>,
    pub(super) p_fuel: f64,
    pub(super) p_batt: f64,
    /// The model's rule outputs (`rule_request`, `rule_target`) here; NaN without them.
    pub(super) rule: (f64, f64),
    /// The end of the interval [t_k, t_k+1] with the decided value held, where the cost priced it.
    pub(super) end: Option<End>,
}

/// A candidate: its mode and decided value (m, d).
pub(super) type Choice = (usize, f64);

/// A strategy's choice at sample k from state x (`on`: the engine ran in the previous interval).
pub(super) type Pick<'p> = dyn FnMut(usize, &[f64], bool) -> Result<Eval, ModalError> + 'p;

/// The run's fixed parts.
pub(super) struct Ecms<'c, 'a, 'm> {
    pub(super) ctx: &'c Ctx<'a, 'm>,
    pub(super) h: &'c Resolved,
    pub(super) samples: &'c Samples,
    pub(super) dt: f64,
    /// ECMS's grid points' prices kept across the search's runs where they do not depend on the state.
    pub(super) prices: PriceCache,
}

impl Ecms<'_, '_, '_> {
    /// y^(0 … r_max) of mode m's reference from the smoothed cycle `base` into `y` (its map: offset + scale · y_c,
    /// the offset on y only).
    pub(super) fn reference_into(&self, m: usize, base: &[f64], y: &mut Vec<f64>) {
        y.clear();
        y.extend_from_slice(base);
        self.ctx.map_cycle(m, y);
    }

    /// The inverse of mode m at sample k from the state `x` (its η) with decided value d.
    pub(super) fn eval(&self, (m, k): (usize, usize), x: &[f64], d: f64) -> Option<Eval> {
        let mut sc = Scratch::default();
        let p = self.point_in((m, k), x, d, &mut sc)?;
        Some(Eval {
            excess: p.margin.max(0.0),
            m,
            d,
            u: p.u,
            x: sc.x,
            p_fuel: p.p_fuel,
            p_batt: p.p_batt,
            rule: p.rule,
            end: None,
        })
    }

    /// Candidate (m, d) at sample k from state x priced over its interval ([`Ecms::price`]), as an [`Eval`]
    /// carrying the interval's end for the run to book.
    fn priced(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        d: f64,
        (s, start): (f64, f64),
        sc: &mut Scratch,
    ) -> Option<Eval> {
        let (_, margin, at, end) = self.price((m, k), x, d, (s, start), false, sc)?;
        Some(Eval {
            excess: margin.max(0.0),
            m,
            d,
            u: at.u,
            x: sc.x.clone(),
            p_fuel: at.p_fuel,
            p_batt: at.p_batt,
            rule: at.rule,
            end: end.map(|e| End {
                eta: sc.eta.clone(),
                x: sc.x1.clone(),
                u: e.u,
                p_fuel: e.p_fuel,
                p_batt: e.p_batt,
            }),
        })
    }

    /// Whether any mode has internal states besides the charge (an engine's temperature): they ride along
    /// the strategies' runs, and make later choices depend on earlier ones.
    pub(super) fn other_internal_states(&self) -> bool {
        self.ctx
            .spec
            .modes
            .iter()
            .any(|m| m.model.info().eta_states.iter().any(|&j| j != self.h.soc))
    }

    /// How far mode m's free input u lies beyond its bounds, as a fraction of its range (0 within).
    pub(super) fn excess(&self, m: usize, u: f64) -> f64 {
        self.margin(m, u).max(0.0)
    }

    /// Mode m's free input u against its bounds [a, b], as a fraction of its range: max(a − u, u − b), how
    /// far beyond them (> 0), or minus the distance to the nearer one within (≤ 0; an absent bound none, a
    /// free input without bounds 0) — continuous in u, the margin whose zero is the feasible set's edge.
    pub(super) fn margin(&self, m: usize, u: f64) -> f64 {
        let input = &self.ctx.spec.inputs[self.ctx.spec.modes[m].free_input];
        let range = match (input.min, input.max) {
            (Some(a), Some(b)) if b > a => b - a,
            _ => 1.0,
        };
        let below = input.min.map(|a| a - u);
        let above = input.max.map(|b| u - b);
        match (below, above) {
            (None, None) => 0.0,
            (l, r) => {
                l.unwrap_or(f64::NEG_INFINITY)
                    .max(r.unwrap_or(f64::NEG_INFINITY))
                    / range
            }
        }
    }

    /// The best candidate at sample k from state x (`on`: the engine ran in the previous interval): the least
    /// cost over its interval ([`Ecms::priced`]). The minimiser's points beyond the bounds already at t_k are
    /// left without their interval (they cost +∞ whatever it holds: [`Ecms::price`]); where no candidate is
    /// feasible, the candidates are evaluated again in full for the one nearest its bounds. `only`: the
    /// candidates of that mode alone.
    fn choose(
        &self,
        (k, x): (usize, &[f64]),
        (s, on): (f64, bool),
        only: Option<usize>,
        sc: &mut Scratch,
    ) -> Result<Eval, ModalError> {
        let start = if on { 0.0 } else { self.h.start_penalty };
        self.select((k, x), (s, start), only, sc)
            .and_then(|(m, d)| self.priced((m, k), x, d, (s, start), sc))
            .ok_or_else(|| self.no_candidate(k))
    }

    /// [`Ecms::choose`]'s candidate (m, d) at sample k from state x, before it is priced for the run.
    fn select(
        &self,
        (k, x): (usize, &[f64]),
        (s, start): (f64, f64),
        only: Option<usize>,
        sc: &mut Scratch,
    ) -> Option<Choice> {
        match self.candidates_at((k, x), (s, start), (only, true), sc) {
            (Some((_, best)), _) => Some(best),
            _ => {
                let (best, nearest) = self.candidates_at((k, x), (s, start), (only, false), sc);
                best.map(|(_, c)| c).or(nearest)
            }
        }
    }

    /// The tie at sample k of the run `out` between modes `ma` and `mb`: J_mb − J_ma, each mode's least cost at
    /// the run's state there and its s, with the start penalty as the run had it (`equivalence.rs` finds the
    /// flip's price by the secant through it). None where either mode has no feasible candidate.
    pub(super) fn tie_gap(&self, out: &Outcome, k: usize, (ma, mb): (usize, usize)) -> Option<f64> {
        let on = k > 0 && self.h.engine_on[out.rec.mode[k - 1]];
        let start = if on { 0.0 } else { self.h.start_penalty };
        let x = &out.rec.states[k];
        let mut sc = Scratch::default();
        let mut cost = |m: usize| {
            let at = self.candidates_at((k, x), (out.s, start), (Some(m), false), &mut sc);
            at.0.map(|(c, _)| c)
        };
        Some(cost(mb)? - cost(ma)?)
    }

    /// Every sample's candidate at s, chosen beforehand and side by side on the cores, where no choice
    /// depends on the run: every candidate's price free of the state ([`PriceCache::state_free`]) and no
    /// start penalty (which would depend on the previous choice). `shares`' samples take their own modes.
    /// `None` where a choice may depend on the run; the run then chooses as it goes.
    fn selected_ahead(&self, s: f64, x0: &[f64], shares: &[Share]) -> Option<Vec<Option<Choice>>> {
        use rayon::prelude::*;
        let free = self
            .samples
            .candidates
            .iter()
            .flatten()
            .all(|&m| self.prices.state_free(m));
        if !free || self.h.start_penalty != 0.0 {
            return None;
        }
        let picks = (0..self.samples.t.len())
            .into_par_iter()
            .map_init(Scratch::default, |sc, k| {
                let own = shares.iter().find(|sh| sh.k == k).and_then(|sh| sh.own);
                self.select((k, x0), (s, 0.0), own, sc)
            })
            .collect();
        Some(picks)
    }

    /// The error where no candidate mode of sample k has an inverse (named by its first candidate).
    pub(super) fn no_candidate(&self, k: usize) -> ModalError {
        self.ctx.err(
            self.samples.candidates[k].first().copied().unwrap_or(0),
            self.samples.t[k],
            "no candidate mode has an inverse here".into(),
        )
    }

    /// Every candidate of sample k from state x at s (`start`: E_start where the engine would start), a
    /// decided input minimised over its bounds: (m, d) of the feasible one of least cost, and of the one
    /// nearest its bounds among every evaluation (by its excess, then its cost; `lazy` leaves points beyond
    /// the bounds at t_k unfinished, and this one unreliable), the first with its cost. `only`: the candidates
    /// of that mode alone.
    fn candidates_at(
        &self,
        (k, x): (usize, &[f64]),
        (s, start): (f64, f64),
        (only, lazy): (Option<usize>, bool),
        sc: &mut Scratch,
    ) -> (Option<(f64, Choice)>, Option<Choice>) {
        // (cost, m, d) of the best feasible candidate; (excess, cost, m, d) of the one nearest its bounds.
        let mut best: Option<(f64, usize, f64)> = None;
        let mut nearest: Option<(f64, f64, usize, f64)> = None;
        let mut consider = |(cost, margin): (f64, f64), (m, d): (usize, f64), final_: bool| {
            let excess = margin.max(0.0);
            if nearest.is_none_or(|(e, c, _, _)| (excess, cost) < (e, c)) {
                nearest = Some((excess, cost, m, d));
            }
            if final_ && excess <= 1e-9 && best.is_none_or(|(b, _, _)| cost < b) {
                best = Some((cost, m, d));
            }
        };
        let candidates = &self.samples.candidates[k];
        // `row`: the candidate's kept prices (found once per mode and sample).
        let parts = |(m, d): Choice, (bounds, row), lazy: bool, sc: &mut Scratch| {
            self.parts((m, k), x, (d, bounds, row), lazy, sc)
        };
        let price = |m: usize, p: Option<Parts>| p.map(|p| self.cost(m, p, (s, start)));
        // The minimiser's evaluations, (d, parts): its best point is one of them, whose full price needs no
        // evaluation again unless it was left beyond its bounds at t_k (a lazy price).
        let mut seen: Vec<(f64, Option<Parts>)> = Vec::new();
        for m in candidates
            .iter()
            .copied()
            .filter(|&m| only.is_none_or(|o| o == m))
        {
            let row = self.prices.row(candidates, (m, k));
            match self.ctx.decided[m].first() {
                None => {
                    if let Some(p) = price(m, parts((m, 0.0), (None, row), false, sc)) {
                        consider(p, (m, 0.0), true);
                    }
                }
                Some(&(i, _)) => {
                    let input = &self.ctx.spec.inputs[i];
                    let bounds = (input.min.unwrap_or(0.0), input.max.unwrap_or(0.0));
                    seen.clear();
                    // (J where feasible, else +∞; the margin less the feasibility's 10⁻⁹).
                    let mut f = |d: f64| {
                        let p = parts((m, d), (Some(bounds), row), lazy, sc);
                        seen.push((d, p));
                        match price(m, p) {
                            Some((c, e)) => {
                                consider((c, e), (m, d), false);
                                (if e <= 1e-9 { c } else { f64::INFINITY }, e - 1e-9)
                            }
                            None => (f64::INFINITY, f64::NAN),
                        }
                    };
                    if let Some((d, _)) = minimise_probed(&mut f, bounds, self.h.grid) {
                        let known = seen
                            .iter()
                            .find(|(e, _)| e.to_bits() == d.to_bits())
                            .map(|&(_, p)| p)
                            .filter(|p| !matches!(p, Some(Parts::Beyond { .. })));
                        let p =
                            known.unwrap_or_else(|| parts((m, d), (Some(bounds), row), false, sc));
                        if let Some(p) = price(m, p) {
                            consider(p, (m, d), true);
                        }
                    }
                }
            }
        }
        (
            best.map(|(c, m, d)| (c, (m, d))),
            nearest.map(|(_, _, m, d)| (m, d)),
        )
    }

    /// The run at equivalence factor s from the state x0 (its internal states at their start values).
    pub(super) fn run(&self, s: f64, x0: &[f64]) -> Result<Outcome, ModalError> {
        self.run_shared(s, x0, &[])
    }

    /// The end of interval k in the chosen candidate's mode with its decided value: η by the zero dynamics,
    /// then the state and free input at t_k+1, and the fuel and battery powers there.
    pub(super) fn interval(&self, k: usize, e: &Eval) -> Result<End, ModalError> {
        let mut sc = Scratch::default();
        sc.x.extend_from_slice(&e.x);
        let p = self
            .end_in((e.m, k), e.d, &mut sc)
            .map_err(|err| self.ctx.err(e.m, self.samples.t[k + 1], err))?;
        Ok(end_of(p, sc))
    }

    /// The state, free input and powers at t_k+1 in e's mode and decided value, with internal states `eta`.
    fn end_at(&self, k: usize, e: &Eval, eta: Vec<f64>) -> Result<End, ModalError> {
        let mut sc = Scratch::default();
        sc.x.extend_from_slice(&e.x);
        sc.eta = eta;
        self.signals_into(e.m, self.samples.signals_at(k + 1), e.d, &mut sc.w);
        let p = self
            .finish_in((e.m, k), e.d, &mut sc)
            .map_err(|err| self.ctx.err(e.m, self.samples.t[k + 1], err))?;
        Ok(end_of(p, sc))
    }

    /// [`Ecms::run`], where `shares` ask for the relaxed choice at their samples (see [`Share`]).
    pub(super) fn run_shared(
        &self,
        s: f64,
        x0: &[f64],
        shares: &[Share],
    ) -> Result<Outcome, ModalError> {
        // One set of buffers for every evaluation of the run.
        let mut sc = Scratch::default();
        let ahead = self.selected_ahead(s, x0, shares);
        self.run_policy(s, x0, shares, &mut |k, x, on| match &ahead {
            Some(picks) => picks[k]
                .and_then(|(m, d)| self.priced((m, k), x, d, (s, 0.0), &mut sc))
                .ok_or_else(|| self.no_candidate(k)),
            None => {
                let own = shares.iter().find(|sh| sh.k == k).and_then(|sh| sh.own);
                self.choose((k, x), (s, on), own, &mut sc)
            }
        })
    }

    /// The run whose candidate at sample k from state x (`on`: the engine ran in the previous interval) is
    /// `pick`'s; `s` is recorded in the outcome (NaN for a strategy without one).
    pub(super) fn run_policy(
        &self,
        s: f64,
        x0: &[f64],
        shares: &[Share],
        pick: &mut Pick<'_>,
    ) -> Result<Outcome, ModalError> {
        let ctx = self.ctx;
        let ns = self.samples.t.len();
        let n_yref = ctx.r_max + 1;
        let first = pick(0, x0, false)?;
        let base0 = &self.samples.base[0];
        let mut rec = Record::new((self.samples.t[0], base0[0]), first.m, ns, (ctx.n, n_yref));
        let soc0 = first.x[self.h.soc];
        let mut out = Outcome {
            s,
            rec: Record::new((0.0, 0.0), 0, 0, (0, 0)),
            shared: Vec::new(),
            soc: (soc0, soc0),
            fuel: 0.0,
            battery: 0.0,
            starts: usize::from(self.h.engine_on[first.m]),
            engine_on: 0.0,
        };
        let mut cur = first;
        let mut was_on = false;
        self.push(&mut rec, 0, &cur);
        for k in 0..ns - 1 {
            let m = cur.m;
            let h = self.samples.t[k + 1] - self.samples.t[k];
            let mut end = match cur.end.take() {
                Some(end) => end,
                None => self.interval(k, &cur)?,
            };
            let mut on_share = if self.h.engine_on[m] { 1.0 } else { 0.0 };
            let (mut pf0, mut pb0) = (cur.p_fuel, cur.p_batt);
            if let Some(sh) = shares.iter().find(|sh| sh.k == k) {
                // The relaxed choice: θ of the interval with this run's candidate, 1 − θ with the other.
                let (other_s, only) = match sh.other {
                    Other::Factor(o) => (o, None),
                    Other::Mode(m) => (s, Some(m)),
                };
                let mut sc = Scratch::default();
                let alt = self.choose((k, &cur.x), (other_s, was_on), only, &mut sc)?;
                let alt_end = self.interval(k, &alt)?;
                let th = sh.theta;
                out.shared.push(Shared {
                    k,
                    other: (alt.m, alt.d),
                    theta: th,
                });
                let eta: Vec<f64> = end
                    .eta
                    .iter()
                    .zip(&alt_end.eta)
                    .map(|(a, b)| th * a + (1.0 - th) * b)
                    .collect();
                let (pf1, pb1) = (
                    th * end.p_fuel + (1.0 - th) * alt_end.p_fuel,
                    th * end.p_batt + (1.0 - th) * alt_end.p_batt,
                );
                end = self.end_at(k, &cur, eta)?;
                (end.p_fuel, end.p_batt) = (pf1, pb1);
                pf0 = th * pf0 + (1.0 - th) * alt.p_fuel;
                pb0 = th * pb0 + (1.0 - th) * alt.p_batt;
                let alt_on = if self.h.engine_on[alt.m] { 1.0 } else { 0.0 };
                on_share = th * on_share + (1.0 - th) * alt_on;
            }
            out.fuel += 0.5 * h * (pf0 + end.p_fuel);
            out.battery += 0.5 * h * (pb0 + end.p_batt);
            out.engine_on += on_share * h;
            rec.u_end.push(end.u);
            rec.x_end.push(&end.x);
            was_on = self.h.engine_on[m];
            let next = pick(k + 1, &end.x, was_on)?;
            if next.m != m {
                rec.transitions.push(Transition {
                    t: self.samples.t[k + 1],
                    from: ctx.spec.modes[m].name.clone(),
                    to: ctx.spec.modes[next.m].name.clone(),
                    max_deviation: 0.0,
                });
                if self.h.engine_on[next.m] && !was_on {
                    out.starts += 1;
                }
            }
            rec.t.push(self.samples.t[k + 1]);
            rec.speed.push(self.samples.base[k + 1][0]);
            rec.impulse.push(0.0);
            rec.mode.push(next.m);
            self.push(&mut rec, k + 1, &next);
            cur = next;
        }
        out.soc.1 = cur.x[self.h.soc];
        out.rec = rec;
        Ok(out)
    }

    /// The first sample where two runs chose differently (mode, or decided value by more than 10⁻⁶ of its
    /// range).
    pub(super) fn first_difference(&self, a: &Record, b: &Record) -> Option<usize> {
        (0..a.mode.len().min(b.mode.len())).find(|&k| self.differ(a, b, k))
    }

    /// The one sample where two runs chose differently, if they differ at exactly one.
    pub(super) fn only_difference(&self, a: &Record, b: &Record) -> Option<usize> {
        let k = self.first_difference(a, b)?;
        let n = a.mode.len().min(b.mode.len());
        (k + 1..n).all(|j| !self.differ(a, b, j)).then_some(k)
    }

    /// The sample k whose interval changes the charge difference of two runs the most,
    /// |(soc_b − soc_a)(t_k+1) − (soc_b − soc_a)(t_k)| (none where it changes nowhere).
    pub(super) fn widest_step(&self, a: &Record, b: &Record) -> Option<usize> {
        let n = a.states.len().min(b.states.len());
        let gap = |k: usize| b.states[k][self.h.soc] - a.states[k][self.h.soc];
        let step = |k: usize| (gap(k + 1) - gap(k)).abs();
        (0..n.saturating_sub(1))
            .filter(|&k| step(k) > 0.0)
            .max_by(|&i, &j| step(i).total_cmp(&step(j)))
    }

    /// The one sample where two runs chose another mode, if they do at exactly one (their decided values may
    /// differ anywhere).
    pub(super) fn only_mode_difference(&self, a: &Record, b: &Record) -> Option<usize> {
        let n = a.mode.len().min(b.mode.len());
        let k = (0..n).find(|&k| a.mode[k] != b.mode[k])?;
        (k + 1..n).all(|j| a.mode[j] == b.mode[j]).then_some(k)
    }

    /// Whether two runs chose differently at sample k.
    fn differ(&self, a: &Record, b: &Record, k: usize) -> bool {
        {
            let (ma, mb) = (a.mode[k], b.mode[k]);
            if ma != mb {
                return true;
            }
            match (
                self.ctx.decided[ma].first(),
                a.decided.get(k),
                b.decided.get(k),
            ) {
                (Some(&(i, _)), Some(da), Some(db)) => {
                    let input = &self.ctx.spec.inputs[i];
                    let range = input.max.unwrap_or(1.0) - input.min.unwrap_or(0.0);
                    da.iter().zip(db).any(|(x, y)| (x - y).abs() > 1e-6 * range)
                }
                _ => false,
            }
        }
    }

    /// Record the chosen candidate at sample k.
    fn push(&self, rec: &mut Record, k: usize, e: &Eval) {
        let mut yref = Vec::new();
        self.reference_into(e.m, &self.samples.base[k], &mut yref);
        rec.push_solved(&Solved {
            x: e.x.clone(),
            u: e.u,
            yref,
        });
        let decided = if self.ctx.decided[e.m].is_empty() {
            Vec::new()
        } else {
            vec![e.d]
        };
        rec.decided.push(decided);
    }
}

/// The end of an interval from its point and the scratch that computed it.
fn end_of(p: Point, sc: Scratch) -> End {
    End {
        eta: sc.eta,
        x: sc.x1,
        u: p.u,
        p_fuel: p.p_fuel,
        p_batt: p.p_batt,
    }
}

/// The candidate modes of a sample: the standstill mode below `standstill_below`, and every traction and
/// brake mode of the gear (an ungeared one in every gear).
pub(super) fn candidates(ctx: &Ctx<'_, '_>, gear: usize, speed: f64) -> Vec<usize> {
    let spec = ctx.spec;
    spec.modes
        .iter()
        .enumerate()
        .filter(|(_, m)| match m.role {
            Role::Standstill => speed < spec.sequence.standstill_below,
            _ => m.gear.is_none_or(|g| g == gear),
        })
        .map(|(i, _)| i)
        .collect()
}
