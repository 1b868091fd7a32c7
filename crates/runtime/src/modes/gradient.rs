//! Exact parameter gradients of a run with modes (`simulate --gradient` of a model with `[modes]`): the
//! recorded run replayed interval by interval, each in the mode it ran in, with the sensitivities carried
//! across the switches.
//!
//! The mode and gear sequence is held fixed: the gear and standstill follow the smoothed cycle (no parameter
//! moves them), and where the sequence decides from the solution (traction ↔ brake by the sign of the force
//! needed) both sides give the same integrand at the switch, so the figures are continuous there and
//! differentiable wherever no decision sits exactly on its threshold (almost everywhere in p).
//!
//! In an interval of mode m the state and input are x = ψ_m⁻¹(ξ_ref, η; p), u = (y_ref^(r) − α)/β, with
//! ξ_ref = y_c + e(t) the smoothed cycle plus the re-entry's transition e (`blend.rs`). The chain rule at each
//! point is [`crate::gradient::Point`]'s (implicit function theorem), with two sources of change besides p:
//! * η: S = ∂η/∂p obeys dS/dt = ∂q/∂η S + ∂q/∂ξ dξ_ref + ∂q/∂y^(r) dy_ref^(r) + ∂q/∂p along the mode's zero
//!   dynamics ([`super::gradient_zd`]; Hairer, Nørsett & Wanner, *Solving ODEs I*, §I.14), from the
//!   equilibrium's S = −(∂q/∂η)⁻¹ ∂q/∂p at the start (implicit function theorem);
//! * the transition: e(τ) = (1 − S(τ/T)) Σ_j e_j τ^j/j! is linear in its initial deviations e_j =
//!   ψ_(m,j+1)(x(t_s)) − y_c^(j)(t_s) (and e_r = y_prev^(r) − y_c^(r) where the input continues), so its
//!   derivative is the transition of de_j = ∂ψ_(m,j+1)/∂x dx(t_s) + ∂ψ_(m,j+1)/∂p (and dy_prev^(r)).
//!
//! The state is shared by the modes and continuous at a switch, so dx(t_s) is the old mode's at the end of
//! its interval and the new mode's η sensitivities are its components: dη = dx_(eta_states). The integrals
//! are differentiated through the run's trapezoids, each interval's two ends in its own mode, exactly as
//! `summary.rs` sums them.

use super::blend::{Blend, Blends};
use super::gradient_point::{moved_references, point_at, point_into, OutputChanges};
use super::gradient_zd::ZdSensitivity;
use super::record::{Ctx, EntryLog, Record};
use super::{ModalError, ModalSpec, ModalSummary};
use crate::gradient::{figures, Buffers, Direction, Gradient, Integrals, ModalWrt, Point, Wrt};
use crate::grid::Grid;

/// ∂(∫ o_a dt)/∂p_c for the model's accumulated outputs a, in their order (`[a][c]`), of the run `rec` on
/// `grid` with the look-ahead and the zero dynamics' reference `reference`.
pub(super) fn of_run(
    ctx: &Ctx<'_, '_>,
    grid: &Grid,
    rec: &Record,
    wrt: &ModalWrt,
) -> Result<Vec<Vec<f64>>, ModalError> {
    let info = ctx.spec.modes[0].model.info();
    let accumulated: Vec<usize> = (0..ctx.spec.n_outputs)
        .filter(|&o| info.outputs[o].accumulate)
        .collect();
    let zd = ZdSensitivity::new(ctx);
    integral_gradients(ctx, (grid, zd), rec, wrt, &accumulated)
}

/// The summary's `gradient` block from the integrals' derivatives `d` ([`of_run`]) and the figures of
/// `summary` (the integrals' values, the distance).
pub(super) fn figures_of(
    spec: &ModalSpec<'_>,
    wrt: &ModalWrt,
    summary: &ModalSummary,
    d: Vec<Vec<f64>>,
) -> Gradient {
    let info = spec.modes[0].model.info();
    let accumulate: Vec<usize> = (0..spec.n_outputs)
        .filter(|&o| info.outputs[o].accumulate)
        .collect();
    let values: Vec<f64> = accumulate
        .iter()
        .map(|&o| {
            let name = &info.outputs[o].name;
            summary
                .totals
                .integrals
                .get(name)
                .copied()
                .unwrap_or(f64::NAN)
        })
        .collect();
    let names: Vec<String> = wrt.params.iter().map(|p| p.name.clone()).collect();
    let params: Vec<usize> = wrt.params.iter().map(|p| p.param).collect();
    let integrals = Integrals {
        accumulate: &accumulate,
        values: &values,
        derivatives: &d,
    };
    let by = Wrt {
        names: &names,
        params: &params,
        values: spec.modes[0].model.params(),
    };
    Gradient {
        figures: figures(info, &by, &integrals, summary.run.distance_m),
    }
}

