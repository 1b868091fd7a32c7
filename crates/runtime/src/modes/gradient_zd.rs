//! The sensitivities of a mode's zero dynamics over one output interval, for the gradient of a run with
//! modes (`gradient.rs`), along the steps the run took over it:
//!
//! ```text
//! dη/dt = q(ξ_ref(t), η, y_ref^(r)(t); p)
//! dS/dt = A(t) S + B(t),   A = ∂q/∂η,   B_c = ∂q/∂p_c + Σ_(l<r) ∂q/∂ξ_l de_c,l(t) + ∂q/∂y^(r) de_c,r(t)
//! ```
//!
//! (Hairer, Nørsett & Wanner, *Solving ODEs I*, §I.14; de_c(t) the re-entry transition's derivative,
//! `gradient_point.rs`). As in the single-mode pass (`crate::gradient::pass`, the staggered direct method of
//! Caracotsios & Stewart 1985), η is the run's: a differentiated run logs each accepted step of its
//! integrator with the step's continuous extension (`zd_ode.rs`, [`crate::ode::StepLog`]), and S is advanced
//! over the same step by the Gauss–Legendre method of the extension's order (`crate::gradient::Gauss`; both
//! A-stable): 4 stages (order 8) over DOP853's steps with its extension of order 7, 2 stages (order 4) over
//! DOPRI5's with its extension of order 4. A and B are taken at the method's nodes from η's extension there:
//! x = ψ⁻¹(ξ_ref, η), u the inverse's input, A, B and the reference's columns ∂q/∂(ξ, y^(r)) by one adjoint
//! product per row ([`crate::gradient::Point::moved_row_jacobians`]), or the mode's closed form. S's
//! equations are linear with η's own linearisation A, so the steps that control η's error resolve S's time
//! scales too; the stiff manifold modes need no error control of S (Gauss–Legendre is stable for any step).
//! The reference at the nodes is the run's (the sub-grid interpolant where the run used one:
//! `crate::smoother::FineReference`).

use super::blend::{Blend, Blends};
use super::gradient_point::{add_transition_moves, point_into};
use super::record::{Ctx, ZdSteps};
use super::ModalError;
use crate::gradient::{Buffers, ClosedJacobian, ClosedRows as Rows, Gauss, GridColumns, Singular};
use crate::ode::StepFailure;
use crate::smoother::FineReference;

/// The most nodes of a step (the 4-stage method's).
const NODES_MAX: usize = 4;

/// Per mode (built at the mode's first interval) its Gauss–Legendre method and work space.
pub(super) struct ZdSensitivity {
    modes: Vec<Option<ModeZd>>,
    /// Where the last interval found the first corner within the look-ahead ([`Smoother::still_on_from`]).
    corner: usize,
}

/// The mode, its transition and the transition's derivatives, and each derivative's column in the mode with
/// the mode's columns of the grid values.
pub(super) type Along<'b> = (
    usize,
    Option<&'b Blend>,
    Option<&'b Blends>,
    (&'b [Option<usize>], &'b GridColumns),
);

/// One mode's Gauss–Legendre method, S (ne × P, column-major) and the buffers of its nodes.
struct ModeZd {
    gauss: Gauss,
    s: Vec<f64>,
    nodes: Nodes,
}

/// A and B at a step's nodes and the buffers of their evaluation.
struct Nodes {
    /// The mode's reader of the reference's sub-grid (`None`: the smoother pointwise, as in the run).
    fine: Option<FineReference>,
    eta: Vec<f64>,
    x: Vec<f64>,
    yr: Vec<f64>,
    w: Vec<f64>,
    /// The transition's basis at a node ([`Blends::basis_at`]) and its moves of the reference.
    basis: Vec<f64>,
    moved: Vec<f64>,
    /// ∂q/∂(ξ, y^(r)) (ne × (r + 1), column-major).
    reference: Vec<f64>,
    rows: Vec<usize>,
    buf: Buffers,
    a: [Vec<f64>; NODES_MAX],
    b: [Vec<f64>; NODES_MAX],
    /// The mode's closed-form A, B and reference columns, where it has them ([`ClosedJacobian`]).
    closed: ClosedJacobian,
}

