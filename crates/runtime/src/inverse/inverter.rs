//! The three ways to obtain the input and the state along the reference, behind one type: r = n (every sample
//! independent), causal (η integrated forward, [`super::causal`]) and stable (η from the bounded solution of
//! [`crate::stable`], then every sample independent again).

use invsim_model_api::InverseModel;

use super::causal::Causal;
use super::error::SimulateError;
use super::options::SimulationOptions;
use crate::error::RunError;
use crate::grid::{Grid, MAX_DERIVATIVES};
use crate::smoother::Smoother;
use crate::stable::{StableRun, ZeroDynamicsPlan};

/// A block of samples of the result's columns: the times, y_d … y_d^(r) (read only: the result's columns or a
/// shared reference's), the input, the states, η and the extra outputs.
pub(super) struct Block<'c, 'd> {
    /// Index of the block's first sample on the grid.
    pub k0: usize,
    pub time: &'c [f64],
    pub yd: &'c [&'c [f64]],
    /// The smoothed signals' columns S, S_d1, …, S_dr per signal (`InverseModel`'s `w`, column-wise).
    pub w: &'c [&'c [f64]],
    pub u: &'c mut [f64],
    pub x: &'c mut [&'d mut [f64]],
    pub eta: &'c mut [&'d mut [f64]],
    pub out: &'c mut [&'d mut [f64]],
}

/// How η is obtained.
enum Strategy<'a> {
    /// r = n: there is no η.
    Direct,
    /// η integrated forward.
    Causal(Box<Causal>),
    /// η from the stable inversion's solution.
    Stable(&'a StableRun),
}

/// Fills blocks with the inverse: x = ψ⁻¹(ξ, η) and u = (y_d^(r) − α)/β at every sample.
pub(super) struct Inverter<'a, M: ?Sized> {
    model: &'a M,
    smoother: &'a Smoother,
    grid: Grid,
    strategy: Strategy<'a>,
    /// The last sample's state: the guess for a numerically solved ψ⁻¹.
    x: Vec<f64>,
    /// The last sample's input: Newton's start for a non-affine y^(r) (NaN before the first sample).
    u: f64,
    eta: Vec<f64>,
}

impl<'a, M: InverseModel + ?Sized> Inverter<'a, M> {
    /// The integrals' derivatives a causal run summed as it went (where it is differentiated).
    pub(super) fn gradient_integrals(&self) -> Option<Vec<Vec<f64>>> {
        match &self.strategy {
            Strategy::Causal(c) => c.gradient_integrals(),
            _ => None,
        }
    }

    /// The inverter for the zero-dynamics plan `zd`; a causal run starts here (from `eta0` or the equilibrium),
    /// carrying the sensitivities by `wrt` along where they are asked for.
    pub(super) fn new(
        model: &'a M,
        (smoother, grid): (&'a Smoother, Grid),
        zd: &'a ZeroDynamicsPlan,
        (eta0, wrt): (Option<Vec<f64>>, Option<&crate::gradient::Derivatives>),
        opts: &SimulationOptions,
    ) -> Result<Self, SimulateError> {
        let info = model.info();
        let strategy = match &zd.stable {
            Some(st) => Strategy::Stable(st),
            None if info.n_eta == 0 => Strategy::Direct,
            None => {
                let causal = Causal::start(model, (smoother, &grid), eta0, wrt, opts)?;
                Strategy::Causal(Box::new(causal))
            }
        };
        Ok(Inverter {
            model,
            smoother,
            grid,
            strategy,
            x: vec![0.0; info.n_states()],
            u: f64::NAN,
            eta: vec![0.0; info.n_eta],
        })
    }

    /// Fill `b`'s input, states and η from its y_d columns.
    pub(super) fn fill(&mut self, b: &mut Block<'_, '_>) -> Result<(), SimulateError> {
        match &mut self.strategy {
            Strategy::Direct => self.batch(b),
            Strategy::Stable(st) => {
                // η from the bounded (stable) solution of the zero dynamics between its collocation nodes.
                for (i, &t) in b.time.iter().enumerate() {
                    st.solution.eval(t, &mut self.eta);
                    for (c, &v) in b.eta.iter_mut().zip(&self.eta) {
                        c[i] = v;
                    }
                }
                self.batch(b)
            }
            Strategy::Causal(c) => {
                let (model, smoother, grid) = (self.model, self.smoother, &self.grid);
                sample_by_sample(model, smoother, grid, c, &mut self.x, b)
            }
        }
    }

    /// Every sample independent: [`InverseModel::invert_batch`] on the whole block.
    fn batch(&mut self, b: &mut Block<'_, '_>) -> Result<(), SimulateError> {
        let r = b.yd.len() - 1;
        let xi: Vec<&[f64]> = b.yd[..r].iter().map(|c| &**c).collect();
        let etas: Vec<&[f64]> = b.eta.iter().map(|c| &**c).collect();
        let time = b.time;
        let last = (&mut self.x[..], &mut self.u);
        invert_chained(self.model, (&xi, &etas, b.w, b.yd[r]), (b.x, b.u), last)
            .map_err(|(i, source)| RunError::Model { t: time[i], source }.into())
    }
}

/// A block's columns for [`InverseModel::invert_batch`]: ξ, η, the signals and y^(r).
type InverseColumns<'a> = (&'a [&'a [f64]], &'a [&'a [f64]], &'a [&'a [f64]], &'a [f64]);

/// [`InverseModel::invert_batch`] on a block whose first sample starts from `last` (the previous block's last
/// state and input: the guesses of a numerically solved ψ⁻¹ and of an input solved by Newton's method), then
/// `last` set to this block's last sample: blocks chained as one run.
fn invert_chained<M: InverseModel + ?Sized>(
    model: &M,
    (xi, eta, w, yr): InverseColumns<'_>,
    (x, u): (&mut [&mut [f64]], &mut [f64]),
    (x_last, u_last): (&mut [f64], &mut f64),
) -> Result<(), (usize, invsim_model_api::ModelError)> {
    for (c, &v) in x.iter_mut().zip(x_last.iter()) {
        c[0] = v;
    }
    if let Some(u0) = u.first_mut() {
        *u0 = *u_last;
    }
    model.invert_batch(xi, eta, w, yr, x, u)?;
    let len = u.len();
    for (v, c) in x_last.iter_mut().zip(x.iter()) {
        *v = c[len - 1];
    }
    *u_last = u[len - 1];
    Ok(())
}

/// The causal run over a block: η integrated from sample to sample, then the inverse at each.
fn sample_by_sample<M: InverseModel + ?Sized>(
    model: &M,
    smoother: &Smoother,
    grid: &Grid,
    causal: &mut Causal,
    x: &mut [f64],
    b: &mut Block<'_, '_>,
) -> Result<(), SimulateError> {
    let r = b.yd.len() - 1;
    let mut yd = [0.0_f64; MAX_DERIVATIVES];
    for i in 0..b.time.len() {
        let (k, t) = (b.k0 + i, b.time[i]);
        for (o, c) in yd[..=r].iter_mut().zip(b.yd.iter()) {
            *o = c[i];
        }
        let eta = causal.advance(model, smoother, grid, (k, t), &yd[..=r])?;
        for (c, &v) in b.eta.iter_mut().zip(eta) {
            c[i] = v;
        }
        b.u[i] = causal.invert(model, t, &yd[..=r], x)?;
        for (c, &v) in b.x.iter_mut().zip(x.iter()) {
            c[i] = v;
        }
    }
    Ok(())
}
