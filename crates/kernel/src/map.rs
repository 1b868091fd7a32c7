//! Smooth lookup maps (contract §6): the convolution of a 1-D or 2-D (bi)linear interpolant with the bump
//! kernel, and all its partial derivatives, exact and in one pass.
//!
//! # Definition
//!
//! A map has a grid per argument (strictly increasing, at least two points), values at the grid points and an
//! extrapolation rule. `L` is the (bi)linear interpolant, continued outside the grid by its end segments
//! (`linear`, `error`) or by the edge values (`clamp`); in 2-D the continuation is the tensor product of the
//! two axes' continuations (corner regions included). The smooth map is
//!
//! ```text
//! M(a)    = ∫ k_h(s) L(a − s) ds,                      h = smooth · min_j (x_{j+1} − x_j),
//! M(a, b) = ∫∫ k_hx(s) k_hy(σ) L(a − s, b − σ) ds dσ,   (product kernel, one half-width per axis)
//! ```
//!
//! with `k_h` the drive-cycle kernel of half-width `h`. `L(a, b) = Σ_ij v_ij φ_i(a) ψ_j(b)` is a tensor
//! product of hat functions, so `M(a, b) = Σ_ij v_ij Φ_i(a) Ψ_j(b)` with `Φ_i = k_hx * φ_i`, `Ψ_j = k_hy * ψ_j`
//! and `∂^(p+q) M / ∂a^p ∂b^q = Σ_ij v_ij Φ_i^(p)(a) Ψ_j^(q)(b)`. Each smoothed basis function is closed-form
//! (see `axis`): a sum over the grid corners within the kernel window, like the drive-cycle smoother. Because
//! the kernel is even, `M = L` wherever `L` is (bi)linear on the window, in particular everywhere for
//! (bi)linear data under `linear` extrapolation.
//!
//! With [`Interp::Linear`] no kernel is applied: `M = L` (plain (bi)linear, first derivatives piecewise
//! constant, higher ones zero); the contract allows that only for maps used in outputs alone.

mod axis;
mod batch;
mod chunk;
mod contract;
mod extrapolate;
mod memo;
mod one;
mod small;
mod violation;
mod weights;

use axis::{Axis, Basis};
pub use extrapolate::Extrapolate;
pub use violation::{take_violation, Violation};

use crate::Kernel;

/// Smooth (kernel-convolved) or plain (bi)linear interpolation (contract §6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interp {
    /// The interpolant convolved with the kernel: C-infinity (the default).
    Smooth,
    /// Plain (bi)linear interpolation (only for maps used in outputs alone).
    Linear,
}

impl Interp {
    /// The name in model files: `smooth`, `linear`.
    pub fn name(self) -> &'static str {
        match self {
            Interp::Smooth => "smooth",
            Interp::Linear => "linear",
        }
    }

    /// The interpolation of a name in model files.
    pub fn from_name(name: &str) -> Option<Interp> {
        match name {
            "smooth" => Some(Interp::Smooth),
            "linear" => Some(Interp::Linear),
            _ => None,
        }
    }
}

/// The settings of a map besides its data (contract §6 defaults: 0.5, linear, smooth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSettings {
    /// Kernel half-width per axis as a multiple of the axis' smallest grid spacing (> 0).
    pub smooth: f64,
    pub extrapolate: Extrapolate,
    pub interp: Interp,
}

impl Default for MapSettings {
    fn default() -> Self {
        MapSettings {
            smooth: 0.5,
            extrapolate: Extrapolate::Linear,
            interp: Interp::Smooth,
        }
    }
}

