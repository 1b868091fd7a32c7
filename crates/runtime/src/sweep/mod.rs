//! Parameter sweeps: many variants of one model (parameter values from a full-factorial grid or a table) ×
//! one or more cycles, each run inversely, one row of summary figures per variant × cycle.
//!
//! ```
//! use invsim_runtime::{Cycle, SimulationOptions, Sweep};
//! let nedc = Cycle::builtin("nedc").expect("built in");
//! let opts = SimulationOptions::builder().dt(1.0).build()?;
//! let sweep = Sweep::new(|| invsim_models::builtin("si_engine").expect("built in"))
//!     .cycle(&nedc)
//!     .grid("m", 1000.0, 1600.0, 4)
//!     .options(opts)
//!     .threads(1)
//!     .build()?;
//! let result = sweep.run();
//! assert_eq!(result.rows.len(), 4);
//! assert_eq!(result.failed(), 0);
//! # Ok::<(), invsim_runtime::SweepError>(())
//! ```
//!
//! The smoothed reference and the model's smoothed signals are computed once per cycle
//! ([`crate::inverse::reference`]) and shared by every
//! variant ([`crate::inverse::simulate_shared`]): a row's figures are bit for bit those of
//! [`crate::simulate()`] of the same variant. Variants run in parallel (rayon), each worker with its own copy
//! of the model (made by the factory once per worker, then [`InverseModel::set_param`] per variant); no time
//! series is stored unless `verify` needs one. A variant that fails is a row with its error.

mod exec;
mod hybrid_columns;
mod parquet;
mod plan;
mod rows;

use std::path::PathBuf;
use std::sync::Arc;

use invsim_model_api::InverseModel;
use thiserror::Error;

use crate::cycle::Cycle;
use crate::inverse::{SimulateError, SimulationOptions};
use crate::plant::Plant;
use crate::run_keep::{Shared, SharedError};

pub use hybrid_columns::{Cell, HybridColumn, HYBRID_COLUMNS};
pub use plan::{ModelFactory, Sweep};
pub use rows::{Figures, ModeFigures, SweepResult, SweepRow};

/// Why a sweep could not be built.
#[derive(Debug, Error)]
pub enum SweepError {
    #[error("a sweep needs at least one cycle")]
    NoCycles,
    #[error("cannot make the model: {0}")]
    Model(String),
    #[error("grid axis `{name}`: {reason}")]
    BadAxis { name: String, reason: String },
    #[error("parameter `{name}` is swept twice")]
    DuplicateParameter { name: String },
    #[error("parameter table: row {row} has {got} values, the header names {expected} parameters")]
    TableWidth {
        row: usize,
        got: usize,
        expected: usize,
    },
    #[error("unknown parameter `{name}` (the model declares: {known})")]
    UnknownParameter { name: String, known: String },
    #[error("parameter `{name}`: {reason}")]
    NotSettable { name: String, reason: String },
    #[error("cycle `{cycle}`: {reason}")]
    Gears { cycle: String, reason: String },
    #[error("cycle `{cycle}`: {source}")]
    Reference {
        cycle: String,
        #[source]
        source: Box<SimulateError>,
    },
    #[error(transparent)]
    Options(Box<SimulateError>),
    /// A strategy the model or the other options cannot run (`--strategy` on a model without `[hybrid]`).
    #[error("{0}")]
    Strategy(String),
    #[error("cannot start {threads} worker threads: {reason}")]
    Threads { threads: usize, reason: String },
    #[error(
        "{} runs ({what}) exceed the limit of {max} runs a sweep makes; sweep fewer values",
        crate::numfmt::num(*runs)
    )]
    TooManyRuns {
        /// The runs asked for (a float: the product of the axes' sizes may exceed every integer type).
        runs: f64,
        /// How they come about: "3 grid axes × 2 cycles", "a table of 2000000 rows × 1 cycle".
        what: String,
        max: usize,
    },
}

