//! The gradient of an ECMS run's charge-sustaining fuel (`simulate --strategy ecms --gradient …`): the
//! derivative of the optimum by the envelope theorem, from the run's own arithmetic with its decisions held.
//!
//! The charge-sustaining ECMS run solves, over the modes and decided inputs d of every sample,
//!
//! ```text
//! F*(p) = min_d  E_fuel(d; p)   subject to   E_batt(d; p) = 0,
//! ```
//!
//! E_fuel the trapezoids of the `[hybrid]` fuel power and E_batt the battery power's quadrature as the run
//! prices them, through its Lagrangian E_fuel + s·E_batt, s the equivalence factor its search found (Paganelli et al.
//! 2002; the Lagrange multiplier of the battery's energy, Sciarretta, Back & Guzzella 2004). By the envelope
//! theorem (e.g. Mas-Colell, Whinston & Green, *Microeconomic Theory*, 1995, §M.L) the optimum's derivative is
//! the Lagrangian's partial derivative with the decisions and s held:
//!
//! ```text
//! dF*/dp = ∂/∂p (E_fuel + s·E_batt) |_(d, s held)
//! ```
//!
//! — each sample's mode a discrete choice, held almost everywhere in p, its decided value d first-order
//! optimal where it lies inside the feasible set (a continuous minimiser in d), and E_batt = 0 along the
//! optimum, so s's move does not enter. Where the optimum lies on the feasible set's edge — the free input u
//! at its bound at t_k or t_k+1 (hev_p2's braking: the motor recovers all the friction brake leaves) — the
//! constraint is what stays active, not d: there d moves with p so that u stays at its bound,
//! dd = −(∂u/∂p)/(∂u/∂d), both through the interval as the run computes it (the constraint's multiplier
//! enters the Lagrangian; Mas-Colell et al. §M.L, the theorem with constraints). ∂/∂d is a column of the
//! model's sensitivities: a decided input is a signal of its mode. A decided value at its own bound is held. A
//! shared sample (θ of its interval with one choice, 1 − θ with the other: the relaxed optimum where E_batt(s)
//! jumps, [`super::ecms::Share`]) holds θ too.
//!
//! The premise: the energy s prices is the charge the search sustains. The run prices the battery's energy by
//! the Runge–Kutta step's own quadrature of P_batt (`interval_cost.rs`), so where P_batt is proportional to
//! the charge's rate (constant U_oc) E_batt = −U_oc Q ΔSOC exactly; priced by its trapezoid (the summary's
//! booking) it differed by O(Δt²) and the derivatives were 0.1 to 1 % off the re-optimised run's. What is left
//! (checked in `crates/cli/tests/gradient_hybrid.rs`, within 2·10⁻⁵): the search's bracket — the sample it
//! shares holds choices optimal at its two ends, 10⁻⁴ apart in s.
//!
//! The partial derivative is the run's own: at every sample x = ψ⁻¹(ξ, η), u the inverse's input, with the
//! chain rule of [`crate::gradient::Point`]; η over [t_k, t_k+1] by the run's one classical Runge–Kutta step
//! with d held, differentiated exactly, stage by stage: dk_i = A_i (dη + c_i h dk_(i−1)) + B_i, A_i = ∂q/∂η
//! and B_i = ∂q/∂p at the stage's η and reference, dη(t_k+1) = dη + h/6 (dk₁ + 2dk₂ + 2dk₃ + dk₄), and the
//! battery's energy h/6 (dP₁ + 2dP₂ + 2dP₃ + dP₄) at the same stages; the state at t_k+1 (the interval's end,
//! ψ⁻¹ there) carries dη into the next sample's mode, as the run carries η.

use super::ecms::{Ecms, Outcome, Shared};
use super::gradient_point::point_into;
use super::record::Record;
use super::scratch::Scratch;
use super::ModalError;
use crate::gradient::{Buffers, ModalWrt, Point};

/// A free input within this fraction of its range from a bound is on the feasible set's edge (the minimiser
/// finds the edge to 10⁻⁹ of the decided input's range).
const EDGE: f64 = 1e-7;

