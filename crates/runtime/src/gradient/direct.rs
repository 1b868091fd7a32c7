//! The sensitivities of a run without internal states (r = n), carried along the run a block of samples at a
//! time: every sample is independent, so the run's block (its reference, x and u from `invert_batch`) is
//! differentiated as it is solved, the model's partial derivatives from `sensitivity_batch`, and the chain
//! rule of [`super::point`] is applied column by column (loops over the samples that vectorise) instead of
//! point by point.
//!
//! With r = n, ψ(x; p) = ξ and φ(x, u; p) = y^(r) (φ affine in u or not). For an accumulated output's row
//! q(x, u; p) at one sample (implicit function theorem, as in [`super::point`]):
//!
//! ```text
//! ratio = (∂q/∂u)/(∂φ/∂u),   g_j = ∂q/∂x_j − ratio·∂φ/∂x_j,   m = (∂ψ/∂x)⁻ᵀ g
//! dq/dp_c = ∂q/∂p_c − ratio·∂φ/∂p_c − Σ_(l<n) m_l ∂ψ_l/∂p_c
//! ```
//!
//! each evaluated in the same order as [`super::point::Point::row_jacobians`] (so the numbers are those of
//! the point-by-point pass from the same partial derivatives), then summed by the run's trapezoidal rule
//! ∫ dq/dp dt ≈ Σ_k dt·(dq_k + dq_(k+1))/2.

use invsim_model_api::{InverseModel, SensitivityLayout};

use super::derivatives::Derivatives;
use super::point::{inverse_two, invert};
use super::sample::Sums;
use crate::error::RunError;
use crate::inverse::SimulateError;

/// Samples per evaluation of the partial derivatives: their columns (every entry of the layout) are held
/// for this many samples at a time.
const SUB: usize = 256;

/// A block of the run: its times, signals' columns, states' columns and inputs (r = n: no η).
pub(crate) type RunBlock<'a> = (&'a [f64], &'a [&'a [f64]], &'a [&'a [f64]], &'a [f64]);

/// ∂(∫ o_a dt)/∂p_c for every accumulated output a and wanted parameter c of a run without internal states
/// (no grid values asked for), summed block by block as the run solves them ([`DirectSensitivities::block`]).
pub(crate) struct DirectSensitivities {
    params: Vec<usize>,
    accumulate: Vec<usize>,
    cols: Columns,
    sums: Sums,
    half: f64,
    /// The next block is the grid's first.
    opens: bool,
}

impl DirectSensitivities {
    /// For the run of `model` (`n_eta` = 0) by the parameters of `wrt` (no grid values) on a grid of step `dt`.
    pub(crate) fn new<M: InverseModel + ?Sized>(
        model: &M,
        wrt: &Derivatives,
        dt: f64,
    ) -> DirectSensitivities {
        let info = model.info();
        let layout = SensitivityLayout::of(info);
        debug_assert!(layout.n_eta == 0 && layout.n == layout.r && wrt.grid.is_empty());
        let params = wrt.columns(info.parameters.len());
        let accumulate: Vec<usize> = (0..info.outputs.len())
            .filter(|&i| info.outputs[i].accumulate)
            .collect();
        let mut cols = Columns::new(layout);
        cols.want(&params, &accumulate);
        DirectSensitivities {
            sums: Sums::new(accumulate.len(), params.len()),
            half: 0.5 * dt,
            opens: true,
            params,
            accumulate,
            cols,
        }
    }

    /// The run's block `b` (times, signals, x and u): its samples' terms of the integrals' derivatives.
    pub(crate) fn block<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        b: RunBlock<'_>,
    ) -> Result<(), SimulateError> {
        let len = b.0.len();
        let mut s0 = 0;
        while s0 < len {
            let sl = SUB.min(len - s0);
            self.cols.partials(model, b, (s0, sl))?;
            let opens = self.opens && s0 == 0;
            let wanted = (&self.params[..], &self.accumulate[..]);
            (self.cols).chain_rule(wanted, sl, (&mut self.sums, self.half, opens));
            s0 += sl;
        }
        self.opens = false;
        Ok(())
    }

    /// ∂(∫ o_a dt)/∂p_c, `[a][c]`, over the blocks so far.
    pub(crate) fn integrals(&self) -> Vec<Vec<f64>> {
        self.sums.integrals()
    }
}