/// Most runs (variants × cycles) a sweep makes: every run is a whole simulation (milliseconds to seconds
/// each, so 10⁶ runs already take hours of CPU time) and its row (a few hundred bytes) is kept until the
/// table is written; 10⁶ rows stay in the hundreds of MiB. Checked before any variant is made
/// ([`count_runs`]): `--grid m=1000:1800:1000000000`, or two axes of 10⁵ values, is refused at once.
pub const MAX_RUNS: usize = 1_000_000;

/// The number of runs of a sweep whose design has variants of `sizes` (one size per grid axis — the variants
/// are their product, computed with overflow checks — or the table's row count alone) on `cycles` cycles;
/// more than [`MAX_RUNS`] is [`SweepError::TooManyRuns`] (`what` describes the design for the message).
pub fn count_runs(sizes: &[usize], cycles: usize, what: &str) -> Result<usize, SweepError> {
    let exact = sizes
        .iter()
        .try_fold(cycles.max(1), |acc, &n| acc.checked_mul(n));
    match exact {
        Some(runs) if runs <= MAX_RUNS => Ok(runs),
        _ => {
            let runs = sizes
                .iter()
                .fold(cycles.max(1) as f64, |acc, &n| acc * n as f64);
            let cycles = match cycles.max(1) {
                1 => "1 cycle".to_string(),
                n => format!("{n} cycles"),
            };
            Err(SweepError::TooManyRuns {
                runs,
                what: format!("{what} × {cycles}"),
                max: MAX_RUNS,
            })
        }
    }
}

/// How the variants' parameter values are given.
#[derive(Debug, Clone)]
enum Design {
    /// Full factorial over the axes (the last axis varies fastest).
    Grid(Vec<(String, Vec<f64>)>),
    /// One variant per row.
    Table {
        names: Vec<String>,
        rows: Vec<Vec<f64>>,
    },
}

/// Builds a [`Sweep`] (see [`Sweep::new`]); [`SweepBuilder::build`] checks everything once.
pub struct SweepBuilder {
    factory: ModelFactory,
    /// Each cycle and the file it was read from (`None`: built in).
    cycles: Vec<(Cycle, Option<PathBuf>)>,
    design: Design,
    table: Option<(Vec<String>, Vec<Vec<f64>>)>,
    errors: Vec<SweepError>,
    opts: SimulationOptions,
    verify: bool,
    threads: usize,
}

impl From<SimulateError> for SweepError {
    fn from(e: SimulateError) -> SweepError {
        SweepError::Options(Box::new(e))
    }
}

impl Sweep {
    /// A sweep of the model `factory` makes (`|| invsim_models::builtin("si_engine").unwrap()`, or
    /// [`Sweep::of`] for a model that is `Clone`).
    // `new` starts the builder, as `Sweep::new(model).cycle(…)….build()?` reads.
    #[allow(clippy::new_ret_no_self)]
    pub fn new<F>(factory: F) -> SweepBuilder
    where
        F: Fn() -> Box<dyn InverseModel> + Send + Sync + 'static,
    {
        Sweep::try_new(move || Ok(factory()))
    }

    /// [`Sweep::new`] with a factory that may fail: [`SweepBuilder::build`] reports its error, and a worker
    /// whose copy fails gives rows with that error.
    pub fn try_new<F>(factory: F) -> SweepBuilder
    where
        F: Fn() -> Result<Box<dyn InverseModel>, String> + Send + Sync + 'static,
    {
        Sweep::of_plants(move || factory().map(Plant::Single))
    }

    /// A sweep of any model, with or without modes: `factory` makes a copy at its base parameters (once per
    /// worker) or says why it cannot.
    pub fn of_plants<F>(factory: F) -> SweepBuilder
    where
        F: Fn() -> Result<Plant, String> + Send + Sync + 'static,
    {
        SweepBuilder {
            factory: Arc::new(factory),
            cycles: Vec::new(),
            design: Design::Grid(Vec::new()),
            table: None,
            errors: Vec::new(),
            opts: SimulationOptions::default(),
            verify: false,
            threads: 0,
        }
    }