/// ∂(∫ o_a dt)/∂p_c for every accumulated output a of the model (`[a][c]`, a in the order of `accumulated`)
/// and every derivative c of `wrt`, over the recorded run `rec` on `grid`.
fn integral_gradients(
    ctx: &Ctx<'_, '_>,
    (grid, zd): (&Grid, ZdSensitivity),
    rec: &Record,
    wrt: &ModalWrt,
    accumulated: &[usize],
) -> Result<Vec<Vec<f64>>, ModalError> {
    let mut pass = Pass::start(ctx, (rec, zd), wrt, accumulated)?;
    let mut entries = rec.entries.iter().peekable();
    let ns = rec.t.len();
    for k in 0..ns.saturating_sub(1) {
        while let Some(e) = entries.next_if(|e| e.sample == k) {
            pass.enter(e, rec.t[k])?;
        }
        pass.interval(rec, k, grid.dt)?;
    }
    Ok(pass.acc)
}

/// The pass's state between samples: the mode in force with its transition (the run's and its derivative
/// per parameter), η's sensitivities, the continuous state's last derivative and the integrals' derivatives.
struct Pass<'p, 'a, 'm> {
    ctx: &'p Ctx<'a, 'm>,
    wrt: &'p ModalWrt,
    accumulated: &'p [usize],
    mode: usize,
    blend: Option<Blend>,
    /// de(t) of the transition, per derivative c (none before the first switch).
    dblend: Option<Blends>,
    /// ∂η/∂p_c of the mode in force, per c.
    deta: Vec<Vec<f64>>,
    zd: ZdSensitivity,
    acc: Vec<Vec<f64>>,
    /// The state and input at the last point (where a switch leaves from).
    x: Vec<f64>,
    u: f64,
    /// Buffers of a switch: the signals, a point's, dx/dp_c per c, a direction's dx, the transition's
    /// basis and its moves de_c (per c, r + 1 each).
    w: Vec<f64>,
    buf: Buffers,
    dx: Vec<Vec<f64>>,
    dir: Vec<f64>,
    basis: Vec<f64>,
    de: Vec<f64>,
    /// The transitions' bases made so far, one per number of deviations ([`Blends::basis`]).
    bases: Vec<std::sync::Arc<[Blend]>>,
    outputs: OutputChanges,
    /// The output derivatives at the start and the end of the interval in hand (entry (a, c) at c·na + a).
    start: Vec<f64>,
    end: Vec<f64>,
    /// Whether `end` holds the last interval's end where the next one starts from the same point in the same
    /// mode (the run's next sample bit for bit, no switch between).
    carried: bool,
}

impl<'p, 'a, 'm> Pass<'p, 'a, 'm> {
    /// The start: the first mode (the one the run started in, before any switch at t0) at its
    /// zero dynamics' equilibrium, S = −(∂q/∂η)⁻¹ ∂q/∂p.
    fn start(
        ctx: &'p Ctx<'a, 'm>,
        (rec, zd): (&Record, ZdSensitivity),
        wrt: &'p ModalWrt,
        accumulated: &'p [usize],
    ) -> Result<Self, ModalError> {
        let mode = rec
            .entries
            .first()
            .filter(|e| e.sample == 0)
            .map_or(rec.mode[0], |e| e.from);
        let t0 = rec.t[0];
        let x = rec.states[0].to_vec();
        let model = ctx.model(mode);
        let info = model.info();
        let w = ctx.w(mode, t0);
        let mut y = vec![0.0; ctx.r_max + 1];
        ctx.reference_into(mode, t0, None, &mut y);
        let r = info.relative_degree;
        let eta: Vec<f64> = info.eta_states.iter().map(|&s| x[s]).collect();
        let mut xs = x.clone();
        let u = model
            .invert(&y[..r], &eta, &w, y[r], &mut xs)
            .map_err(|e| ctx.err(mode, t0, e.to_string()))?;
        let point = point_at(ctx, (mode, &wrt.grids[mode]), (t0, &xs, &w, u))?;
        let deta = equilibrium_sensitivity(&point, &wrt.columns[mode]);
        let np = wrt.params.len();
        Ok(Pass {
            ctx,
            wrt,
            accumulated,
            mode,
            blend: None,
            dblend: None,
            deta,
            zd,
            acc: vec![vec![0.0; np]; accumulated.len()],
            x: xs,
            u,
            w: Vec::new(),
            buf: Buffers::default(),
            dx: Vec::new(),
            dir: Vec::new(),
            basis: Vec::new(),
            de: Vec::new(),
            bases: Vec::new(),
            outputs: OutputChanges::default(),
            start: Vec::new(),
            end: Vec::new(),
            carried: false,
        })
    }