/// The partial derivatives of a sub-block and the chain rule's work.
struct Columns {
    layout: SensitivityLayout,
    /// Entry e of the layout at sample k of the sub-block: `sens[e][k]`.
    sens: Vec<Vec<f64>>,
    /// The parameter-only entries of `sens` are written (by the first sub-block's evaluation).
    invariant_written: bool,
    /// The entries the chain rule reads: the rows of ψ, φ and the accumulated outputs, the columns of x, u
    /// and the wanted parameters (the others are not asked of the model: an empty column).
    wanted: Vec<bool>,
    /// (∂ψ/∂x)⁻¹ entry (j, l) at sample k of the sub-block: `inverse[j·n + l][k]`.
    inverse: Vec<Vec<f64>>,
    /// A sample's ∂ψ/∂x and its inverse (row-major), for [`invert`].
    jac: Vec<f64>,
    inv: Vec<f64>,
    /// One row's ratio, g_j, m_l and dq/dp_c over the sub-block.
    work: Work,
}

/// The chain rule's columns for one row over a sub-block.
struct Work {
    ratio: Vec<f64>,
    g: Vec<Vec<f64>>,
    m: Vec<Vec<f64>>,
    dq: Vec<f64>,
}

impl Columns {
    /// For sub-blocks of up to [`SUB`] samples.
    fn new(layout: SensitivityLayout) -> Columns {
        let n = layout.n;
        let sub = SUB;
        Columns {
            layout,
            sens: vec![vec![0.0; sub]; layout.len()],
            invariant_written: false,
            wanted: vec![true; layout.len()],
            inverse: vec![vec![0.0; sub]; n * n],
            jac: vec![0.0; n * n],
            inv: vec![0.0; n * n],
            work: Work {
                ratio: vec![0.0; sub],
                g: vec![vec![0.0; sub]; n],
                m: vec![vec![0.0; sub]; n],
                dq: vec![0.0; sub],
            },
        }
    }

    /// Asks the model for the entries of the chain rule of `params` and the outputs `accumulate` alone
    /// ([`Columns::wanted`]).
    fn want(&mut self, params: &[usize], accumulate: &[usize]) {
        let l = self.layout;
        let rows: Vec<usize> = (0..l.r)
            .map(|i| l.psi(i))
            .chain([l.phi()])
            .chain(accumulate.iter().map(|&o| l.output(o)))
            .collect();
        let columns: Vec<usize> = (0..l.n)
            .map(|j| l.x(j))
            .chain([l.u()])
            .chain(params.iter().map(|&p| l.param(p)))
            .collect();
        self.wanted.fill(false);
        for &row in &rows {
            for &column in &columns {
                self.wanted[l.at(row, column)] = true;
            }
        }
    }