    /// A sweep of copies of `model` (e.g. an `invsim_inversion::Interpreter`).
    pub fn of<M: InverseModel + Clone + 'static>(model: M) -> SweepBuilder {
        Sweep::new(move || Box::new(model.clone()))
    }

    /// Names of the swept parameters, in the order of every row's `params`.
    pub fn parameters(&self) -> &[String] {
        &self.names
    }
    /// The variants' parameter values.
    pub fn variants(&self) -> &[Vec<f64>] {
        &self.variants
    }
    /// The worker threads the sweep starts (0: rayon's global pool, one per core).
    pub fn threads(&self) -> usize {
        self.threads
    }
    /// Number of rows [`Sweep::run`] returns: variants × cycles.
    pub fn len(&self) -> usize {
        self.variants.len() * self.cycles.len()
    }
    /// True if there is nothing to run (a table without rows).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Run every variant on every cycle: rows in the order variant 0 on each cycle, variant 1 on each cycle, ….
    pub fn run(&self) -> SweepResult {
        self.run_with_progress(&|_| {})
    }

    /// [`Sweep::run`], calling `progress(n)` after each finished row with the number of rows finished by then
    /// (from the worker threads).
    pub fn run_with_progress(&self, progress: &(dyn Fn(usize) + Sync)) -> SweepResult {
        exec::run(self, progress)
    }
}

impl SweepBuilder {
    /// Add a built-in cycle, or a cycle file's (its name labels the rows).
    pub fn cycle(mut self, cycle: &Cycle) -> Self {
        self.cycles.push((cycle.clone(), None));
        self
    }

    /// Add a cycle read from `file` (a model whose gearbox takes the gear from a column of the cycle file
    /// reads it there).
    pub fn cycle_file(mut self, cycle: &Cycle, file: impl Into<PathBuf>) -> Self {
        self.cycles.push((cycle.clone(), Some(file.into())));
        self
    }

    /// Add a grid axis: `n` values of parameter `name` evenly from `start` to `stop` (both included;
    /// n = 1 gives `start`). Several axes make a full-factorial design, the last added varying fastest. An
    /// axis of more than [`MAX_RUNS`] values is refused here, before its values are made.
    pub fn grid(self, name: impl Into<String>, start: f64, stop: f64, n: usize) -> Self {
        let name = name.into();
        if let Err(e) = count_runs(&[n], 1, &format!("grid axis `{name}` of {n} values")) {
            return self.fail(e);
        }
        match grid_values(start, stop, n) {
            Ok(v) => self.values(name, v),
            Err(reason) => self.fail(SweepError::BadAxis { name, reason }),
        }
    }