/// The Gauss–Legendre stages for a logged step: 4 over DOP853's (order 8), 2 over DOPRI5's.
fn stages_for(order: usize) -> usize {
    if order >= 8 {
        4
    } else {
        2
    }
}

impl ZdSensitivity {
    /// For the run of `ctx` (reading the zero dynamics' reference as the run does).
    pub(super) fn new(ctx: &Ctx<'_, '_>) -> ZdSensitivity {
        ZdSensitivity {
            modes: (0..ctx.spec.modes.len()).map(|_| None).collect(),
            corner: 0,
        }
    }

    /// Advance S (`deta`, per derivative) of mode m over interval k, [ta, tb], along the run's logged steps
    /// (`steps`) from the run's state and input at ta (`start`: the guesses of the inverse).
    pub(super) fn advance(
        &mut self,
        ctx: &Ctx<'_, '_>,
        along: Along<'_>,
        (k, steps): (usize, &ZdSteps),
        (ta, tb): (f64, f64),
        (x0, u0): (&[f64], f64),
        deta: &mut [Vec<f64>],
    ) -> Result<(), ModalError> {
        let m = along.0;
        let info = ctx.model(m).info();
        let (r, ne, nw) = (info.relative_degree, info.n_eta, info.n_w());
        let np = deta.len();
        let range = steps.of_interval(k);
        let Some(first) = range.clone().next().map(|i| steps.log.step(i)) else {
            return Ok(());
        };
        let stages = stages_for(first.order());
        let zd = self.modes[m].get_or_insert_with(|| ModeZd {
            gauss: Gauss::with_stages(ne, np, stages),
            s: vec![0.0; ne * np],
            nodes: Nodes::new(ctx, m, np),
        });
        for (c, d) in deta.iter().enumerate() {
            zd.s[ne * c..ne * (c + 1)].copy_from_slice(d);
        }
        // Where the reference is constant on the interval (a standstill more than a look-ahead from any
        // corner, no transition under way: as the run has it) every node takes ta's.
        let smoother = &ctx.reference.smoother;
        let still =
            along.1.is_none_or(|b| b.done(ta)) && smoother.still_on_from(&mut self.corner, ta, tb);
        let ModeZd { gauss, s, nodes } = zd;
        if still {
            let (y, w) = (&mut nodes.yr[..=r], (&mut nodes.w, nw));
            ctx.stage_reference_into((m, ta, along.1), nodes.fine.as_mut(), y, w);
        }
        let fail = |e: StepFailure| {
            let reason = format!("the zero dynamics' sensitivities failed: {}", e.reason);
            ctx.err(m, e.t, reason)
        };
        for i in range {
            let step = steps.log.step(i);
            let stages = stages_for(step.order());
            if gauss.nodes().len() != stages {
                *gauss = Gauss::with_stages(ne, np, stages);
            }
            let mut c = [0.0; NODES_MAX];
            c[..stages].copy_from_slice(gauss.nodes());
            for (j, c) in c[..stages].iter().enumerate() {
                let at = step.t + c * step.h;
                steps.log.eval(&step, at, &mut nodes.eta);
                nodes
                    .jacobians_at(ctx, &along, (at, x0, u0, still), j)
                    .map_err(fail)?;
            }
            let a: [&[f64]; NODES_MAX] = std::array::from_fn(|j| &nodes.a[j][..]);
            let b: [&[f64]; NODES_MAX] = std::array::from_fn(|j| &nodes.b[j][..]);
            gauss
                .step(step.h, &a[..stages], &b[..stages], s)
                .map_err(|Singular| {
                    fail(StepFailure {
                        t: step.t,
                        reason: "the Gauss–Legendre stage system is singular or not finite".into(),
                    })
                })?;
        }
        for (c, d) in deta.iter_mut().enumerate() {
            d.copy_from_slice(&s[ne * c..ne * (c + 1)]);
        }
        Ok(())
    }
}