    /// The partial derivatives at samples s0 … s0 + sl − 1 of the block into `sens[e][0 … sl − 1]`, and
    /// (∂ψ/∂x)⁻¹ at each of them (NaN where it is singular, as [`super::point::Point`] has it).
    fn partials<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        (time, w, x, u): RunBlock<'_>,
        (s0, sl): (usize, usize),
    ) -> Result<(), SimulateError> {
        let x: Vec<&[f64]> = x.iter().map(|c| &c[s0..s0 + sl]).collect();
        let w: Vec<&[f64]> = w.iter().map(|c| &c[s0..s0 + sl]).collect();
        let wanted = &self.wanted;
        let mut out: Vec<&mut [f64]> = (self.sens.iter_mut().zip(wanted))
            .map(|(c, &w)| if w { &mut c[..sl] } else { &mut [] })
            .collect();
        // The parameter-only entries once: the first sub-block is the longest, and the parameters stay.
        let invariant = !self.invariant_written;
        self.invariant_written = true;
        model
            .sensitivity_batch(&x, &w, &u[s0..s0 + sl], (&mut out, invariant))
            .map_err(|(i, source)| RunError::Model {
                t: time[s0 + i],
                source,
            })?;
        let l = &self.layout;
        let n = l.n;
        if n == 2 {
            self.invert_two(sl);
            return Ok(());
        }
        for k in 0..sl {
            // ∂ψ/∂x: row i holds ψ_i's partials by x_j.
            for (e, v) in self.jac.iter_mut().enumerate() {
                *v = self.sens[l.at(l.psi(e / n), l.x(e % n))][k];
            }
            if !invert(n, &mut self.jac, &mut self.inv) {
                self.inv.fill(f64::NAN);
            }
            for (c, &v) in self.inverse.iter_mut().zip(&self.inv) {
                c[k] = v;
            }
        }
        Ok(())
    }

    /// (∂ψ/∂x)⁻¹ at the sub-block's `sl` samples for n = 2, column by column ([`inverse_two`], as
    /// [`invert`] has it), NaN where it refuses.
    fn invert_two(&mut self, sl: usize) {
        let l = &self.layout;
        let entry = |i: usize, j: usize| &self.sens[l.at(l.psi(i), l.x(j))][..sl];
        let (a, b, c, d) = (entry(0, 0), entry(0, 1), entry(1, 0), entry(1, 1));
        let [i00, i01, i10, i11] = &mut self.inverse[..4] else {
            unreachable!("n = 2: four entries")
        };
        for k in 0..sl {
            let v = inverse_two([a[k], b[k], c[k], d[k]]).unwrap_or([f64::NAN; 4]);
            (i00[k], i01[k], i10[k], i11[k]) = (v[0], v[1], v[2], v[3]);
        }
    }

    /// dq/dp_c of every accumulated output and wanted parameter at the sub-block's `sl` samples, each column
    /// handed to the trapezoids (the module doc's formulas, in [`super::point::Point::row_jacobians`]'
    /// order); `opens`: the sub-block starts the grid.
    fn chain_rule(
        &mut self,
        (params, accumulate): (&[usize], &[usize]),
        sl: usize,
        (sums, half, opens): (&mut Sums, f64, bool),
    ) {
        let Columns {
            layout: l,
            sens,
            inverse,
            work,
            ..
        } = self;
        let n = l.n;
        let col = |row: usize, column: usize| &sens[l.at(row, column)][..sl];
        let phi = l.phi();
        let Work { ratio, g, m, dq } = work;
        let (ratio, dq) = (&mut ratio[..sl], &mut dq[..sl]);
        for (a, &o) in accumulate.iter().enumerate() {
            let q = l.output(o);
            for ((v, qu), pu) in ratio.iter_mut().zip(col(q, l.u())).zip(col(phi, l.u())) {
                *v = qu / pu;
            }
            for (j, g) in g.iter_mut().enumerate() {
                let (qx, px) = (col(q, l.x(j)), col(phi, l.x(j)));
                for (((v, qx), px), ratio) in g[..sl].iter_mut().zip(qx).zip(px).zip(&*ratio) {
                    *v = qx - ratio * px;
                }
            }
            for (li, m) in m.iter_mut().enumerate() {
                let m = &mut m[..sl];
                m.fill(0.0);
                for (j, g) in g.iter().enumerate() {
                    for ((v, g), inv) in m.iter_mut().zip(&g[..sl]).zip(&inverse[j * n + li][..sl])
                    {
                        *v += g * inv;
                    }
                }
            }
            for (c, &p) in params.iter().enumerate() {
                let column = l.param(p);
                let (qp, pp) = (col(q, column), col(phi, column));
                for (((v, qp), pp), ratio) in dq.iter_mut().zip(qp).zip(pp).zip(&*ratio) {
                    *v = qp - ratio * pp;
                }
                for (li, m) in m.iter().enumerate() {
                    for ((v, m), psi) in dq.iter_mut().zip(&m[..sl]).zip(col(l.psi(li), column)) {
                        *v -= m * psi;
                    }
                }
                sums.column(a * params.len() + c, dq, (half, opens));
            }
        }
    }
}