    /// The column of derivative c in mode m.
    fn column(&self, m: usize, c: usize) -> Option<usize> {
        self.wrt.columns[m][c]
    }

    /// Mode m's partial derivatives at the last point (x, u) at time t, in the buffers of the last such point.
    fn point_here(&mut self, m: usize, t: f64) -> Result<Point, ModalError> {
        let ctx = self.ctx;
        ctx.w_into(m, t, ctx.model(m).info().n_w(), &mut self.w);
        let buf = std::mem::take(&mut self.buf);
        let at = (t, &self.x[..], &self.w[..], self.u);
        point_into(ctx, (m, &self.wrt.grids[m]), at, buf)
    }

    /// dx/dp_c of the continuous state at the last point (x, u) at time t in the mode in force, per c, into
    /// `self.dx` (dx = ∂x/∂(ξ, η) (dξ, dη) with dξ the transition's de_c(t), dη = S_c, and the parameter's
    /// own column).
    fn state_changes(&mut self, t: f64) -> Result<(), ModalError> {
        let (ctx, m) = (self.ctx, self.mode);
        let point = self.point_here(m, t)?;
        let orders = point.layout().r + 1;
        let np = self.wrt.params.len();
        moved_references(
            self.dblend.as_ref(),
            (np, t, orders),
            &mut self.basis,
            &mut self.de,
        );
        let mut dir = Direction {
            dx: std::mem::take(&mut self.dir),
            du: 0.0,
        };
        dir.dx.resize(ctx.n, 0.0);
        self.dx.resize_with(np, Vec::new);
        for c in 0..np {
            let de = &self.de[c * orders..(c + 1) * orders];
            let col = self.column(m, c);
            point.moved_into(
                &de[..orders - 1],
                de[orders - 1],
                &self.deta[c],
                col,
                &mut dir,
            );
            self.dx[c].clear();
            self.dx[c].extend_from_slice(&dir.dx);
        }
        self.dir = dir.dx;
        self.buf = point.into_buffer();
        Ok(())
    }

    /// A committed entry at time t: the new mode's transition of de (from dx of the state it starts from)
    /// and its η's sensitivities (dx's components).
    fn enter(&mut self, e: &EntryLog, t: f64) -> Result<(), ModalError> {
        let ctx = self.ctx;
        self.state_changes(t)?;
        let to = e.to;
        let model = ctx.model(to);
        let info = model.info();
        let r = info.relative_degree;
        let np = self.wrt.params.len();
        // The old transition's move of y^(r) at t, per c (the new mode's r-th deviation carries it on).
        moved_references(
            self.dblend.as_ref(),
            (np, t, r + 1),
            &mut self.basis,
            &mut self.de,
        );
        let point = self.point_here(to, t)?;
        let l = *point.layout();
        let mut deviations = Vec::with_capacity(np);
        let mut dir = Direction {
            dx: Vec::new(),
            du: 0.0,
        };
        for c in 0..np {
            let deta = &mut self.deta[c];
            deta.clear();
            deta.extend(info.eta_states.iter().map(|&s| self.dx[c][s]));
            dir.dx = std::mem::take(&mut self.dx[c]);
            let col = self.column(to, c);
            let mut de: Vec<f64> = Vec::with_capacity(r + 1);
            de.extend((0..r).map(|j| point.row_change(l.psi(j), &dir, col)));
            if e.deviations > r {
                de.push(self.de[c * (r + 1) + r]);
            }
            deviations.push(de);
            self.dx[c] = std::mem::take(&mut dir.dx);
        }
        self.buf = point.into_buffer();
        let len = deviations.first().map_or(0, Vec::len);
        let basis = match self.bases.iter().find(|b| b.len() == len) {
            Some(b) => b.clone(),
            None => {
                let b = Blends::basis(len, ctx.transition);
                self.bases.push(b.clone());
                b
            }
        };
        self.dblend = Some(Blends::on(basis, t, deviations));
        self.blend = e.blend.clone();
        self.mode = to;
        self.carried = false;
        Ok(())
    }