impl Nodes {
    fn new(ctx: &Ctx<'_, '_>, m: usize, np: usize) -> Nodes {
        let info = ctx.model(m).info();
        let (r, ne) = (info.relative_degree, info.n_eta);
        let layout = invsim_model_api::SensitivityLayout::of(info);
        Nodes {
            fine: ctx.fine_reference(),
            eta: vec![0.0; ne],
            x: vec![0.0; ctx.n],
            yr: vec![0.0; ctx.r_max + 1],
            w: Vec::new(),
            basis: Vec::new(),
            moved: Vec::new(),
            reference: vec![0.0; ne * (r + 1)],
            rows: (0..ne).map(|i| layout.eta(i)).collect(),
            buf: Buffers::default(),
            a: std::array::from_fn(|_| vec![0.0; ne * ne]),
            b: std::array::from_fn(|_| vec![0.0; ne * np]),
            closed: ClosedJacobian::default(),
        }
    }

    /// A and B (with the transition's moves, the module doc's B_c) into node i's matrices at time s and the
    /// interpolated η (`self.eta`), the reference at s (`still`: the interval's constant one, in `yr` and `w`
    /// already): from the mode's closed form where it has one, else by the implicit
    /// function theorem at x = ψ⁻¹(ξ_ref, η) ([`Nodes::solved_jacobians`]).
    fn jacobians_at(
        &mut self,
        ctx: &Ctx<'_, '_>,
        (m, blend, dblend, (cols, grid)): &Along<'_>,
        (s, x0, u0, still): (f64, &[f64], f64, bool),
        i: usize,
    ) -> Result<(), StepFailure> {
        let m = *m;
        let model = ctx.model(m);
        let info = model.info();
        let (r, ne, nw) = (info.relative_degree, info.n_eta, info.n_w());
        if !still {
            let at = (m, s, *blend);
            let (y, w) = (&mut self.yr[..=r], (&mut self.w, nw));
            ctx.stage_reference_into(at, self.fine.as_mut(), y, w);
        }
        let (a, b) = (&mut self.a[i], &mut self.b[i]);
        let point = Rows::ZeroDynamics(&self.yr[..r], &self.eta, &self.w, self.yr[r]);
        if !self
            .closed
            .eval(model, (point, cols), (a, b, Some(&mut self.reference)))
        {
            self.solved_jacobians(ctx, (m, cols, grid), (s, x0, u0), i)?;
        }
        // B_c += ∂q/∂(ξ, y^(r)) de_c(s): the transition's move of the reference.
        let buffers = (r + 1, &mut self.basis, &mut self.moved);
        add_transition_moves((&mut self.b[i], ne), (&self.reference, *dblend, s), buffers);
        Ok(())
    }

    /// A, B and the reference's columns into node i's matrices by the implicit function theorem at
    /// x = ψ⁻¹(ξ_ref, η) (Newton's from the interval's start x0 where ψ⁻¹ is numeric), u from u0.
    fn solved_jacobians(
        &mut self,
        ctx: &Ctx<'_, '_>,
        (m, cols, grid): (usize, &[Option<usize>], &GridColumns),
        (s, x0, u0): (f64, &[f64], f64),
        i: usize,
    ) -> Result<(), StepFailure> {
        let model = ctx.model(m);
        let r = model.info().relative_degree;
        let fail = |reason: String| StepFailure { t: s, reason };
        self.x.copy_from_slice(x0);
        let u = model
            .invert_from(
                &self.yr[..r],
                &self.eta,
                &self.w,
                self.yr[r],
                &mut self.x,
                u0,
            )
            .map_err(|e| fail(e.to_string()))?;
        let buf = std::mem::take(&mut self.buf);
        let point = point_into(ctx, (m, grid), (s, &self.x, &self.w, u), buf)
            .map_err(|e| fail(e.to_string()))?;
        let (a, b) = (&mut self.a[i], &mut self.b[i]);
        point.moved_row_jacobians(&self.rows, cols, (a, b), &mut self.reference);
        self.buf = point.into_buffer();
        Ok(())
    }
}
