//! What both sensitivity passes ([`super::pass`], causal; [`super::stable`], non-causal) do at a grid sample:
//! the reference read from the block's columns, the inverse solved from η with the last sample's state and
//! input as Newton's guesses (as the run solves it), the chain rule's [`Point`] there, and the trapezoidal
//! sums ∫ do_a/dp_c dt ≈ Σ_k dt·(do_k + do_(k+1))/2 of the accumulated outputs' derivatives.

use invsim_model_api::InverseModel;

use super::grid_columns::GridColumns;
use super::point::{Buffers, Point};
use crate::error::RunError;
use crate::grid::{Grid, MAX_DERIVATIVES};
use crate::inverse::SimulateError;
use crate::smoother::Smoother;

/// A block's columns at one sample: time t, column index i of y_d … y_d^(r) (`yd`) and of the signals (`w`).
pub(super) type At<'a> = (f64, &'a [Vec<f64>], &'a [Vec<f64>], usize);

/// The state a pass carries from sample to sample.
pub(super) struct Samples {
    /// The last sample's state and input (the guesses of a numerically solved ψ⁻¹ and input).
    pub(super) x: Vec<f64>,
    pub(super) u_prev: f64,
    buf: Buffers,
    /// ∫ do_a/dp_c dt so far.
    pub(super) sums: Sums,
    /// The accumulated outputs' ∂o/∂η (na × ne) and ∂o/∂p (na × P) at the sample, column-major.
    o_eta: Vec<f64>,
    o_p: Vec<f64>,
    /// The accumulated outputs' rows of the partials, and the sample's signal values.
    rows: Vec<usize>,
    w: Vec<f64>,
}

impl Samples {
    /// For a model of `n_states` states, `accumulated` outputs and `params` parameters.
    pub(super) fn new(n_states: usize, accumulated: usize, params: usize) -> Samples {
        Samples {
            x: vec![0.0; n_states],
            u_prev: f64::NAN,
            buf: Buffers::default(),
            sums: Sums::new(accumulated, params),
            o_eta: Vec::new(),
            o_p: vec![0.0; accumulated * params],
            rows: Vec::new(),
            w: Vec::new(),
        }
    }

    /// The inverse at the sample `at` with internal state `eta`, and the partials there (with the columns of
    /// the grid values `grid`).
    pub(super) fn point<M: InverseModel + ?Sized>(
        &mut self,
        (model, grid): (&M, &GridColumns),
        (t, yd, w, i): At<'_>,
        eta: &[f64],
    ) -> Result<Point, SimulateError> {
        let info = model.info();
        let r = info.relative_degree;
        let mut ydk = [0.0_f64; MAX_DERIVATIVES];
        for (v, c) in ydk[..=r].iter_mut().zip(yd) {
            *v = c[i];
        }
        self.w.clear();
        self.w.extend(w.iter().map(|c| c[i]));
        let model_err = |source| SimulateError::from(RunError::Model { t, source });
        let u = model
            .invert_from(&ydk[..r], eta, &self.w, ydk[r], &mut self.x, self.u_prev)
            .map_err(model_err)?;
        self.u_prev = u;
        let buf = std::mem::take(&mut self.buf);
        let with = (&info.eta_states[..], grid);
        Point::new(model, (&self.x, &self.w, u), with, buf).map_err(model_err)
    }

    /// The partials at a sample the run has solved: state `x`, input `u` and signals `w` at t (they become the
    /// last sample's).
    pub(super) fn point_of<M: InverseModel + ?Sized>(
        &mut self,
        (model, grid): (&M, &GridColumns),
        (t, w): (f64, &[f64]),
        (x, u): (&[f64], f64),
    ) -> Result<Point, SimulateError> {
        self.x.copy_from_slice(x);
        self.u_prev = u;
        let buf = std::mem::take(&mut self.buf);
        let with = (&model.info().eta_states[..], grid);
        Point::new(model, (x, w, u), with, buf)
            .map_err(|source| SimulateError::from(RunError::Model { t, source }))
    }

    /// The trapezoids' terms of every accumulated output and wanted parameter at `point`, whose internal
    /// states move with the parameters `params` (indices of the model's) as `s` says (ne × P, column-major, column c = ∂η/∂p_c):
    /// do_a/dp_c = ∂o_a/∂p_c + Σ_j ∂o_a/∂η_j S_jc ([`Point::row_jacobians`]), then [`Samples::add`].
    pub(super) fn add_outputs(
        &mut self,
        point: &Point,
        (params, accumulate): (&[usize], &[usize]),
        s: &[f64],
        half: Option<f64>,
    ) {
        let l = point.layout();
        let (na, ne) = (accumulate.len(), l.n_eta);
        self.rows.clear();
        self.rows.extend(accumulate.iter().map(|&o| l.output(o)));
        self.o_eta.resize(na * ne, 0.0);
        point.row_jacobians(&self.rows, params, &mut self.o_eta, &mut self.o_p);
        let (o_eta, o_p) = (
            std::mem::take(&mut self.o_eta),
            std::mem::take(&mut self.o_p),
        );
        for (c, o_p) in o_p.chunks_exact(na).enumerate() {
            let column = &s[c * ne..(c + 1) * ne];
            for (a, o_p) in o_p.iter().enumerate() {
                let through_eta: f64 = column
                    .iter()
                    .enumerate()
                    .map(|(j, v)| o_eta[j * na + a] * v)
                    .sum();
                self.sums
                    .term(a * self.sums.params + c, o_p + through_eta, half);
            }
        }
        (self.o_eta, self.o_p) = (o_eta, o_p);
    }