/// dF*/dp_c for every derivative c of `wrt` of the charge-sustaining run `best` (module doc).
pub(super) fn of_ecms(
    run: &Ecms<'_, '_, '_>,
    best: &Outcome,
    wrt: &ModalWrt,
) -> Result<Vec<f64>, ModalError> {
    let mut held = Held::new(run, wrt);
    let rec = &best.rec;
    let np = wrt.params.len();
    let (mut fuel, mut battery) = (vec![0.0; np], vec![0.0; np]);
    let mut dx = vec![vec![0.0; run.ctx.n]; np];
    for k in 0..rec.t.len().saturating_sub(1) {
        let own = choice(rec, k);
        let start = (&rec.states[k][..], rec.free[k]);
        let mine = held.interval(own, k, start, &dx)?;
        let (terms, next) = match best.shared.iter().find(|s| s.k == k) {
            None => (mine.terms, mine.dx_end),
            Some(sh) => {
                let end = (&rec.x_end[k][..], rec.u_end[k]);
                held.shared((k, start.0, end), (own, mine), sh, &dx)?
            }
        };
        for c in 0..np {
            fuel[c] += terms.fuel[c];
            battery[c] += terms.battery[c];
        }
        dx = next;
    }
    Ok(fuel
        .iter()
        .zip(&battery)
        .map(|(f, b)| f + best.s * b)
        .collect())
}

/// The recorded choice at sample k: its mode and decided value (0 where the mode decides nothing).
fn choice(rec: &Record, k: usize) -> (usize, f64) {
    let d = rec.decided.get(k).and_then(|d| d.first()).copied();
    (rec.mode[k], d.unwrap_or(0.0))
}

/// An interval's energies' derivatives per derivative: the fuel's trapezoid h/2 (dP_fuel(t_k) +
/// dP_fuel(t_k+1)) and the battery's Runge–Kutta quadrature h/6 (dP₁ + 2dP₂ + 2dP₃ + dP₄) (the run's price of
/// it, `interval_cost.rs` `advance_in`).
struct Terms {
    fuel: Vec<f64>,
    battery: Vec<f64>,
}

/// A candidate's interval differentiated (the edge resolved): the trapezoid's terms, η's and the state's
/// derivatives at its own end, and the decided value's move dd per derivative (0 where it is held).
struct Interval {
    terms: Terms,
    deta: Vec<Vec<f64>>,
    dx_end: Vec<Vec<f64>>,
    dd: Vec<f64>,
}

/// The derivatives of one point per column: the fuel power's, the free input's and the state's (the battery's
/// power enters through the Runge–Kutta stages, [`Held::step`]).
struct Changes {
    fuel: Vec<f64>,
    du: Vec<f64>,
    dx: Vec<Vec<f64>>,
}

/// The pass's buffers.
struct Held<'h, 'c, 'a, 'm> {
    run: &'h Ecms<'c, 'a, 'm>,
    wrt: &'h ModalWrt,
    sc: Scratch,
    buf: Buffers,
    y: Vec<f64>,
    w: Vec<f64>,
    x: Vec<f64>,
    /// A and B of the η rows at a stage (column-major), the reference's columns (unused: no transitions).
    a: Vec<f64>,
    b: Vec<f64>,
    reference: Vec<f64>,
}

impl<'h, 'c, 'a, 'm> Held<'h, 'c, 'a, 'm> {
    fn new(run: &'h Ecms<'c, 'a, 'm>, wrt: &'h ModalWrt) -> Self {
        Held {
            run,
            wrt,
            sc: Scratch::default(),
            buf: Buffers::default(),
            y: Vec::new(),
            w: Vec::new(),
            x: Vec::new(),
            a: Vec::new(),
            b: Vec::new(),
            reference: Vec::new(),
        }
    }

    /// Mode m's columns: the derivatives of `wrt`, then, where the mode decides an input, its value (the
    /// signal's column after the parameters and the mode's grid values).
    fn columns(&self, m: usize) -> Vec<Option<usize>> {
        let ctx = self.run.ctx;
        let mut cols = self.wrt.columns[m].clone();
        if let Some(&(_, slot)) = ctx.decided[m].first() {
            let info = ctx.model(m).info();
            let signal = slot / (info.relative_degree + 1);
            cols.push(Some(
                info.parameters.len() + self.wrt.grids[m].len() + signal,
            ));
        }
        cols
    }

    /// The partial derivatives of mode m at (x, u) at time t with the signals' row `row` (the run's at t),
    /// decided value d.
    fn point(
        &mut self,
        (m, d, t): (usize, f64, f64),
        (row, x, u): (&[f64], &[f64], f64),
    ) -> Result<Point, ModalError> {
        let run = self.run;
        run.signals_into(m, row, d, &mut self.w);
        let buf = std::mem::take(&mut self.buf);
        point_into(run.ctx, (m, &self.wrt.grids[m]), (t, x, &self.w, u), buf)
    }

