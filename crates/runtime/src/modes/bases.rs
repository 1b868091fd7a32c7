//! The smoothed cycle y_c^(0 … m) at the run's samples, evaluated on the grid block by block with
//! [`Smoother::eval_grid`] (corner by corner, the kernel terms from the grid's table: the same values as a
//! pointwise [`Smoother::eval`] to rounding, at a fraction of its cost), each block once when first needed,
//! kept in a [`SampleTable`] that every run on the same reference reads (a sweep's runs on one cycle).

use std::sync::{Arc, OnceLock};

use crate::grid::Grid;
use crate::smoother::Smoother;

/// Samples per block: enough to spread the per-block set-up, small enough to stay in cache.
const BLOCK: usize = 512;

/// The smoothed cycle at a grid's samples, block by block: block b holds samples b·BLOCK … (b + 1)·BLOCK − 1,
/// `[i·orders + j]` = y_c^(j) at its sample i (a sample's orders side by side: one short copy per sample).
/// The blocks lie at fixed places on the grid, so a value is the same bits whichever run computed it.
pub(crate) struct SampleTable {
    grid: Grid,
    orders: usize,
    /// Each block's values as evaluated (an `Arc` of their `Vec`: no second allocation and copy).
    blocks: Vec<OnceLock<Arc<Vec<f64>>>>,
}

impl SampleTable {
    /// The table of y_c^(0 … orders − 1) on `grid` (nothing evaluated yet).
    pub(crate) fn new(grid: &Grid, orders: usize) -> SampleTable {
        SampleTable {
            grid: *grid,
            orders,
            blocks: (0..grid.samples().div_ceil(BLOCK))
                .map(|_| OnceLock::new())
                .collect(),
        }
    }

    /// The orders held (y_c^(0 … orders − 1)).
    pub(crate) fn orders(&self) -> usize {
        self.orders
    }

    fn block(&self, smoother: &Smoother, b: usize) -> Arc<Vec<f64>> {
        self.blocks[b]
            .get_or_init(|| self.evaluate(smoother, b))
            .clone()
    }

    /// Evaluate block b.
    fn evaluate(&self, smoother: &Smoother, b: usize) -> Arc<Vec<f64>> {
        let first = b * BLOCK;
        let end = (first + BLOCK).min(self.grid.samples());
        let times: Vec<f64> = (first..end).map(|i| self.grid.time(i)).collect();
        let mut columns = vec![0.0; times.len() * self.orders];
        let mut cols: Vec<&mut [f64]> = columns.chunks_exact_mut(times.len()).collect();
        smoother.eval_grid(&times, Some(self.grid.dt), &mut cols);
        let mut values = vec![0.0; columns.len()];
        for (j, column) in columns.chunks_exact(times.len()).enumerate() {
            for (i, &v) in column.iter().enumerate() {
                values[i * self.orders + j] = v;
            }
        }
        Arc::new(values)
    }
}

/// A run's reader of a [`SampleTable`], with the block in hand.
pub(super) struct Bases<'a> {
    table: &'a SampleTable,
    /// Index of the block in hand (`usize::MAX`: none) and its values.
    block: (usize, Arc<Vec<f64>>),
}

impl<'a> Bases<'a> {
    pub(super) fn new(table: &'a SampleTable) -> Bases<'a> {
        Bases {
            table,
            block: (usize::MAX, Arc::new(Vec::new())),
        }
    }

    /// y_c^(0 … orders − 1) at sample k into `base` (its length the number of orders).
    pub(super) fn at(&mut self, smoother: &Smoother, k: usize, base: &mut [f64]) {
        let b = k / BLOCK;
        if self.block.0 != b {
            self.block = (b, self.table.block(smoother, b));
        }
        let orders = self.table.orders;
        let i = k - b * BLOCK;
        base.copy_from_slice(&self.block.1[i * orders..(i + 1) * orders]);
    }
}