    /// The point's buffer back, for the next sample's.
    pub(super) fn recycle(&mut self, point: Point) {
        self.buf = point.into_buffer();
    }
}

/// The trapezoidal sums ∫ do_a/dp_c dt ≈ Σ_k (dt/2)·(d_(k−1) + d_k) of every accumulated output a and
/// parameter c, pair i = a·P + c, fed a sample ([`Sums::term`]) or a column of samples ([`Sums::column`]) at a
/// time.
pub(super) struct Sums {
    acc: Vec<f64>,
    /// Each pair's derivative at the last sample.
    prev: Vec<f64>,
    outputs: usize,
    /// P, the parameters' count.
    pub(super) params: usize,
}

impl Sums {
    pub(super) fn new(outputs: usize, params: usize) -> Sums {
        Sums {
            acc: vec![0.0; outputs * params],
            prev: vec![0.0; outputs * params],
            outputs,
            params,
        }
    }

    /// Pair i's derivative `v` at this sample: the term `half`·(d at the last sample + v) added (`half` = dt/2;
    /// `None` at the first sample, which has no interval before it).
    pub(super) fn term(&mut self, i: usize, v: f64, half: Option<f64>) {
        if let Some(h) = half {
            self.acc[i] += h * (self.prev[i] + v);
        }
        self.prev[i] = v;
    }

    /// Pair i's derivative at consecutive samples `d`: their terms summed in four interleaved partial sums
    /// (independent additions that vectorise, not one chain), times `half` = dt/2; `opens`: d's first sample
    /// is the first (no term pairs it with an earlier one).
    pub(super) fn column(&mut self, i: usize, d: &[f64], (half, opens): (f64, bool)) {
        let (Some(&first), Some(&last)) = (d.first(), d.last()) else {
            return;
        };
        let mut sum = if opens { 0.0 } else { self.prev[i] + first };
        let mut parts = [0.0; 4];
        let (a, b) = (&d[..d.len() - 1], &d[1..]);
        let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
        let (ra, rb) = (ca.remainder(), cb.remainder());
        for (a, b) in ca.zip(cb) {
            for q in 0..4 {
                parts[q] += a[q] + b[q];
            }
        }
        for (a, b) in ra.iter().zip(rb) {
            sum += a + b;
        }
        sum += (parts[0] + parts[1]) + (parts[2] + parts[3]);
        self.acc[i] += half * sum;
        self.prev[i] = last;
    }

    /// ∫ do_a/dp_c dt, `[a][c]`.
    pub(super) fn integrals(&self) -> Vec<Vec<f64>> {
        (0..self.outputs)
            .map(|a| self.acc[a * self.params..(a + 1) * self.params].to_vec())
            .collect()
    }
}

/// The reference's columns over one block of grid samples (y_d … y_d^(r) and the signals), evaluated as the
/// run evaluates them, so that a pass stores no column of the whole run.
pub(super) struct Block {
    pub(super) time: Vec<f64>,
    pub(super) yd: Vec<Vec<f64>>,
    pub(super) w: Vec<Vec<f64>>,
}

impl Block {
    /// Room for `width` samples of r + 1 derivatives and `nw` signal columns.
    pub(super) fn new(width: usize, r: usize, nw: usize) -> Block {
        Block {
            time: vec![0.0; width],
            yd: vec![vec![0.0; width]; r + 1],
            w: vec![vec![0.0; width]; nw],
        }
    }

    /// Samples k0 … k0 + len − 1 of `grid`, into columns 0 … len − 1.
    pub(super) fn fill(&mut self, smoother: &Smoother, grid: &Grid, (k0, len): (usize, usize)) {
        for (i, t) in self.time[..len].iter_mut().enumerate() {
            *t = grid.time(k0 + i);
        }
        let time = &self.time[..len];
        let mut cols: Vec<&mut [f64]> = self.yd.iter_mut().map(|c| &mut c[..len]).collect();
        smoother.eval_grid(time, Some(grid.dt), &mut cols);
        let mut cols: Vec<&mut [f64]> = self.w.iter_mut().map(|c| &mut c[..len]).collect();
        smoother.eval_signals_grid(time, Some(grid.dt), &mut cols);
    }

    /// Column i as a sample's reference.
    pub(super) fn at(&self, i: usize) -> At<'_> {
        (self.time[i], &self.yd, &self.w, i)
    }
}