    /// The changes at `point` of mode m along each column of `cols` with η's changes `deta[i]`.
    fn changes(&self, point: &Point, cols: &[Option<usize>], deta: &[Vec<f64>]) -> Changes {
        let l = *point.layout();
        let fuel = l.output(self.run.h.fuel);
        let mut out = Changes {
            fuel: Vec::with_capacity(cols.len()),
            du: Vec::with_capacity(cols.len()),
            dx: Vec::with_capacity(cols.len()),
        };
        for (&col, de) in cols.iter().zip(deta) {
            let dir = point.direction(de, col);
            out.fuel.push(point.row_change(fuel, &dir, col));
            out.du.push(dir.du);
            out.dx.push(dir.dx);
        }
        out
    }

    /// Candidate (m, d)'s interval from `start` (its state and input at t_k), the full state's derivatives
    /// entering sample k `dx`: the powers at t_k, the run's Runge–Kutta step and the powers at its own end
    /// differentiated along every column, then the edge resolved ([`Held::resolve`]).
    fn interval(
        &mut self,
        (m, d): (usize, f64),
        k: usize,
        (x, u): (&[f64], f64),
        dx: &[Vec<f64>],
    ) -> Result<Interval, ModalError> {
        let run = self.run;
        let info = run.ctx.model(m).info();
        let cols = self.columns(m);
        let ne = info.n_eta;
        let mut deta: Vec<Vec<f64>> = dx
            .iter()
            .map(|dxc| info.eta_states.iter().map(|&s| dxc[s]).collect())
            .collect();
        deta.resize(cols.len(), vec![0.0; ne]);
        let point = self.point((m, d, run.samples.t[k]), (run.samples.signals_at(k), x, u))?;
        let at_start = self.changes(&point, &cols, &deta);
        self.buf = point.into_buffer();
        self.sc.x.clear();
        self.sc.x.extend_from_slice(x);
        let t1 = run.samples.t[k + 1];
        let end = run
            .end_in((m, k), d, &mut self.sc)
            .map_err(|e| run.ctx.err(m, t1, e))?;
        let (deta, battery) = self.step((m, d), k, (x, u), (&cols, deta))?;
        let x1 = std::mem::take(&mut self.sc.x1);
        let point = self.point((m, d, t1), (run.samples.signals_at(k + 1), &x1, end.u))?;
        let at_end = self.changes(&point, &cols, &deta);
        self.buf = point.into_buffer();
        self.sc.x1 = x1;
        let h = t1 - run.samples.t[k];
        let fuel: Vec<f64> = (0..cols.len())
            .map(|i| 0.5 * h * (at_start.fuel[i] + at_end.fuel[i]))
            .collect();
        let ends = (&at_start, &at_end);
        Ok(self.resolve((m, d), (u, end.u), ends, (fuel, battery, deta)))
    }

    /// The interval's derivatives per derivative of `wrt`, from those per column: where the mode decides an
    /// input whose optimum is on the feasible set's edge (the free input at a bound at t_k or t_k+1, d
    /// within its own bounds), d moves by dd = −du/du_d at that end, and every derivative takes dd times the
    /// decided column's; elsewhere dd = 0 (module doc).
    fn resolve(
        &self,
        (m, d): (usize, f64),
        (u0, u1): (f64, f64),
        (s, e): (&Changes, &Changes),
        (fuel, battery, deta): (Vec<f64>, Vec<f64>, Vec<Vec<f64>>),
    ) -> Interval {
        let np = self.wrt.params.len();
        let edge = (s.du.len() > np)
            .then(|| self.edge(m, d, (u0, u1)))
            .flatten();
        let dd: Vec<f64> = (0..np)
            .map(|c| match edge {
                Some(0) => -s.du[c] / s.du[np],
                Some(_) => -e.du[c] / e.du[np],
                None => 0.0,
            })
            .collect();
        // Column c moved by dd_c times the decided value's column np (where there is one).
        let moved = |v: &[f64], c: usize| match v.get(np) {
            Some(vd) if dd[c] != 0.0 => v[c] + dd[c] * vd,
            _ => v[c],
        };
        let moved_vec = |v: &[Vec<f64>], c: usize| -> Vec<f64> {
            match v.get(np) {
                Some(vd) if dd[c] != 0.0 => {
                    v[c].iter().zip(vd).map(|(a, b)| a + dd[c] * b).collect()
                }
                _ => v[c].clone(),
            }
        };
        Interval {
            terms: Terms {
                fuel: (0..np).map(|c| moved(&fuel, c)).collect(),
                battery: (0..np).map(|c| moved(&battery, c)).collect(),
            },
            deta: (0..np).map(|c| moved_vec(&deta, c)).collect(),
            dx_end: (0..np).map(|c| moved_vec(&e.dx, c)).collect(),
            dd,
        }
    }