    /// Add a grid axis with the given values of parameter `name`.
    pub fn values(mut self, name: impl Into<String>, values: Vec<f64>) -> Self {
        let name = name.into();
        if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
            let reason = "needs at least one value, all finite".to_string();
            return self.fail(SweepError::BadAxis { name, reason });
        }
        if let Design::Grid(axes) = &mut self.design {
            axes.push((name, values));
        }
        self
    }

    /// The variants as a table: the parameters `names` and one row of values per variant (instead of a grid).
    pub fn table(mut self, names: Vec<String>, rows: Vec<Vec<f64>>) -> Self {
        self.table = Some((names, rows));
        self
    }

    /// The options of every run (look-ahead, dt, engine name, …; `keep_series` is ignored: no series is kept).
    pub fn options(mut self, opts: SimulationOptions) -> Self {
        self.opts = opts;
        self
    }

    /// Replay every variant's input through the original model and report its tracking error.
    pub fn verify(mut self, verify: bool) -> Self {
        self.verify = verify;
        self
    }

    /// Number of worker threads (0, the default: rayon's choice, one per core); at most one per run and
    /// [`MAX_THREADS_PER_CORE`] per core are started ([`worker_threads`], [`Sweep::threads`]).
    pub fn threads(mut self, threads: usize) -> Self {
        self.threads = threads;
        self
    }

    fn fail(mut self, e: SweepError) -> Self {
        self.errors.push(e);
        self
    }

    /// The sweep, checked: the parameters exist, the axes and the table are well formed, the options are valid,
    /// and the reference of every cycle (computed here, once).
    pub fn build(mut self) -> Result<Sweep, SweepError> {
        if let Some(e) = self.errors.drain(..).next() {
            return Err(e);
        }
        if let Some((names, rows)) = self.table.take() {
            if matches!(&self.design, Design::Grid(axes) if !axes.is_empty()) {
                return Err(SweepError::BadAxis {
                    name: names.join(","),
                    reason: "a sweep has either grid axes or a table, not both".to_string(),
                });
            }
            self.design = Design::Table { names, rows };
        }
        if self.cycles.is_empty() {
            return Err(SweepError::NoCycles);
        }
        let mut opts = self.opts.clone();
        opts.verify = self.verify;
        opts.keep_series = false;
        // A row reports the figures, not the engine's operating points.
        opts.operating_points = false;
        opts.validate()?;
        count_runs(
            &design_sizes(&self.design),
            self.cycles.len(),
            &describe(&self.design),
        )?;
        let model = (self.factory)().map_err(SweepError::Model)?;
        check_strategy(&model, &opts)?;
        let (names, variants) = expand(&self.design)?;
        if let Some((name, reason)) = names
            .iter()
            .find_map(|n| model.not_settable(n).map(|r| (n.clone(), r)))
        {
            return Err(SweepError::NotSettable { name, reason });
        }
        let mut settable = model.parameters();
        settable.extend(model.per_gear_names());
        check_names(&settable, &names)?;
        let cycles = self
            .cycles
            .into_iter()
            .map(|(c, file)| {
                // One choice of look-ahead per cycle (it depends on the cycle and dt, not on the variant).
                let (opts, _) =
                    crate::lookahead::resolve(&opts, &c).map_err(|e| SweepError::Reference {
                        cycle: c.name.clone(),
                        source: Box::new(e),
                    })?;
                let shared = shared(&model, &c, file.as_deref(), &opts)?;
                Ok((c, shared, opts))
            })
            .collect::<Result<Vec<_>, SweepError>>()?;
        let threads = worker_threads(self.threads, variants.len() * cycles.len());
        let pool = match threads {
            0 | 1 => None,
            n => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| SweepError::Threads {
                        threads: n,
                        reason: e.to_string(),
                    })?,
            ),
        };
        Ok(Sweep {
            model: model.name().to_string(),
            integrals: model.integrals(),
            headline: crate::headline::sweep_columns(model.info()),
            modes: model.mode_names(),
            factory: self.factory,
            cycles,
            names,
            variants,
            opts,
            threads,
            pool,
        })
    }
}

/// Worker threads per core a sweep starts at most: more only wait for a core, each with a copy of the model.
pub const MAX_THREADS_PER_CORE: usize = 4;

