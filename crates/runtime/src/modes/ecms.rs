//! One run of the equivalent consumption minimisation strategy (ECMS; Paganelli et al., "Equivalent
//! consumption minimization strategy for parallel hybrid powertrains", IEEE VTC 2002) at a fixed equivalence
//! factor s: at every sample t_k, over every candidate mode (the gear's modes, and the standstill mode below
//! `standstill_below`) and, in a mode that decides an input, over that input's bounds, the inverse gives the
//! free input and the state, and the strategy takes the feasible candidate of least
//!
//!   J = P_fuel + s · P_batt (+ E_start / Δt where the engine starts),
//!
//! P_fuel and P_batt the model's fuel and battery chemical powers (`[hybrid]`), E_start its start penalty. A
//! candidate is feasible where its free input is within its bounds (10⁻⁹ of the range); where none is, the
//! one nearest its bounds is taken and the summary reports the violation. The decided value is held over
//! [t_k, t_k+1]; η (the charge among it) follows the chosen mode's zero dynamics by one classical Runge–Kutta
//! step per interval (the reference at t_k, the midpoint and t_k+1), and the next sample's state is that mode's
//! ψ⁻¹ there (every mode shares the state, so a switch keeps it; a mode whose ξ differs starts from the
//! reference at once, as `--switching quasi-static` does).

use super::minimise::minimise;
use super::record::{Ctx, Record, Solved, Transition};
use super::rows::Rows;
use super::{ModalError, Role};

/// The end of an interval: the internal states, the state and free input, the fuel and battery powers.
pub(super) struct End {
    pub(super) eta: Vec<f64>,
    pub(super) x: Vec<f64>,
    pub(super) u: f64,
    pub(super) p_fuel: f64,
    pub(super) p_batt: f64,
}

/// The relaxed choice at sample k where ΔSOC(s) jumps at s (one sample's choice flips there, both
/// choices equally cheap): the interval [t_k, t_k+1] is shared, θ with the run's own choice and 1 − θ with
/// the choice at the `other` equivalence factor (the other side of the jump), every integral and the
/// internal states taken in those shares. The relaxed control of the time-shared problem (a chattering
/// engine on/off within the interval) is what makes the charge-sustaining optimum exist where ΔSOC jumps.
pub(super) struct Share {
    pub(super) k: usize,
    pub(super) other: f64,
    pub(super) theta: f64,
}

/// The reference of every sample and interval midpoint, and each sample's candidate modes (independent of s:
/// computed once for the search).
pub(super) struct Samples {
    pub(super) t: Vec<f64>,
    /// y_c^(0 … r_max) at t_k.
    pub(super) base: Rows,
    /// y_c^(0 … r_max) at (t_k + t_k+1)/2.
    pub(super) mid: Rows,
    pub(super) candidates: Vec<Vec<usize>>,
}

/// What one run at a fixed s gives.
pub(super) struct Outcome {
    pub(super) s: f64,
    pub(super) rec: Record,
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
    pub(super) cost: f64,
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
}

/// A strategy's choice at sample k from state x (`on`: the engine ran in the previous interval).
pub(super) type Pick<'p> = dyn FnMut(usize, &[f64], bool) -> Result<Eval, ModalError> + 'p;

/// The run's fixed parts.
pub(super) struct Ecms<'c, 'a, 'm> {
    pub(super) ctx: &'c Ctx<'a, 'm>,
    pub(super) h: &'c Resolved,
    pub(super) samples: &'c Samples,
    pub(super) dt: f64,
}