    /// Which end of mode m's interval holds its free input at a bound (0: t_k, 1: t_k+1), where the decided
    /// value d lies inside its own bounds; `None` for an interior optimum.
    fn edge(&self, m: usize, d: f64, (u0, u1): (f64, f64)) -> Option<usize> {
        let ctx = self.run.ctx;
        let spec = ctx.spec;
        let free = &spec.inputs[spec.modes[m].free_input];
        if free.min.is_none() && free.max.is_none() {
            return None;
        }
        let decided = &spec.inputs[ctx.decided[m].first()?.0];
        if let (Some(a), Some(b)) = (decided.min, decided.max) {
            if (d - a).abs() <= 1e-9 * (b - a) || (b - d).abs() <= 1e-9 * (b - a) {
                return None;
            }
        }
        let (g0, g1) = (self.run.margin(m, u0), self.run.margin(m, u1));
        let (end, g) = if g1 > g0 { (1, g1) } else { (0, g0) };
        (g.abs() <= EDGE).then_some(end)
    }

    /// dη over the run's Runge–Kutta step of mode m with d held from dη(t_k) = `deta` (per column of `cols`),
    /// the stages' derivatives k_i in `self.sc.stages` from [`Ecms::end_in`] of the same interval, and the
    /// derivative of the interval's battery energy, the step's quadrature of P_batt at its stages:
    ///
    /// ```text
    /// dk_i = A_i (dη + c_i h dk_(i−1)) + B_i,   dη(t_k+1) = dη + h/6 (dk₁ + 2dk₂ + 2dk₃ + dk₄),
    /// dE = h/6 (dP₁ + 2dP₂ + 2dP₃ + dP₄),      dP_i = ∂P/∂η (dη + c_i h dk_(i−1)) + ∂P/∂p
    /// ```
    ///
    /// (A_i, B_i and P's row by one adjoint product per row at the stage's point).
    fn step(
        &mut self,
        (m, d): (usize, f64),
        k: usize,
        (x, u): (&[f64], f64),
        (cols, mut deta): (&[Option<usize>], Vec<Vec<f64>>),
    ) -> Result<(Vec<Vec<f64>>, Vec<f64>), ModalError> {
        let run = self.run;
        let model = run.ctx.model(m);
        let info = model.info();
        let (r, ne, nc) = (info.relative_degree, info.n_eta, cols.len());
        let samples = run.samples;
        let h = samples.t[k + 1] - samples.t[k];
        let tm = samples.t[k] + h / 2.0;
        let times = [samples.t[k], tm, tm, samples.t[k + 1]];
        let refs = [
            &samples.base[k],
            &samples.mid[k],
            &samples.mid[k],
            &samples.base[k + 1],
        ];
        let rows = [
            samples.signals_at(k),
            samples.signals_mid_at(k),
            samples.signals_mid_at(k),
            samples.signals_at(k + 1),
        ];
        let steps = [0.0, h / 2.0, h / 2.0, h];
        let weights = [1.0, 2.0, 2.0, 1.0];
        let eta0: Vec<f64> = info.eta_states.iter().map(|&s| x[s]).collect();
        let layout = invsim_model_api::SensitivityLayout::of(info);
        // The η rows, then P_batt's.
        let mut rows_q: Vec<usize> = (0..ne).map(|i| layout.eta(i)).collect();
        rows_q.push(layout.output(run.h.battery));
        let nr = ne + 1;
        let (mut dk, mut sum) = (vec![vec![0.0; ne]; nc], vec![vec![0.0; ne]; nc]);
        let mut battery = vec![0.0; nc];
        let mut eta = vec![0.0; ne];
        for i in 0..4 {
            // The stage's η as the run forms it: η + c_i h k_(i−1).
            for (j, e) in eta.iter_mut().enumerate() {
                *e = eta0[j]
                    + if i == 0 {
                        0.0
                    } else {
                        steps[i] * self.sc.stages[i - 1][j]
                    };
            }
            run.reference_into(m, refs[i], &mut self.y);
            run.signals_into(m, rows[i], d, &mut self.w);
            self.x.clear();
            self.x.extend_from_slice(x);
            let t = times[i];
            let ui = model
                .invert_from(&self.y[..r], &eta, &self.w, self.y[r], &mut self.x, u)
                .map_err(|e| run.ctx.err(m, t, e.to_string()))?;
            let buf = std::mem::take(&mut self.buf);
            let at = (t, &self.x[..], &self.w[..], ui);
            let point = point_into(run.ctx, (m, &self.wrt.grids[m]), at, buf)?;
            self.a.resize(nr * ne, 0.0);
            self.b.resize(nr * nc, 0.0);
            self.reference.resize(nr * (r + 1), 0.0);
            let ab = (&mut self.a[..], &mut self.b[..]);
            point.moved_row_jacobians(&rows_q, cols, ab, &mut self.reference);
            self.buf = point.into_buffer();
            for c in 0..nc {
                // The stage's dη, then each row's change along it: dk_i's rows and dP_i.
                let at: Vec<f64> = (0..ne).map(|j| deta[c][j] + steps[i] * dk[c][j]).collect();
                for row in 0..nr {
                    let mut v = self.b[c * nr + row];
                    for (j, a) in at.iter().enumerate() {
                        v += self.a[j * nr + row] * a;
                    }
                    if row < ne {
                        dk[c][row] = v;
                        sum[c][row] += weights[i] * v;
                    } else {
                        battery[c] += h / 6.0 * weights[i] * v;
                    }
                }
            }
        }
        for (de, s) in deta.iter_mut().zip(&sum) {
            for (v, sv) in de.iter_mut().zip(s) {
                *v += h / 6.0 * sv;
            }
        }
        Ok((deta, battery))
    }

