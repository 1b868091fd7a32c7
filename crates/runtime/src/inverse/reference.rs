//! A smoothed reference computed once and shared by many inverse runs of the same cycle (parameter sweeps):
//! the [`Smoother`], y_d … y_d^(r) on the cycle's grid t_k = t_0 + k·dt, and the model's signals (resolved
//! from their sources once, smoothed, and S^(k) on the same grid): a model parameter moves none of them.

use invsim_model_api::ReferenceMap;

use crate::grid::Grid;
use crate::signals::{ResolvedSignal, SignalInput};
use crate::smoother::Smoother;

/// A shared reference's samples on the run's grid: y_d^(k) columns and S_i^(k) columns.
pub(super) type SharedColumns<'a> = (&'a [Vec<f64>], &'a [Vec<f64>]);

/// The smoothed reference of one cycle on one grid, for models of one relative degree and one reference map
/// (built by [`super::reference`], used by [`super::simulate_shared`]).
///
/// The samples are those a run computes itself (the same smoother, evaluated over the same blocks of the
/// grid), so a run on a shared reference gives bit for bit the numbers of [`super::simulate`].
#[derive(Debug)]
pub struct Reference {
    pub(super) smoother: Smoother,
    /// The warning when the smoothed reference's distance leaves the cycle's (computed once, as a run does).
    pub(super) distance_warning: Option<String>,
    pub(super) cycle: String,
    pub(super) lookahead: f64,
    pub(super) grid: Grid,
    /// y_d^(k)(t_j) in `yd[k][j]`, k = 0 … r, j = 0 … n.
    pub(super) yd: Vec<Vec<f64>>,
    /// The model's signals as resolved for this cycle, the names they were resolved for, and the sources
    /// given (`--signal`) they came from.
    pub(super) signals: Vec<ResolvedSignal>,
    pub(super) signal_names: Vec<String>,
    pub(super) signal_inputs: Vec<SignalInput>,
    /// S_i^(k)(t_j) in `w[i·(r+1) + k][j]` (the layout of the models' `w`).
    pub(super) w: Vec<Vec<f64>>,
}

impl Reference {
    /// The relative degree r the reference was computed for (it holds y_d … y_d^(r)).
    pub fn relative_degree(&self) -> usize {
        self.yd.len() - 1
    }
    /// The reference map y_d = offset + scale · (smoothed cycle) it applies.
    pub fn map(&self) -> ReferenceMap {
        self.smoother.reference()
    }
    /// The cycle's name.
    pub fn cycle(&self) -> &str {
        &self.cycle
    }
    /// Number of grid samples, n + 1.
    pub fn samples(&self) -> usize {
        self.grid.samples()
    }
    /// y_d^(k) on the grid, k = 0 … r.
    pub fn yd(&self, k: usize) -> Option<&[f64]> {
        self.yd.get(k).map(|c| c.as_slice())
    }
    /// The smoother.
    pub fn smoother(&self) -> &Smoother {
        &self.smoother
    }

    /// Whether a run with these numbers can use the reference: same look-ahead, dt, relative degree and map.
    pub(super) fn fits(&self, lookahead: f64, dt: f64, r: usize, map: ReferenceMap) -> bool {
        self.lookahead == lookahead
            && self.grid.dt == dt
            && self.relative_degree() == r
            && self.map() == map
    }

    /// Whether a run of a model with these signals and these given sources can use the reference's signals.
    pub(super) fn signals_fit(&self, names: &[String], given: &[SignalInput]) -> bool {
        self.signal_names == names && self.signal_inputs == given
    }

    /// The shared samples, y_d^(k) and S_i^(k), when the run's grid is the reference's (no pre- or
    /// post-actuation).
    pub(super) fn columns_for(&self, grid: &Grid) -> Option<SharedColumns<'_>> {
        let same = grid.k0 == 0 && grid.n == self.grid.n && grid.t0 == self.grid.t0;
        same.then_some((self.yd.as_slice(), self.w.as_slice()))
    }
}