impl Ecms<'_, '_, '_> {
    /// y^(0 … r_max) of mode m's reference from the smoothed cycle `base` (its map: offset + scale · y_c).
    fn reference(&self, m: usize, base: &[f64]) -> Vec<f64> {
        let map = self.ctx.spec.modes[m].model.reference();
        let mut y: Vec<f64> = base.iter().map(|v| v * map.scale).collect();
        y[0] += map.offset;
        y
    }

    /// The signal values of mode m with its decided input at d.
    fn w(&self, m: usize, d: f64) -> Vec<f64> {
        let mut w = vec![0.0; self.ctx.spec.modes[m].model.info().n_w()];
        if let Some(&(_, slot)) = self.ctx.decided[m].first() {
            w[slot] = d;
        }
        w
    }

    /// The inverse of mode m at sample k from the state `x` (its η), decided value d, and the cost at s.
    pub(super) fn eval(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        d: f64,
        (s, start): (f64, f64),
    ) -> Option<Eval> {
        let model = self.ctx.spec.modes[m].model;
        let info = model.info();
        let r = info.relative_degree;
        let y = self.reference(m, &self.samples.base[k]);
        let eta: Vec<f64> = info.eta_states.iter().map(|&j| x[j]).collect();
        let w = self.w(m, d);
        let mut xs = x.to_vec();
        let u = model.invert(&y[..r], &eta, &w, y[r], &mut xs).ok()?;
        if !(u.is_finite() && xs.iter().all(|v| v.is_finite())) {
            return None;
        }
        let mut outs = vec![0.0; info.outputs.len()];
        model.outputs(&xs, &w, u, &mut outs);
        let (p_fuel, p_batt) = (outs[self.h.fuel], outs[self.h.battery]);
        let rule = self
            .h
            .rules
            .map_or((f64::NAN, f64::NAN), |(r, g, _)| (outs[r], outs[g]));
        let excess = self.excess(m, u);
        let on = self.h.engine_on[m];
        Some(Eval {
            cost: p_fuel + s * p_batt + if on { start } else { 0.0 },
            excess,
            m,
            d,
            u,
            x: xs,
            p_fuel,
            p_batt,
            rule,
        })
    }

    /// How far mode m's free input u lies beyond its bounds, as a fraction of its range (0 within).
    pub(super) fn excess(&self, m: usize, u: f64) -> f64 {
        let input = &self.ctx.spec.inputs[self.ctx.spec.modes[m].free_input];
        let range = match (input.min, input.max) {
            (Some(a), Some(b)) if b > a => b - a,
            _ => 1.0,
        };
        let below = input.min.map_or(0.0, |a| a - u);
        let above = input.max.map_or(0.0, |b| u - b);
        below.max(above).max(0.0) / range
    }

    /// The best candidate at sample k from state x (`on`: the engine ran in the previous interval).
    fn choose(&self, k: usize, x: &[f64], s: f64, on: bool) -> Result<Eval, ModalError> {
        let start = if on {
            0.0
        } else {
            self.h.start_penalty / self.dt
        };
        let mut best: Option<Eval> = None;
        let mut nearest: Option<Eval> = None;
        let mut consider = |e: &Eval, best: &mut Option<Eval>| {
            if nearest
                .as_ref()
                .is_none_or(|n| (e.excess, e.cost) < (n.excess, n.cost))
            {
                nearest = Some(e.clone());
            }
            if e.excess <= 1e-9 && best.as_ref().is_none_or(|b| e.cost < b.cost) {
                *best = Some(e.clone());
            }
        };
        for &m in &self.samples.candidates[k] {
            match self.ctx.decided[m].first() {
                None => {
                    if let Some(e) = self.eval((m, k), x, 0.0, (s, start)) {
                        consider(&e, &mut best);
                    }
                }
                Some(&(i, _)) => {
                    let input = &self.ctx.spec.inputs[i];
                    let bounds = (input.min.unwrap_or(0.0), input.max.unwrap_or(0.0));
                    let mut local: Option<Eval> = None;
                    let mut f = |d: f64| match self.eval((m, k), x, d, (s, start)) {
                        Some(e) => {
                            let c = if e.excess <= 1e-9 {
                                e.cost
                            } else {
                                f64::INFINITY
                            };
                            consider(&e, &mut local);
                            c
                        }
                        None => f64::INFINITY,
                    };
                    if let Some((d, _)) = minimise(&mut f, bounds, self.h.grid) {
                        if let Some(e) = self.eval((m, k), x, d, (s, start)) {
                            consider(&e, &mut best);
                        }
                    }
                }
            }
        }
        best.or(nearest).ok_or_else(|| {
            self.ctx.err(
                self.samples.candidates[k].first().copied().unwrap_or(0),
                self.samples.t[k],
                "no candidate mode has an inverse here".into(),
            )
        })
    }

    /// η of mode m with decided value d over [t_k, t_k+1]: one classical Runge–Kutta step, the reference at
    /// t_k, the midpoint and t_k+1.
    fn advance(&self, (m, k): (usize, usize), d: f64, eta: &mut [f64]) {
        let model = self.ctx.spec.modes[m].model;
        let r = model.info().relative_degree;
        let w = self.w(m, d);
        let h = self.samples.t[k + 1] - self.samples.t[k];
        let y0 = self.reference(m, &self.samples.base[k]);
        let ym = self.reference(m, &self.samples.mid[k]);
        let y1 = self.reference(m, &self.samples.base[k + 1]);
        let n = eta.len();
        let q = |y: &[f64], e: &[f64]| {
            let mut de = vec![0.0; n];
            model.zero_dynamics(&y[..r], e, &w, y[r], &mut de);
            de
        };
        let shift = |e: &[f64], k: &[f64], a: f64| -> Vec<f64> {
            e.iter().zip(k).map(|(x, v)| x + a * v).collect()
        };
        let k1 = q(&y0, eta);
        let k2 = q(&ym, &shift(eta, &k1, h / 2.0));
        let k3 = q(&ym, &shift(eta, &k2, h / 2.0));
        let k4 = q(&y1, &shift(eta, &k3, h));
        for j in 0..n {
            eta[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
    }

    /// The run at equivalence factor s from the state x0 (its internal states at their start values).
    pub(super) fn run(&self, s: f64, x0: &[f64]) -> Result<Outcome, ModalError> {
        self.run_shared(s, x0, None)
    }

    /// The end of interval k in the chosen candidate's mode with its decided value: η by the zero dynamics,
    /// then the state and free input at t_k+1, and the fuel and battery powers there.
    pub(super) fn interval(&self, k: usize, e: &Eval) -> Result<End, ModalError> {
        let model = self.ctx.spec.modes[e.m].model;
        let info = model.info();
        let mut eta: Vec<f64> = info.eta_states.iter().map(|&j| e.x[j]).collect();
        self.advance((e.m, k), e.d, &mut eta);
        self.end_at(k, e, eta)
    }

    /// The state, free input and powers at t_k+1 in e's mode and decided value, with internal states `eta`.
    fn end_at(&self, k: usize, e: &Eval, eta: Vec<f64>) -> Result<End, ModalError> {
        let model = self.ctx.spec.modes[e.m].model;
        let info = model.info();
        let r = info.relative_degree;
        let y = self.reference(e.m, &self.samples.base[k + 1]);
        let w = self.w(e.m, e.d);
        let mut x = e.x.clone();
        let u = model
            .invert(&y[..r], &eta, &w, y[r], &mut x)
            .map_err(|err| self.ctx.err(e.m, self.samples.t[k + 1], err.to_string()))?;
        let mut outs = vec![0.0; info.outputs.len()];
        model.outputs(&x, &w, u, &mut outs);
        Ok(End {
            eta,
            x,
            u,
            p_fuel: outs[self.h.fuel],
            p_batt: outs[self.h.battery],
        })
    }

    /// [`Ecms::run`], where `share` asks for the relaxed choice at one sample (see [`Share`]).
    pub(super) fn run_shared(
        &self,
        s: f64,
        x0: &[f64],
        share: Option<&Share>,
    ) -> Result<Outcome, ModalError> {
        self.run_policy(s, x0, share, &mut |k, x, on| self.choose(k, x, s, on))
    }

    /// The run whose candidate at sample k from state x (`on`: the engine ran in the previous interval) is
    /// `pick`'s; `s` is recorded in the outcome (NaN for a strategy without one).
    pub(super) fn run_policy(
        &self,
        s: f64,
        x0: &[f64],
        share: Option<&Share>,
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
            let mut end = self.interval(k, &cur)?;
            let mut on_share = if self.h.engine_on[m] { 1.0 } else { 0.0 };
            let (mut pf0, mut pb0) = (cur.p_fuel, cur.p_batt);
            if let Some(sh) = share.filter(|sh| sh.k == k) {
                // The relaxed choice: θ of the interval with this run's candidate, 1 − θ with the other s's.
                let alt = self.choose(k, &cur.x, sh.other, was_on)?;
                let alt_end = self.interval(k, &alt)?;
                let th = sh.theta;
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
            rec.impulse_dir.push(Vec::new());
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
        (0..a.mode.len().min(b.mode.len())).find(|&k| {
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
        })
    }

    /// Record the chosen candidate at sample k.
    fn push(&self, rec: &mut Record, k: usize, e: &Eval) {
        let yref = self.reference(e.m, &self.samples.base[k]);
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