/// A map's data that [`Map::new`] refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapError {
    #[error("the {axis} grid has {len} point(s); a map needs at least 2")]
    TooFewPoints { axis: &'static str, len: usize },
    #[error("the {axis} grid is not strictly increasing: entry {index} ({value}) does not exceed the one before ({previous})")]
    NotIncreasing {
        axis: &'static str,
        index: usize,
        value: f64,
        previous: f64,
    },
    #[error("the {axis} grid has a non-finite entry {index} ({value})")]
    NonFiniteGrid {
        axis: &'static str,
        index: usize,
        value: f64,
    },
    #[error("value {index} of the map is not finite ({value})")]
    NonFiniteValue { index: usize, value: f64 },
    #[error("the map has {got} values; its grid needs {expected}")]
    Shape { expected: usize, got: usize },
    #[error("smooth = {0} is not valid; expected a finite number > 0")]
    Smooth(f64),
    #[error("the map takes {expected} argument(s); the new data have {got}")]
    Arity { expected: usize, got: usize },
}

/// A 1-D or 2-D lookup map (see the module documentation). Equal maps have equal grids, values, settings
/// and names.
#[derive(Debug, Clone)]
pub struct Map {
    x: Axis,
    y: Option<Axis>,
    /// Row-major: `values[i · len(y) + j]` at `(x_i, y_j)`; 1-D: `values[i]`.
    values: Vec<f64>,
    settings: MapSettings,
    /// Scratch sizes per axis for one basis evaluation and one order.
    max_count: [usize; 2],
    /// Every axis is served by the fast path of `small.rs` (orders up to 2 per argument).
    small: bool,
    /// Every axis has the fixed-width basis of `batch.rs` ([`Map::partials2_batch`]'s fast path).
    batch: bool,
    /// The values padded with zeros for `batch.rs`.
    padded: Vec<f64>,
    /// The map's name in messages (see [`Map::named`]).
    name: std::sync::Arc<str>,
    /// Unique per data (clones share it): the key of the one-pass memo (`memo.rs`).
    id: u64,
}

impl PartialEq for Map {
    fn eq(&self, other: &Map) -> bool {
        (&self.x, &self.y, &self.values, &self.settings, &self.name)
            == (
                &other.x,
                &other.y,
                &other.values,
                &other.settings,
                &other.name,
            )
    }
}

/// A fresh id for new map data.
fn next_id() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// Scratch values on the stack per axis; larger windows (large `smooth` on uneven grids) use the heap.
const STACK_SCRATCH: usize = 48;

fn check_grid(axis: &'static str, grid: &[f64]) -> Result<(), MapError> {
    if grid.len() < 2 {
        return Err(MapError::TooFewPoints {
            axis,
            len: grid.len(),
        });
    }
    for (index, &value) in grid.iter().enumerate() {
        if !value.is_finite() {
            return Err(MapError::NonFiniteGrid { axis, index, value });
        }
        if index > 0 && value <= grid[index - 1] {
            return Err(MapError::NotIncreasing {
                axis,
                index,
                value,
                previous: grid[index - 1],
            });
        }
    }
    Ok(())
}

fn make_axis(axis: &'static str, grid: Vec<f64>, s: &MapSettings) -> Result<Axis, MapError> {
    check_grid(axis, &grid)?;
    let kernel = match s.interp {
        Interp::Linear => None,
        Interp::Smooth => {
            if !(s.smooth > 0.0 && s.smooth.is_finite()) {
                return Err(MapError::Smooth(s.smooth));
            }
            let spacing = grid
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(f64::INFINITY, f64::min);
            let h = s.smooth * spacing;
            if !(h > 0.0 && h.is_finite()) {
                return Err(MapError::Smooth(s.smooth));
            }
            Some(Kernel::new(h))
        }
    };
    Ok(Axis::new(grid, s.extrapolate, kernel))
}