    /// A shared interval: θ of it with the recorded choice (`mine`), 1 − θ with the other from the same
    /// state `start`; the trapezoid's terms in those shares, and the state's derivatives at the recorded
    /// end `end` (the recorded mode's ψ⁻¹ at the shared η, its decided value moved as in `mine`).
    fn shared(
        &mut self,
        (k, start, end): (usize, &[f64], (&[f64], f64)),
        (own, mine): ((usize, f64), Interval),
        sh: &Shared,
        dx: &[Vec<f64>],
    ) -> Result<(Terms, Vec<Vec<f64>>), ModalError> {
        let run = self.run;
        let (om, od) = sh.other;
        let t = run.samples.t[k];
        let p = run
            .point_in((om, k), start, od, &mut self.sc)
            .ok_or_else(|| {
                run.ctx
                    .err(om, t, "the shared choice's inverse failed".into())
            })?;
        let alt_x = self.sc.x.clone();
        let theirs = self.interval((om, od), k, (&alt_x, p.u), dx)?;
        let th = sh.theta;
        let mix = |a: &[f64], b: &[f64]| -> Vec<f64> {
            a.iter()
                .zip(b)
                .map(|(x, y)| th * x + (1.0 - th) * y)
                .collect()
        };
        let terms = Terms {
            fuel: mix(&mine.terms.fuel, &theirs.terms.fuel),
            battery: mix(&mine.terms.battery, &theirs.terms.battery),
        };
        let mut deta: Vec<Vec<f64>> = mine
            .deta
            .iter()
            .zip(&theirs.deta)
            .map(|(a, b)| mix(a, b))
            .collect();
        // The recorded end: own mode, d moved by mine.dd (its direct effect on ψ⁻¹ through the signal).
        let cols = self.columns(own.0);
        let np = self.wrt.params.len();
        let ne = deta.first().map_or(0, Vec::len);
        deta.resize(cols.len(), vec![0.0; ne]);
        let t1 = run.samples.t[k + 1];
        let point = self.point(
            (own.0, own.1, t1),
            (run.samples.signals_at(k + 1), end.0, end.1),
        )?;
        let at = self.changes(&point, &cols, &deta);
        self.buf = point.into_buffer();
        let dx_end = (0..np)
            .map(|c| {
                let moved = at.dx.get(np).filter(|_| mine.dd[c] != 0.0);
                match moved {
                    Some(dd_col) => at.dx[c]
                        .iter()
                        .zip(dd_col)
                        .map(|(a, b)| a + mine.dd[c] * b)
                        .collect(),
                    None => at.dx[c].clone(),
                }
            })
            .collect();
        Ok((terms, dx_end))
    }
}