/// The worker threads a sweep of `jobs` runs starts when `requested` are asked for (0: rayon's choice, one
/// per core): never more than there are runs, nor more than [`MAX_THREADS_PER_CORE`] per core of this
/// machine, and at least one.
pub fn worker_threads(requested: usize, jobs: usize) -> usize {
    if requested == 0 {
        return 0;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    requested.min(jobs).min(MAX_THREADS_PER_CORE * cores).max(1)
}

/// `n` values evenly from `start` to `stop`: start + i·(stop − start)/(n − 1), i = 0 … n − 1 (the last is
/// `stop` exactly).
fn grid_values(start: f64, stop: f64, n: usize) -> Result<Vec<f64>, String> {
    if !(start.is_finite() && stop.is_finite()) {
        return Err(format!("start {start} and stop {stop} must be finite"));
    }
    match n {
        0 => Err("needs at least one point (N ≥ 1)".to_string()),
        1 => Ok(vec![start]),
        _ => {
            let step = (stop - start) / (n - 1) as f64;
            Ok((0..n)
                .map(|i| {
                    if i + 1 == n {
                        stop
                    } else {
                        start + i as f64 * step
                    }
                })
                .collect())
        }
    }
}

/// The sizes whose product is a design's variant count: each grid axis's, or the table's row count.
fn design_sizes(design: &Design) -> Vec<usize> {
    match design {
        Design::Grid(axes) => axes.iter().map(|(_, v)| v.len()).collect(),
        Design::Table { rows, .. } => vec![rows.len()],
    }
}

/// A design for a message: "3 grid axes", "a table of 20 rows".
fn describe(design: &Design) -> String {
    match design {
        Design::Grid(axes) if axes.len() == 1 => "1 grid axis".to_string(),
        Design::Grid(axes) => format!("{} grid axes", axes.len()),
        Design::Table { rows, .. } => format!("a table of {} rows", rows.len()),
    }
}

/// The parameter names and the variants of a design (full factorial for a grid, last axis fastest).
fn expand(design: &Design) -> Result<(Vec<String>, Vec<Vec<f64>>), SweepError> {
    match design {
        Design::Table { names, rows } => {
            if let Some((row, r)) = rows
                .iter()
                .enumerate()
                .find(|(_, r)| r.len() != names.len())
            {
                return Err(SweepError::TableWidth {
                    row: row + 1,
                    got: r.len(),
                    expected: names.len(),
                });
            }
            Ok((names.clone(), rows.clone()))
        }
        Design::Grid(axes) => {
            let names: Vec<String> = axes.iter().map(|(n, _)| n.clone()).collect();
            let mut variants: Vec<Vec<f64>> = vec![Vec::new()];
            for (_, values) in axes {
                variants = variants
                    .iter()
                    .flat_map(|v| {
                        values.iter().map(move |&x| {
                            let mut w = v.clone();
                            w.push(x);
                            w
                        })
                    })
                    .collect();
            }
            Ok((names, variants))
        }
    }
}

/// What every run of `model` on `cycle` (read from `file`, `None` for a built-in) shares: the smoothed
/// reference of a model without modes, the gear schedule and the smoothed cycle of one with modes.
fn shared(
    model: &Plant,
    cycle: &Cycle,
    file: Option<&std::path::Path>,
    opts: &SimulationOptions,
) -> Result<Shared, SweepError> {
    Shared::new(model, cycle, file, opts).map_err(|e| match e {
        SharedError::Reference(source) => SweepError::Reference {
            cycle: cycle.name.clone(),
            source: Box::new(source),
        },
        SharedError::Gears(reason) => SweepError::Gears {
            cycle: cycle.name.clone(),
            reason,
        },
    })
}

/// A strategy's sweep needs a hybrid (a model with modes and a `[hybrid]` table), refused here once rather
/// than in every row.
pub fn check_strategy(model: &Plant, opts: &SimulationOptions) -> Result<(), SweepError> {
    let Some(strategy) = &opts.strategy else {
        return Ok(());
    };
    let flag = strategy.method.flag();
    let hybrid = matches!(model, Plant::Modal(p) if p.hybrid().is_some());
    if !hybrid {
        return Err(SweepError::Strategy(format!(
            "{flag} needs a model with modes and a [hybrid] table (fuel_power, battery_power, soc); \
             `{}` has none",
            model.name()
        )));
    }
    Ok(())
}

/// Every swept name is one the model takes (a parameter, or a gearbox parameter's per-gear name), and none
/// twice.
fn check_names(declared: &[String], names: &[String]) -> Result<(), SweepError> {
    for (i, name) in names.iter().enumerate() {
        if names[..i].contains(name) {
            return Err(SweepError::DuplicateParameter { name: name.clone() });
        }
        if !declared.iter().any(|p| p == name) {
            return Err(SweepError::UnknownParameter {
                name: name.clone(),
                known: declared.join(", "),
            });
        }
    }
    Ok(())
}
