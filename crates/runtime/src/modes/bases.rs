//! The smoothed cycle y_c^(0 … m) at the run's samples, evaluated on the grid block by block with
//! [`Smoother::eval_grid`] (corner by corner, the kernel terms from the grid's table: the same values as a
//! pointwise [`Smoother::eval`] to rounding, at a fraction of its cost), and read sample by sample.

use crate::grid::Grid;
use crate::smoother::Smoother;

/// Samples per block: enough to spread the per-block set-up, small enough to stay in cache.
const BLOCK: usize = 512;

/// The smoothed cycle on the samples of the block in hand.
pub(super) struct Bases {
    /// Index of the block's first sample.
    start: usize,
    /// Samples in the block (0 before the first).
    len: usize,
    times: Vec<f64>,
    /// `cols[j][i]` = y_c^(j)(t_{start + i}).
    cols: Vec<Vec<f64>>,
}

impl Bases {
    /// Room for y_c^(0 … orders − 1).
    pub(super) fn new(orders: usize) -> Bases {
        Bases {
            start: 0,
            len: 0,
            times: Vec::with_capacity(BLOCK),
            cols: vec![vec![0.0; BLOCK]; orders],
        }
    }

    /// y_c^(0 … orders − 1) at sample k of `grid` into `base` (its length the number of orders).
    pub(super) fn at(&mut self, smoother: &Smoother, grid: &Grid, k: usize, base: &mut [f64]) {
        if !(self.start..self.start + self.len).contains(&k) {
            self.fill(smoother, grid, k);
        }
        let i = k - self.start;
        for (b, col) in base.iter_mut().zip(&self.cols) {
            *b = col[i];
        }
    }

    /// Evaluate the block that starts at sample k.
    fn fill(&mut self, smoother: &Smoother, grid: &Grid, k: usize) {
        let end = (k + BLOCK).min(grid.samples());
        self.times.clear();
        self.times.extend((k..end).map(|i| grid.time(i)));
        let mut cols: Vec<&mut [f64]> = self.cols.iter_mut().map(|c| &mut c[..]).collect();
        smoother.eval_grid(&self.times, Some(grid.dt), &mut cols);
        (self.start, self.len) = (k, end - k);
    }
}