fn check_values(values: &[f64], expected: usize) -> Result<(), MapError> {
    if values.len() != expected {
        return Err(MapError::Shape {
            expected,
            got: values.len(),
        });
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(MapError::NonFiniteValue {
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

impl Map {
    /// A 1-D map `M(a)` with `values[i]` at `x[i]`.
    pub fn new_1d(x: Vec<f64>, values: Vec<f64>, settings: MapSettings) -> Result<Map, MapError> {
        let x = make_axis("x", x, &settings)?;
        check_values(&values, x.len())?;
        Ok(Map {
            max_count: [x.max_count(), 0],
            small: x.is_small(),
            batch: batch::fits(&x, None),
            padded: batch::pad(&values, x.len(), None),
            x,
            y: None,
            values,
            settings,
            name: "map".into(),
            id: next_id(),
        })
    }

    /// A 2-D map `M(a, b)` with `values[i · y.len() + j]` at `(x[i], y[j])` (row-major, one row per `x`).
    pub fn new_2d(
        x: Vec<f64>,
        y: Vec<f64>,
        values: Vec<f64>,
        settings: MapSettings,
    ) -> Result<Map, MapError> {
        let x = make_axis("x", x, &settings)?;
        let y = make_axis("y", y, &settings)?;
        check_values(&values, x.len() * y.len())?;
        Ok(Map {
            max_count: [x.max_count(), y.max_count()],
            small: x.is_small() && y.is_small(),
            batch: batch::fits(&x, Some(&y)),
            padded: batch::pad(&values, x.len(), Some(y.len())),
            x,
            y: Some(y),
            values,
            settings,
            name: "map".into(),
            id: next_id(),
        })
    }

    /// The map with `name` for messages (a [`Violation`] names it).
    pub fn named(mut self, name: &str) -> Map {
        self.name = name.into();
        self
    }

    /// The map's name in messages.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The number of arguments: 1 or 2.
    pub fn arity(&self) -> usize {
        if self.y.is_some() {
            2
        } else {
            1
        }
    }

    /// The settings the map was built with.
    pub fn settings(&self) -> MapSettings {
        self.settings
    }

    /// The grid of the first argument.
    pub fn x(&self) -> &[f64] {
        &self.x.grid
    }

    /// The grid of the second argument (2-D maps).
    pub fn y(&self) -> Option<&[f64]> {
        self.y.as_ref().map(|a| a.grid.as_slice())
    }

    /// The values, row-major (see [`Map::new_2d`]).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// A map with the same name and settings on new data (`--map NAME=FILE.csv`); the arity must stay.
    pub fn with_data(
        &self,
        x: Vec<f64>,
        y: Option<Vec<f64>>,
        values: Vec<f64>,
    ) -> Result<Map, MapError> {
        let got = if y.is_some() { 2 } else { 1 };
        if got != self.arity() {
            return Err(MapError::Arity {
                expected: self.arity(),
                got,
            });
        }
        let map = match y {
            None => Map::new_1d(x, values, self.settings)?,
            Some(y) => Map::new_2d(x, y, values, self.settings)?,
        };
        Ok(map.named(&self.name))
    }

    /// Replaces the values (same grid).
    pub fn set_values(&mut self, values: Vec<f64>) -> Result<(), MapError> {
        check_values(&values, self.values.len())?;
        self.padded = batch::pad(&values, self.x.len(), self.y.as_ref().map(Axis::len));
        self.values = values;
        self.id = next_id();
        Ok(())
    }

    /// Under `extrapolate = "error"`: the index of the first argument outside `[first, last]` of its grid
    /// (NaN counts as outside), `None` if all are inside or the rule is another.
    pub fn outside(&self, args: &[f64]) -> Option<usize> {
        if self.settings.extrapolate != Extrapolate::Error {
            return None;
        }
        let axes = [Some(&self.x), self.y.as_ref()];
        args.iter().zip(axes).position(|(&a, axis)| {
            axis.is_some_and(|ax| !(a >= ax.grid[0] && a <= ax.grid[ax.grid.len() - 1]))
        })
    }

    /// Under `extrapolate = "error"`: records an argument outside the grid as this thread's [`Violation`].
    #[inline]
    fn check_range(&self, args: &[f64]) {
        if self.settings.extrapolate == Extrapolate::Error {
            if let Some(k) = self.outside(args) {
                let grid = if k == 0 {
                    self.x()
                } else {
                    self.y().unwrap_or(self.x())
                };
                violation::record(&self.name, k, args[k], (grid[0], grid[grid.len() - 1]));
            }
        }
    }

    /// Value and partial derivatives in one pass. 1-D: `out[n] = M^(n)(a)` for `n = 0 … out.len() − 1`
    /// (`orders` is ignored). 2-D: `out[p · (orders[1] + 1) + q] = ∂^(p+q) M / ∂a^p ∂b^q` for
    /// `p ≤ orders[0]`, `q ≤ orders[1]`; `out` must hold `(orders[0] + 1)(orders[1] + 1)` values.
    /// A NaN argument gives NaN everywhere.
    ///
    /// Under `extrapolate = "error"` an argument outside the grid is recorded as this thread's
    /// [`Violation`] (see [`take_violation`]); the value is still the linear continuation.
    pub fn eval(&self, args: &[f64], orders: [usize; 2], out: &mut [f64]) {
        self.check_range(args);
        self.eval_unchecked(args, orders, out);
    }

    /// [`Map::eval`] without the range check.
    fn eval_unchecked(&self, args: &[f64], orders: [usize; 2], out: &mut [f64]) {
        if args.iter().take(self.arity()).any(|a| a.is_nan()) {
            out.fill(f64::NAN);
            return;
        }
        match &self.y {
            None if self.small && out.len() <= 3 => self.eval_1d_small(args[0], out),
            None => self.eval_1d(args[0], out),
            Some(y) if self.small && orders[0] <= 2 && orders[1] <= 2 => {
                let r = small::contract(
                    &self.values,
                    y.len(),
                    &self.x.small_basis(args[0]),
                    &y.small_basis(args[1]),
                );
                let oy = orders[1] + 1;
                for (p, row) in r.iter().enumerate().take(orders[0] + 1) {
                    for (q, &v) in row.iter().enumerate().take(oy) {
                        out[p * oy + q] = v;
                    }
                }
            }
            Some(y) => self.eval_2d(y, args, orders, out),
        }
    }

    /// `eval_1d_small`'s entry `order` (≤ 2) alone: the same sum in the same order.
    fn eval_1d_small_one(&self, a: f64, order: usize) -> f64 {
        let b = self.x.small_basis(a);
        let mut sum = 0.0;
        for (k, row) in b.values.iter().enumerate().take(b.count) {
            sum += self.values[b.first + k] * row[order];
        }
        sum
    }

    fn eval_1d_small(&self, a: f64, out: &mut [f64]) {
        let b = self.x.small_basis(a);
        // Summed in a fixed-size array (a `fill` of the short output would be a call to memset).
        let mut sum = [0.0; 3];
        for (k, row) in b.values.iter().enumerate().take(b.count) {
            let v = self.values[b.first + k];
            for (o, &phi) in sum.iter_mut().zip(row) {
                *o += v * phi;
            }
        }
        for (o, &s) in out.iter_mut().zip(&sum) {
            *o = s;
        }
    }

    /// The value and every partial derivative up to order 2 per argument at `args`, in one pass:
    /// `out[p · 3 + q] = ∂^(p+q) M / ∂a^p ∂b^q` (1-D: `out[p] = M^(p)(a)`, the rest 0). Generated code reads
    /// every map call of a function at the same arguments from one such array.
    ///
    /// Under `extrapolate = "error"` an argument outside the grid is recorded as for [`Map::eval`].
    ///
    /// Shares the per-thread memo of [`Map::partial`] (a single call at the same point is then a look-up).
    pub fn partials2(&self, args: &[f64]) -> [f64; 9] {
        self.check_range(args);
        let b = if self.y.is_some() { args[1] } else { 0.0 };
        memo::entry(self.id, [args[0], b], |out| self.partials2_into(args, out))
    }

    /// The numbers of [`Map::partials2`] into `out`, without range check or memo: a 2-D map that
    /// [`batch::fits`] at finite arguments by the fixed-width path of one point ([`one::partials2_one`],
    /// fixed-size loops; the same bits as [`Map::eval`], whose basis leaves out the terms that are exact
    /// zeros there), every other case by [`Map::eval`].
    #[inline]
    fn partials2_into(&self, args: &[f64], out: &mut [f64; 9]) {
        match &self.y {
            None => self.eval_unchecked(&args[..1], [2, 0], &mut out[..3]),
            Some(y) if self.batch && args[0].is_finite() && args[1].is_finite() => {
                *out = one::partials2_one(&self.x, y, &self.padded, args[0], args[1]);
            }
            Some(_) => self.eval_unchecked(args, [2, 2], out),
        }
    }

    /// [`Map::partials2`] without the per-thread memo: evaluated afresh, neither looked up nor stored. The same
    /// numbers (a memo hit is what a fresh evaluation gives); for callers whose points are new on every call
    /// (Newton's iterates), where the memo's look-up and store are pure overhead.
    ///
    /// Under `extrapolate = "error"` an argument outside the grid is recorded as for [`Map::eval`].
    pub fn partials2_fresh(&self, args: &[f64]) -> [f64; 9] {
        self.check_range(args);
        let mut out = [0.0; 9];
        self.partials2_into(args, &mut out);
        out
    }

    /// [`Map::partials2`] at `n = a.len()` points at once, as structure of arrays: `out[k · n + i]` is entry
    /// `k` of `partials2(&[a[i], b[i]])` for `k < 9` (2-D), or of `partials2(&[a[i]])` for `k < 3` (1-D:
    /// `M, M', M''`; `b` is not read and may be empty). The same numbers as point by point.
    ///
    /// Maps whose windows hold at most one corner per axis (`smooth ≤ 0.5`, the default, and
    /// `interp = "linear"`) take a fixed-width, branch-free path over chunks of points (see `batch.rs`),
    /// compiled for AVX2 where the processor has it; others are evaluated point by point. No memo.
    ///
    /// Under `extrapolate = "error"` the first point with an argument outside the grid is recorded as for
    /// [`Map::eval`].
    ///
    /// # Panics
    ///
    /// If `out` holds fewer than `9n` (1-D: `3n`) values, or a 2-D map's `b` fewer than `n`.
    pub fn partials2_batch(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        self.batch(a, b, out, false);
    }

    /// The value alone of [`Map::partials2_batch`]: `out[i]` is entry 0 of `partials2(&[a[i], b[i]])`
    /// (1-D: of `partials2(&[a[i]])`, `b` not read), the same number, without the partial derivatives
    /// (for callers that read only the value, such as outputs).
    ///
    /// # Panics
    ///
    /// If `out` holds fewer than `n = a.len()` values, or a 2-D map's `b` fewer than `n`.
    pub fn values_batch(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        self.batch(a, b, out, true);
    }

    /// [`Map::partials2_batch`], or its values alone.
    fn batch(&self, a: &[f64], b: &[f64], out: &mut [f64], value: bool) {
        let n = a.len();
        let two_d = self.y.is_some();
        let width = match (value, two_d) {
            (true, _) => 1,
            (false, true) => 9,
            (false, false) => 3,
        };
        assert!(out.len() >= width * n, "map batch: `out` is too short");
        assert!(!two_d || b.len() >= n, "map batch: `b` is too short");
        let b = if two_d { &b[..n] } else { &[][..] };
        let args = |i: usize| [a[i], b.get(i).copied().unwrap_or(0.0)];
        if self.settings.extrapolate == Extrapolate::Error {
            if let Some(i) = (0..n).find(|&i| self.outside(&args(i)).is_some()) {
                self.check_range(&args(i));
            }
        }
        if !self.batch {
            // Point by point; the values alone by `eval`'s order 0 (the value does not depend on the orders
            // asked for, as the memo relies on).
            let mut one = [0.0; 9];
            let full = if value {
                1
            } else if two_d {
                9
            } else {
                3
            };
            for i in 0..n {
                let orders = match (value, two_d) {
                    (true, _) => [0, 0],
                    (false, true) => [2, 2],
                    (false, false) => [2, 0],
                };
                self.eval_unchecked(&args(i)[..self.arity()], orders, &mut one[..full]);
                for (k, &v) in one[..width].iter().enumerate() {
                    out[k * n + i] = v;
                }
            }
            return;
        }
        let data = batch::Data {
            x: &self.x,
            y: self.y.as_ref(),
            padded: &self.padded,
        };
        batch::dispatch(data, a, b, out, value);
        // NaN arguments give NaN everywhere (as `eval`); the fixed-width path does not look at them.
        let any_nan = a.iter().chain(b).fold(false, |any, v| any | v.is_nan());
        for i in (0..n).filter(|_| any_nan) {
            if a[i].is_nan() || b.get(i).is_some_and(|v| v.is_nan()) {
                for k in 0..width {
                    out[k * n + i] = f64::NAN;
                }
            }
        }
    }

    /// One partial derivative: `orders[k]` times with respect to argument `k` (`orders[1]` ignored in 1-D).
    ///
    /// Orders up to 2 per argument come from one evaluation of all of them per point (a per-thread memo of
    /// the last few points), so `M`, `M_d10`, `M_d01`, `M_d11`, … at the same arguments cost one pass.
    pub fn partial(&self, args: &[f64], orders: [usize; 2]) -> f64 {
        self.check_range(args);
        let two_d = self.y.is_some();
        if orders[0] <= memo::MEMO_ORDER && (!two_d || orders[1] <= memo::MEMO_ORDER) {
            let b = if two_d { args[1] } else { 0.0 };
            let o = [orders[0], if two_d { orders[1] } else { 0 }];
            if !two_d {
                // 1-D: the memo's first row holds M, M' (and M'').
                return memo::partial(self.id, [args[0], b], [0, o[0]], self.small, |cap, out| {
                    self.eval(&args[..1], [cap, 0], &mut out[..cap + 1])
                });
            }
            return memo::partial(self.id, [args[0], b], o, self.small, |cap, out| {
                let w = cap + 1;
                let mut dense = [0.0; memo::WIDTH];
                self.eval(args, [cap, cap], &mut dense[..w * w]);
                // Rows of `cap + 1` entries into the memo's rows of MEMO_ORDER + 1.
                for p in 0..w {
                    out[p * (memo::MEMO_ORDER + 1)..][..w].copy_from_slice(&dense[p * w..][..w]);
                }
            });
        }
        self.fresh(args, orders)
    }

    /// [`Map::partial`] without the memo: for batch evaluation (a tape instruction runs over a column of
    /// points, each new, where the memo would only add its bookkeeping). The same numbers.
    #[inline]
    pub fn partial_unmemoized(&self, args: &[f64], orders: [usize; 2]) -> f64 {
        self.check_range(args);
        if self.y.is_none() && self.small && orders[0] <= 2 {
            // Inlined into the caller's loop: the interpreter's efficiency curves.
            return self.one_1d_small(args[0], orders[0]);
        }
        self.fresh(args, orders)
    }

    /// 1-D, orders up to 2, on the fast path: one column of `eval_1d_small` (plain linear: without the basis).
    #[inline]
    fn one_1d_small(&self, a: f64, order: usize) -> f64 {
        if a.is_nan() {
            return f64::NAN;
        }
        match self.x.kernel {
            None => self.x.plain_one(&self.values, a, order),
            Some(_) => self.eval_1d_small_one(a, order),
        }
    }

    /// One partial derivative, evaluated (the range check done by the caller).
    fn fresh(&self, args: &[f64], orders: [usize; 2]) -> f64 {
        if self.y.is_none() && self.small && orders[0] <= 2 {
            return self.one_1d_small(args[0], orders[0]);
        }
        let len = if self.y.is_none() {
            orders[0] + 1
        } else {
            (orders[0] + 1) * (orders[1] + 1)
        };
        let orders = [orders[0], if self.y.is_none() { 0 } else { orders[1] }];
        if len <= 9 {
            // Orders up to 2 per argument (the common case): a small array to clear.
            let mut out = [0.0; 9];
            self.eval(args, orders, &mut out[..len]);
            out[len - 1]
        } else if len <= 100 {
            let mut out = [0.0; 100];
            self.eval(args, orders, &mut out[..len]);
            out[len - 1]
        } else {
            let mut out = vec![0.0; len];
            self.eval(args, orders, &mut out);
            out[len - 1]
        }
    }

    fn eval_1d(&self, a: f64, out: &mut [f64]) {
        let orders = out.len();
        with_scratch(scratch_len(self.max_count[0], orders), |scratch| {
            let basis = self.x.basis(a, orders, scratch);
            out.fill(0.0);
            for (k, row) in basis.values.chunks_exact(orders).enumerate() {
                let v = self.values[basis.first + k];
                for (o, &b) in out.iter_mut().zip(row) {
                    *o += v * b;
                }
            }
        });
    }

    fn eval_2d(&self, y: &Axis, args: &[f64], orders: [usize; 2], out: &mut [f64]) {
        let (ox, oy) = (orders[0] + 1, orders[1] + 1);
        let ny = y.len();
        with_scratch(scratch_len(self.max_count[0], ox), |sx| {
            with_scratch(scratch_len(self.max_count[1], oy), |sy| {
                let bx = self.x.basis(args[0], ox, sx);
                let by = y.basis(args[1], oy, sy);
                contract(&self.values, ny, &bx, ox, &by, oy, out);
            })
        });
    }
}

/// `out[p · oy + q] = Σ_ij v_ij Φ_i^(p) Ψ_j^(q)`: per row `i`, first `t_q = Σ_j v_ij Ψ_j^(q)`, then the
/// outer product with `Φ_i^(p)`.
fn contract(
    values: &[f64],
    ny: usize,
    bx: &Basis<'_>,
    ox: usize,
    by: &Basis<'_>,
    oy: usize,
    out: &mut [f64],
) {
    out[..ox * oy].fill(0.0);
    let mut row_sum = [0.0; 16];
    let mut heap;
    let t: &mut [f64] = if oy <= row_sum.len() {
        &mut row_sum[..oy]
    } else {
        heap = vec![0.0; oy];
        &mut heap
    };
    for ki in 0..bx.count {
        let row = &values[(bx.first + ki) * ny..(bx.first + ki + 1) * ny];
        t.fill(0.0);
        for kj in 0..by.count {
            let v = row[by.first + kj];
            for (tq, &psi) in t.iter_mut().zip(&by.values[kj * oy..(kj + 1) * oy]) {
                *tq += v * psi;
            }
        }
        for (p, &phi) in bx.values[ki * ox..(ki + 1) * ox].iter().enumerate() {
            for (o, &tq) in out[p * oy..(p + 1) * oy].iter_mut().zip(t.iter()) {
                *o += phi * tq;
            }
        }
    }
}

fn scratch_len(max_count: usize, orders: usize) -> usize {
    max_count * orders + orders
}

/// Runs `f` with a zeroed scratch slice of `len` values, on the stack when it fits.
fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    if len <= STACK_SCRATCH {
        let mut buf = [0.0; STACK_SCRATCH];
        f(&mut buf[..len])
    } else {
        f(&mut vec![0.0; len])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The portable build of the one-point path (what a processor without AVX2 runs for `partials2`) gives
    /// `eval`'s numbers bit for bit (the integration tests cover the dispatched one), inside, at and outside
    /// the grid's edges, under both rules that continue the map.
    #[test]
    fn the_portable_one_point_path_equals_eval() {
        let x = vec![50.0, 100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0];
        let y = vec![2.0e4, 4.0e4, 6.0e4, 8.0e4, 1.0e5];
        let v: Vec<f64> = (0..40)
            .map(|k| 0.5 + 0.01 * ((k * 7) % 11) as f64)
            .collect();
        for rule in [Extrapolate::Linear, Extrapolate::Clamp] {
            for interp in [Interp::Smooth, Interp::Linear] {
                let s = MapSettings {
                    smooth: 0.5,
                    extrapolate: rule,
                    interp,
                };
                let map = Map::new_2d(x.clone(), y.clone(), v.clone(), s).expect("valid map");
                let y_axis = map.y.as_ref().expect("a 2-D map");
                for i in 0..=400 {
                    for j in 0..=60 {
                        let a = -40.0 + 2.0 * i as f64 + 0.37 * (j % 3) as f64;
                        let b = 5.0e3 + 1.75e3 * j as f64;
                        let got = one::portable(&map.x, y_axis, &map.padded, a, b);
                        let mut want = [0.0; 9];
                        map.eval(&[a, b], [2, 2], &mut want);
                        assert_eq!(
                            got.map(f64::to_bits),
                            want.map(f64::to_bits),
                            "{s:?} at ({a}, {b})"
                        );
                    }
                }
            }
        }
    }

    /// The portable build of the fixed-width path (what a processor without AVX2 runs) gives `partials2`'s
    /// numbers bit for bit, as the dispatched one does (the integration tests cover the dispatched one).
    #[test]
    fn the_portable_batch_path_equals_partials2() {
        let x = vec![50.0, 100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0];
        let y = vec![2.0e4, 4.0e4, 6.0e4, 8.0e4, 1.0e5];
        let v: Vec<f64> = (0..40)
            .map(|k| 0.5 + 0.01 * ((k * 7) % 11) as f64)
            .collect();
        let mut state = 1_u64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for rule in [Extrapolate::Linear, Extrapolate::Clamp] {
            for interp in [Interp::Smooth, Interp::Linear] {
                let s = MapSettings {
                    smooth: 0.5,
                    extrapolate: rule,
                    interp,
                };
                let maps = [
                    Map::new_2d(x.clone(), y.clone(), v.clone(), s).expect("valid map"),
                    Map::new_1d(x.clone(), v[..8].to_vec(), s).expect("valid map"),
                ];
                for map in &maps {
                    let n = 77;
                    let a: Vec<f64> = (0..n).map(|_| -100.0 + 900.0 * next()).collect();
                    let b: Vec<f64> = (0..n).map(|_| 1.0e4 + 1.0e5 * next()).collect();
                    let width = if map.arity() == 2 { 9 } else { 3 };
                    let mut out = vec![0.0; width * n];
                    let data = batch::Data {
                        x: &map.x,
                        y: map.y.as_ref(),
                        padded: &map.padded,
                    };
                    let b_in = if map.arity() == 2 { &b[..] } else { &[][..] };
                    batch::portable(data, &a, b_in, &mut out, false);
                    let mut values = vec![0.0; n];
                    batch::portable(data, &a, b_in, &mut values, true);
                    for i in 0..n {
                        assert_eq!(values[i].to_bits(), out[i].to_bits(), "{s:?} value {i}");
                    }
                    for i in 0..n {
                        let want = map.partials2(&[a[i], b[i]][..map.arity()]);
                        for k in 0..width {
                            assert_eq!(
                                out[k * n + i].to_bits(),
                                want[k].to_bits(),
                                "{s:?} point {i} entry {k}"
                            );
                        }
                    }
                }
            }
        }
    }
}
