//! The inverse of a strategy's candidate (mode m, decided value d) at a sample and over its interval
//! [t_k, t_k+1], evaluated in reusable buffers ([`Scratch`]) so that ECMS's minimiser, which evaluates every
//! candidate many times per sample, allocates nothing (docs/hybrids.md, ECMS). The arithmetic is the one
//! place where a candidate's inverse, its interval's Runge–Kutta step and its end are computed: the run, DP
//! and the rules reach it through [`Ecms::eval`] and [`Ecms::interval`].

use super::ecms::Ecms;
use super::price_cache::Parts;
#[cfg(doc)]
use super::price_cache::PriceCache;
use super::scratch::{Point, Scratch};
use invsim_model_api::{InverseModel, ModelError};

impl Ecms<'_, '_, '_> {
    /// Mode m's signal values at one time into `w`: the exogenous signals from `row`, the run's
    /// [S, S_d1, …, S_dR] per signal at that time (`Samples::signals_at`, empty without signals), in the
    /// mode's layout ([`super::record::Ctx::w_from_row`]), and its decided input at d (its derivatives 0:
    /// held over the interval).
    pub(super) fn signals_into(&self, m: usize, row: &[f64], d: f64, w: &mut Vec<f64>) {
        let n_w = self.ctx.spec.modes[m].model.info().n_w();
        // Zeroed in place where it has the length already (every evaluation after a mode's first).
        if w.len() == n_w {
            w.fill(0.0);
        } else {
            w.clear();
            w.resize(n_w, 0.0);
        }
        if !row.is_empty() {
            self.ctx.w_from_row(m, row, w);
        }
        if let Some(&(_, slot)) = self.ctx.decided[m].first() {
            w[slot] = d;
        }
    }

    /// [`Ecms::signals_into`] at another time of the same candidate (m, d), `w` holding its values at an
    /// earlier one: without exogenous signals (`row` empty) w holds d alone, the same at every time, and is
    /// left as it is.
    fn signals_again(&self, m: usize, row: &[f64], d: f64, w: &mut Vec<f64>) {
        if !row.is_empty() {
            self.signals_into(m, row, d, w);
        }
    }

    /// The inverse of mode m at sample k from the state `x` (its η) with decided value d: x = ψ⁻¹(ξ, η) into
    /// `sc.x`, η into `sc.eta`, u = (y^(r) − α)/β and the powers; `None` where the inverse fails or is not
    /// finite.
    pub(super) fn point_in(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        d: f64,
        sc: &mut Scratch,
    ) -> Option<Point> {
        let model = self.ctx.spec.modes[m].model;
        let info = model.info();
        let r = info.relative_degree;
        self.reference_into(m, &self.samples.base[k], &mut sc.y);
        let y = &sc.y;
        sc.eta.clear();
        sc.eta.extend(info.eta_states.iter().map(|&j| x[j]));
        self.signals_into(m, self.samples.signals_at(k), d, &mut sc.w);
        sc.x.clear();
        sc.x.extend_from_slice(x);
        let u = model
            .invert(&y[..r], &sc.eta, &sc.w, y[r], &mut sc.x)
            .ok()?;
        if !(u.is_finite() && sc.x.iter().all(|v| v.is_finite())) {
            return None;
        }
        Some(self.powers(m, u, false, sc))
    }

    /// The interval [t_k, t_k+1] after [`Ecms::point_in`] (`sc` holding its state): η by one classical
    /// Runge–Kutta step of mode m's zero dynamics with d held (the reference and the signals at t_k, the
    /// midpoint and t_k+1), then x = ψ⁻¹ at t_k+1 into `sc.x1` and the powers there; the inverse's error as
    /// text.
    pub(super) fn end_in(
        &self,
        (m, k): (usize, usize),
        d: f64,
        sc: &mut Scratch,
    ) -> Result<Point, String> {
        let info = self.ctx.spec.modes[m].model.info();
        self.signals_into(m, self.samples.signals_at(k), d, &mut sc.w);
        sc.eta.clear();
        sc.eta.extend(info.eta_states.iter().map(|&j| sc.x[j]));
        self.end_after_point((m, k), d, sc, false)
    }

    /// [`Ecms::end_in`] right after [`Ecms::point_in`] of the same candidate, whose signals at t_k and η
    /// (those of `sc.x`: ψ⁻¹ keeps the internal states it is given) `sc` holds already; `batteries`: with the
    /// battery's power at the Runge–Kutta step's stages 2, 3 and 4 into `sc.batteries` ([`Ecms::advance_in`]).
    fn end_after_point(
        &self,
        (m, k): (usize, usize),
        d: f64,
        sc: &mut Scratch,
        batteries: bool,
    ) -> Result<Point, String> {
        self.advance_in((m, k), d, sc, batteries)?;
        self.finish_in((m, k), d, sc)
    }

    /// The state and free input at t_k+1 from the internal states `sc.eta` (the other states from `sc.x`;
    /// `sc.w` holding mode m's signals with decided value d at some time of the interval, set to t_k+1's):
    /// x = ψ⁻¹ into `sc.x1`, and the powers there.
    pub(super) fn finish_in(
        &self,
        (m, k): (usize, usize),
        d: f64,
        sc: &mut Scratch,
    ) -> Result<Point, String> {
        let model = self.ctx.spec.modes[m].model;
        let r = model.info().relative_degree;
        self.signals_again(m, self.samples.signals_at(k + 1), d, &mut sc.w);
        self.reference_into(m, &self.samples.base[k + 1], &mut sc.y);
        let y = &sc.y;
        sc.x1.clear();
        sc.x1.extend_from_slice(&sc.x);
        let u = model
            .invert(&y[..r], &sc.eta, &sc.w, y[r], &mut sc.x1)
            .map_err(|e| e.to_string())?;
        Ok(self.powers(m, u, true, sc))
    }

    /// η (in `sc.eta`) over [t_k, t_k+1] with d held, the signals w(t) at the stage times (`sc.w` holding
    /// them at t_k, set to the midpoint's before k₂ and to t_k+1's before k₄): k₁ = q(y(t_k), η, w(t_k)),
    /// k₂ = q(y(t_m), η + h/2 k₁, w(t_m)), k₃ = q(y(t_m), η + h/2 k₂, w(t_m)),
    /// k₄ = q(y(t_k+1), η + h k₃, w(t_k+1)), η += h/6 (k₁ + 2 k₂ + 2 k₃ + k₄).
    ///
    /// `batteries`: also P_batt at stages 2, 3 and 4 into `sc.batteries`, where the stage's state and input
    /// are solved (x = ψ⁻¹ at the stage's η, u) and k_i is F_η(x, w, u) of the model's right-hand side
    /// rather than the zero dynamics' closed form (one inverse serves both). The interval's battery energy is
    /// then h/6 (P₁ + 2P₂ + 2P₃ + P₄), the quadrature the step integrates the charge with: where P_batt is
    /// proportional to the charge's rate (constant U_oc: P_batt = U_oc I_b, dsoc/dt = −I_b/Q) the priced
    /// energy is exactly −U_oc Q Δsoc, the charge the search sustains ([`Ecms::price`]). An inverse that
    /// fails is the error.
    fn advance_in(
        &self,
        (m, k): (usize, usize),
        d: f64,
        sc: &mut Scratch,
        batteries: bool,
    ) -> Result<(), String> {
        let model = self.ctx.spec.modes[m].model;
        let info = model.info();
        let r = info.relative_degree;
        let h = self.samples.t[k + 1] - self.samples.t[k];
        let n = sc.eta.len();
        let rows = [
            &self.samples.base[k],
            &self.samples.mid[k],
            &self.samples.mid[k],
            &self.samples.base[k + 1],
        ];
        let steps = [0.0, h / 2.0, h / 2.0, h];
        // The buffers keep their length from one evaluation to the next.
        for v in sc.stages.iter_mut().chain([&mut sc.tmp]) {
            v.resize(n, 0.0);
        }
        for i in 0..4 {
            // k₃ takes the midpoint's reference as k₂ did: `sc.y` holds it.
            if i != 2 {
                self.reference_into(m, rows[i], &mut sc.y);
            }
            let y = &sc.y;
            match i {
                1 => self.signals_again(m, self.samples.signals_mid_at(k), d, &mut sc.w),
                3 => self.signals_again(m, self.samples.signals_at(k + 1), d, &mut sc.w),
                _ => {}
            }
            let (done, rest) = sc.stages.split_at_mut(i);
            if i == 0 {
                sc.tmp.copy_from_slice(&sc.eta);
            } else {
                for ((t, x), v) in sc.tmp.iter_mut().zip(&sc.eta).zip(&done[i - 1]) {
                    *t = x + steps[i] * v;
                }
            }
            rest[0].fill(0.0);
            if batteries && i > 0 {
                let u = stage_inverse(model, y, (&sc.tmp, &sc.w), &sc.x, &mut sc.xs)
                    .map_err(|e| e.to_string())?;
                sc.dx.resize(sc.xs.len(), 0.0);
                model.rhs(&sc.xs, &sc.w, u, &mut sc.dx);
                for (kj, &s) in rest[0].iter_mut().zip(&info.eta_states) {
                    *kj = sc.dx[s];
                }
                let outputs = (&sc.xs[..], &sc.w[..], u);
                sc.batteries[i - 1] = self.battery(model, outputs, &mut sc.outs);
            } else {
                model.zero_dynamics(&y[..r], &sc.tmp, &sc.w, y[r], &mut rest[0]);
            }
        }
        let [k1, k2, k3, k4] = &sc.stages;
        for j in 0..n {
            sc.eta[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
        }
        Ok(())
    }

    /// The outputs of mode m at the state `sc.x` (`sc.x1` at the interval's end) with free input u.
    fn powers(&self, m: usize, u: f64, end: bool, sc: &mut Scratch) -> Point {
        let model = self.ctx.spec.modes[m].model;
        sc.outs.clear();
        sc.outs.resize(model.info().outputs.len(), 0.0);
        let x = if end { &sc.x1 } else { &sc.x };
        model.outputs(x, &sc.w, u, &mut sc.outs);
        Point {
            u,
            margin: self.margin(m, u),
            p_fuel: sc.outs[self.h.fuel],
            p_batt: sc.outs[self.h.battery],
            rule: self
                .h
                .rules
                .map_or((f64::NAN, f64::NAN), |(r, g, _)| (sc.outs[r], sc.outs[g])),
        }
    }

    /// Candidate (m, d) at sample k from state x priced over its interval:
    ///
    ///   J = Δt/2 (P_fuel(t_k) + P_fuel(t_k+1)) + s · Δt/6 (P_batt,1 + 2 P_batt,2 + 2 P_batt,3 + P_batt,4)
    ///       (+ E_start),
    ///
    /// the fuel's trapezoid as the run books it, the powers at t_k+1 those of the interval's end with d held
    /// ([`Ecms::end_in`]), and the battery's energy by the quadrature of the Runge–Kutta step that moves the
    /// charge, P_batt at its four stages ([`Ecms::advance_in`]): s then prices the charge the search sustains
    /// (exactly, where P_batt is proportional to the charge's rate), which the envelope theorem of the
    /// run's gradient needs (`gradient_strategy.rs`); priced by its trapezoid, the battery's energy differs
    /// from the charge's by O(Δt²) and hev_p2's charge-sustaining fuel by up to 1.7·10⁻⁴ at Δt = 1 s. The
    /// excess is the larger of the two ends' (feasible within 10⁻⁹ of the range at both, as DP's controls).
    /// At the last sample (no interval) Δt (P_fuel + s P_batt) (+ E_start). `start` is E_start where the
    /// engine would start. (cost, the larger of the two ends' signed margins ([`Ecms::margin`]), the points
    /// at t_k and t_k+1); `None` where an inverse fails or a cost is not finite. `lazy`: a candidate beyond
    /// its bounds at t_k already (infeasible whatever its interval) is left there, its cost +∞ and its margin
    /// t_k's.
    pub(super) fn price(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        d: f64,
        (s, start): (f64, f64),
        lazy: bool,
        sc: &mut Scratch,
    ) -> Option<(f64, f64, Point, Option<Point>)> {
        let (parts, at, end) = self.evaluate((m, k), x, d, lazy, sc)?;
        let (cost, margin) = self.cost(m, parts, (s, start));
        Some((cost, margin, at, end))
    }

    /// The parts of [`Ecms::price`] that do not depend on s: the interval's energies and the margins, with
    /// the points at t_k and t_k+1.
    pub(super) fn evaluate(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        d: f64,
        lazy: bool,
        sc: &mut Scratch,
    ) -> Option<(Parts, Point, Option<Point>)> {
        let (at, done) = self.opening((m, k), x, d, lazy, sc)?;
        if let Some(parts) = done {
            return Some((parts, at, None));
        }
        let end = self.end_after_point((m, k), d, sc, true).ok()?;
        let h = self.samples.t[k + 1] - self.samples.t[k];
        let parts = Parts::interval(h, &at, sc.batteries, &end)?;
        Some((parts, at, Some(end)))
    }

    /// A price's point at t_k ([`Ecms::point_in`]) and, where the price ends there, its parts: beyond the
    /// bounds at t_k in a lazy price, or at the last sample (no interval).
    fn opening(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        d: f64,
        lazy: bool,
        sc: &mut Scratch,
    ) -> Option<(Point, Option<Parts>)> {
        let at = self.point_in((m, k), x, d, sc)?;
        let done = if lazy && at.margin > 1e-9 {
            Some(Parts::Beyond { margin: at.margin })
        } else if k + 1 == self.samples.t.len() {
            Some(Parts::last(&at))
        } else {
            None
        };
        Some((at, done))
    }

    /// [`Ecms::evaluate`]'s parts where mode m's price is free of the state ([`PriceCache::state_free`]):
    /// the battery's power at the Runge–Kutta step's stages does not depend on their η, so stages 2 and 3
    /// share one inverse at the midpoint, stage 4's is the interval's end, and the charge is not advanced —
    /// three inverses instead of five, the same numbers bit for bit.
    fn evaluate_free(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        d: f64,
        lazy: bool,
        sc: &mut Scratch,
    ) -> Option<Parts> {
        let (at, done) = self.opening((m, k), x, d, lazy, sc)?;
        if done.is_some() {
            return done;
        }
        let model = self.ctx.spec.modes[m].model;
        self.signals_again(m, self.samples.signals_mid_at(k), d, &mut sc.w);
        self.reference_into(m, &self.samples.mid[k], &mut sc.y);
        let u = stage_inverse(model, &sc.y, (&sc.eta, &sc.w), &sc.x, &mut sc.xs).ok()?;
        let mid = self.battery(model, (&sc.xs, &sc.w, u), &mut sc.outs);
        let end = self.finish_in((m, k), d, sc).ok()?;
        let h = self.samples.t[k + 1] - self.samples.t[k];
        Parts::interval(h, &at, [mid, mid, end.p_batt], &end)
    }

    /// The battery's power of `model` at (x, w, u), through its outputs in `outs`.
    fn battery(
        &self,
        model: &dyn InverseModel,
        (x, w, u): (&[f64], &[f64], f64),
        outs: &mut Vec<f64>,
    ) -> f64 {
        // Every output is written: the buffer is only sized, not cleared.
        outs.resize(model.info().outputs.len(), 0.0);
        model.outputs(x, w, u, outs);
        outs[self.h.battery]
    }

    /// [`Ecms::price`]'s (cost, margin) of mode m's candidate from its `parts`, at s with E_start `start`.
    pub(super) fn cost(&self, m: usize, parts: Parts, (s, start): (f64, f64)) -> (f64, f64) {
        let penalty = if self.h.engine_on[m] { start } else { 0.0 };
        match parts {
            Parts::Beyond { margin } => (f64::INFINITY, margin),
            Parts::Last {
                p_fuel,
                p_batt,
                margin,
            } => (self.dt * (p_fuel + s * p_batt) + penalty, margin),
            Parts::Interval {
                fuel,
                battery,
                margin,
                ..
            } => (fuel + s * battery + penalty, margin),
        }
    }

    /// [`Ecms::evaluate`]'s parts of candidate (m, d) at sample k from state x, kept in the cache where
    /// they are free of the state and d is a grid point of `bounds` (`None`: m decides no input), `row`
    /// the candidate's row in the cache ([`PriceCache::row`], `None`: not kept). Kept parts serve a request
    /// only where they are what it would compute: a full price serves a lazy one as [`Parts::lazily`]; a
    /// lazy price beyond the bounds, or a full one that failed (a lazy one might have stopped before the
    /// failure), is computed afresh for the other kind.
    pub(super) fn parts(
        &self,
        (m, k): (usize, usize),
        x: &[f64],
        (d, bounds, row): (f64, Option<(f64, f64)>, Option<usize>),
        lazy: bool,
        sc: &mut Scratch,
    ) -> Option<Parts> {
        let fresh = |sc: &mut Scratch| {
            if self.prices.state_free(m) {
                self.evaluate_free((m, k), x, d, lazy, sc)
            } else {
                self.evaluate((m, k), x, d, lazy, sc).map(|(p, _, _)| p)
            }
        };
        let Some(slot) = row.and_then(|row| self.prices.slot(row, d, bounds)) else {
            return fresh(sc);
        };
        let kept = *self.prices.kept(slot).get_or_init(|| (fresh(sc), lazy));
        match (kept, lazy) {
            ((Some(p), _), true) => Some(p.lazily()),
            ((None, false), true) => fresh(sc),
            ((Some(Parts::Beyond { .. }), true), false) => fresh(sc),
            ((p, _), false) => p,
            ((None, true), true) => None,
        }
    }
}

/// x = ψ⁻¹ at a Runge–Kutta stage of `model`: the reference `y` (y … y^(r)), the stage's η and signals, into
/// `xs` from the interval's start state `x` (the states ψ⁻¹ does not set); the free input u.
fn stage_inverse(
    model: &dyn InverseModel,
    y: &[f64],
    (eta, w): (&[f64], &[f64]),
    x: &[f64],
    xs: &mut Vec<f64>,
) -> Result<f64, ModelError> {
    let r = model.info().relative_degree;
    xs.clear();
    xs.extend_from_slice(x);
    model.invert(&y[..r], eta, w, y[r], xs)
}
