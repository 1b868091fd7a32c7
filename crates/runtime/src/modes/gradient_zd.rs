//! The sensitivities of a mode's zero dynamics over one output interval, for the gradient of a run with
//! modes (`gradient.rs`): [η, S_1, …, S_P] integrated together by Dormand–Prince 5(4) at rtol 1e-10, atol
//! 1e-12 (a hundred times tighter than the run's `zd_ode.rs`: the derivatives are compared with central
//! differences of the run), S in the error norm too, from the η the run recorded at the interval's start:
//!
//! ```text
//! dη/dt  = q(ξ_ref(t), η, y_ref^(r)(t); p)
//! dS_c/dt = ∂q/∂η S_c + ∂q/∂ξ dξ_ref,c(t) + ∂q/∂y^(r) dy_ref,c^(r)(t) + ∂q/∂p_c
//! ```
//!
//! (Hairer, Nørsett & Wanner, *Solving ODEs I*, §I.14), each right-hand side by the chain rule of
//! [`crate::gradient::Point`] at x = ψ⁻¹(ξ_ref, η), u the inverse's input. η here is the run's to the
//! integrator's tolerance (the run integrates it by DOP853 on a sub-grid reference), and S the derivative of
//! the exact η to the same tolerance; each interval starts again from the run's η.

use super::blend::Blend;
use super::gradient_point::{moved_reference_into, point_into};
use super::record::Ctx;
use super::ModalError;
use crate::gradient::{Buffers, Direction, GridColumns};
use crate::ode::{Dopri5, StepFailure};

const RTOL: f64 = 1e-10;
const ATOL: f64 = 1e-12;

/// One integrator per mode (built at the mode's first interval), reused, and where the last interval ended.
pub(super) struct ZdSensitivity {
    ode: Vec<Option<Dopri5>>,
    last: Option<(usize, f64)>,
}

/// The mode, its transition and the transition's derivatives, and each derivative's column in the mode with
/// the mode's columns of the grid values.
pub(super) type Along<'b> = (
    usize,
    Option<&'b Blend>,
    &'b [Option<Blend>],
    (&'b [Option<usize>], &'b GridColumns),
);

impl ZdSensitivity {
    pub(super) fn new(modes: usize) -> ZdSensitivity {
        ZdSensitivity {
            ode: (0..modes).map(|_| None).collect(),
            last: None,
        }
    }

    /// Advance S (`deta`, per derivative) of mode m over [ta, tb] from the run's state and input at ta
    /// (`start`: η's start and the guesses of the inverse).
    pub(super) fn advance(
        &mut self,
        ctx: &Ctx<'_, '_>,
        (m, blend, dblend, (cols, grid)): Along<'_>,
        (ta, tb): (f64, f64),
        (x0, u0): (&[f64], f64),
        deta: &mut [Vec<f64>],
    ) -> Result<(), ModalError> {
        let model = ctx.model(m);
        let info = model.info();
        let (r, ne, nw) = (info.relative_degree, info.n_eta, info.n_w());
        let np = deta.len();
        let mut y = vec![0.0; ne * (1 + np)];
        for (j, &s) in info.eta_states.iter().enumerate() {
            y[j] = x0[s];
        }
        for (c, d) in deta.iter().enumerate() {
            y[ne * (1 + c)..ne * (2 + c)].copy_from_slice(d);
        }
        let ode = self.ode[m].get_or_insert_with(|| Dopri5::new(y.len(), RTOL, ATOL, tb - ta));
        let h0 = match self.last {
            Some((lm, lt)) if lm == m && lt.to_bits() == ta.to_bits() => {
                ode.step_size().min(tb - ta)
            }
            _ => (tb - ta) / 4.0,
        };
        self.last = Some((m, tb));
        ode.reset(h0);
        let (mut yr, mut w, mut x) = (vec![0.0; ctx.r_max + 1], Vec::new(), x0.to_vec());
        let mut dir = Direction {
            dx: vec![0.0; ctx.n],
            du: 0.0,
        };
        let (mut buf, mut de) = (Buffers::default(), vec![0.0; r + 1]);
        let fail = |t: f64, reason: String| StepFailure { t, reason };
        let mut f = |s: f64, v: &[f64], dv: &mut [f64]| -> Result<(), StepFailure> {
            ctx.reference_into(m, s, blend, &mut yr[..=r]);
            ctx.w_into(m, s, nw, &mut w);
            let (xi, eta) = (&yr[..r], &v[..ne]);
            model.zero_dynamics_from(xi, eta, &w, yr[r], u0, &mut dv[..ne]);
            x.copy_from_slice(x0);
            let u = model
                .invert_from(xi, eta, &w, yr[r], &mut x, u0)
                .map_err(|e| fail(s, e.to_string()))?;
            let point = point_into(ctx, (m, grid), (s, &x, &w, u), std::mem::take(&mut buf))
                .map_err(|e| fail(s, e.to_string()))?;
            let l = *point.layout();
            for c in 0..np {
                moved_reference_into(dblend[c].as_ref(), s, &mut de);
                let range = ne * (1 + c)..ne * (2 + c);
                point.moved_into(&de[..r], de[r], &v[range.clone()], cols[c], &mut dir);
                for (j, d) in dv[range].iter_mut().enumerate() {
                    *d = point.row_change(l.eta(j), &dir, cols[c]);
                }
            }
            buf = point.into_buffer();
            Ok(())
        };
        ode.advance(ta, tb, &mut y, &mut f).map_err(|e| {
            ctx.err(
                m,
                e.t,
                format!("the zero dynamics' sensitivities failed: {}", e.reason),
            )
        })?;
        for (c, d) in deta.iter_mut().enumerate() {
            d.copy_from_slice(&y[ne * (1 + c)..ne * (2 + c)]);
        }
        Ok(())
    }
}