    /// Interval k: the derivatives of the outputs at its ends (in its mode), η's sensitivities integrated
    /// across it, the trapezoid's term dt·(do_start + do_end)/2.
    fn interval(&mut self, rec: &Record, k: usize, dt: f64) -> Result<(), ModalError> {
        let ctx = self.ctx;
        let m = self.mode;
        let (ta, tb) = (rec.t[k], rec.t[k + 1]);
        if self.carried {
            std::mem::swap(&mut self.start, &mut self.end);
        } else {
            let mut start = std::mem::take(&mut self.start);
            self.outputs_into((ta, &rec.states[k], rec.free[k]), &mut start)?;
            self.start = start;
        }
        let model = ctx.model(m);
        if model.info().n_eta > 0 {
            let cols = (&self.wrt.columns[m][..], &self.wrt.grids[m]);
            let guess = (&rec.states[k], rec.free[k]);
            let steps = rec.zd_steps.as_ref().ok_or_else(|| {
                ModalError::Setup("the run kept no steps of its zero dynamics".into())
            })?;
            self.zd.advance(
                ctx,
                (m, self.blend.as_ref(), self.dblend.as_ref(), cols),
                (k, steps),
                (ta, tb),
                guess,
                &mut self.deta,
            )?;
        }
        let mut end = std::mem::take(&mut self.end);
        self.outputs_into((tb, &rec.x_end[k], rec.u_end[k]), &mut end)?;
        self.end = end;
        let na = self.accumulated.len();
        for (a, row) in self.acc.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v += 0.5 * dt * (self.start[c * na + a] + self.end[c * na + a]);
            }
        }
        self.x.copy_from_slice(&rec.x_end[k]);
        self.u = rec.u_end[k];
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(p, q)| p.to_bits() == q.to_bits());
        self.carried = rec.mode.get(k + 1) == Some(&m)
            && rec.u_end[k].to_bits() == rec.free[k + 1].to_bits()
            && same(&rec.x_end[k], &rec.states[k + 1]);
        Ok(())
    }

    /// d o_a/d p_c of the accumulated outputs at (x, u) at time t in the mode in force into `out` (entry (a, c)
    /// at c·na + a).
    fn outputs_into(
        &mut self,
        (t, x, u): (f64, &[f64], f64),
        out: &mut Vec<f64>,
    ) -> Result<(), ModalError> {
        let at = (
            (self.mode, t),
            (x, u),
            (&self.deta[..], self.dblend.as_ref()),
        );
        let outputs = (self.wrt, self.accumulated);
        self.outputs.at(self.ctx, outputs, at, out)
    }
}

/// S = −(∂q/∂η)⁻¹ ∂q/∂p_c at an equilibrium of the zero dynamics (`point`), per derivative c with its
/// column `columns[c]` in the mode (implicit function theorem; empty for a mode without internal dynamics).
fn equilibrium_sensitivity(point: &Point, columns: &[Option<usize>]) -> Vec<Vec<f64>> {
    let l = *point.layout();
    let ne = l.n_eta;
    if ne == 0 {
        return vec![Vec::new(); columns.len()];
    }
    let q_eta = nalgebra::DMatrix::from_fn(ne, ne, |i, j| {
        let mut e = vec![0.0; ne];
        e[j] = 1.0;
        point.row_change(l.eta(i), &point.direction(&e, None), None)
    });
    let zero = vec![0.0; ne];
    let lu = q_eta.lu();
    columns
        .iter()
        .map(|&col| {
            let q_p = nalgebra::DVector::from_fn(ne, |i, _| {
                -point.row_change(l.eta(i), &point.direction(&zero, col), col)
            });
            lu.solve(&q_p)
                .map_or_else(|| vec![f64::NAN; ne], |s| s.iter().copied().collect())
        })
        .collect()
}
