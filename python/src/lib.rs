//! The Rust extension `invsim._invsim` of the Python package `invsim`: a model loaded once (`Model`), its
//! derivation as JSON, single inverse simulations returning their columns as numpy arrays (moved, not copied)
//! and parameter sweeps. Every call runs without the GIL. The Python wrappers in `python/invsim/` turn the
//! JSON into dicts (a run's summary when it is first read) and the columns into pandas and polars data
//! frames.

mod engine;
mod error;
mod forward;
mod run;
mod strategy;
mod sweep;

use std::path::PathBuf;

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use engine::{EngineChoice, Loaded};
use error::{to_py, Failure, InvsimError};
use forward::{forward_one, ForwardRequest};
use run::{load_cycle, simulate_any, Output, PySignal, RunOptions};
use strategy::PyStrategy;
use sweep::{run_sweep, Variants};

/// What `Model.simulate` and `Model.forward` return: the summary, the column names, the columns and their
/// units.
type RunOutput<'py> = (
    RunSummary,
    Vec<String>,
    Vec<Bound<'py, PyArray1<f64>>>,
    Vec<(String, Option<String>)>,
);

/// The summary of one run, kept as Rust data: written as JSON (what `--summary-json` writes) when asked
/// for, so that a run whose summary is not read does not pay for writing and parsing it.
#[pyclass(module = "invsim._invsim", frozen)]
struct RunSummary(run::RunSummary);

#[pymethods]
impl RunSummary {
    /// The summary as JSON.
    fn json(&self) -> PyResult<String> {
        serde_json::to_string(&self.0).map_err(|e| InvsimError::new_err(e.to_string()))
    }
}

/// A run's output as Python gets it: each column's Vec becomes the buffer of its numpy array (no copy).
fn to_python(py: Python<'_>, (summary, columns, data, units): Output) -> RunOutput<'_> {
    let arrays = data.into_iter().map(|c| c.into_pyarray(py)).collect();
    (RunSummary(summary), columns, arrays, units)
}
/// One sweep row: variant, cycle index, every parameter's value, the summary JSON, the error.
type SweepRow = (usize, usize, Vec<f64>, Option<String>, Option<String>);

/// A model file, read and derived once; runs on compiled code when the file is a built-in model's.
#[pyclass(module = "invsim._invsim", frozen)]
struct Model {
    loaded: Loaded,
    path: String,
    source: Vec<u8>,
    engine_choice: String,
    /// What its runs on one cycle share, kept from run to run (`invsim_runtime::RunKeep`).
    keep: invsim_runtime::RunKeep,
}

impl Model {
    fn load(py: Python<'_>, path: String, source: Vec<u8>, engine: String) -> PyResult<Model> {
        let loaded = py.allow_threads(|| {
            let choice: EngineChoice = engine
                .parse()
                .map_err(|e: invsim_loader::LoadError| Failure::msg(e.to_string()))?;
            Loaded::new(&PathBuf::from(&path), &source, choice)
        });
        Ok(Model {
            loaded: to_py(py, loaded)?,
            path,
            source,
            engine_choice: engine,
            keep: invsim_runtime::RunKeep::new(),
        })
    }
}

#[pymethods]
impl Model {
    /// Read, check and derive the model file at `path`; `engine` is "auto", "compiled" or "interpreted".
    #[new]
    #[pyo3(signature = (path, engine = "auto"))]
    fn new(py: Python<'_>, path: PathBuf, engine: &str) -> PyResult<Model> {
        let source = py.allow_threads(|| {
            std::fs::read(&path).map_err(|_| {
                // The model reader's own message for an unreadable file.
                match invsim_inversion::Model::from_path(&path) {
                    Err(e) => Failure::from(e),
                    Ok(_) => {
                        Failure::in_file("cannot read the model file", path.display().to_string())
                    }
                }
            })
        });
        let source = to_py(py, source)?;
        Model::load(py, path.display().to_string(), source, engine.to_string())
    }

    /// The same model from the bytes of its file (`path` names it in messages); used to unpickle.
    #[staticmethod]
    #[pyo3(signature = (path, source, engine = String::from("auto")))]
    fn from_source(
        py: Python<'_>,
        path: String,
        source: Vec<u8>,
        engine: String,
    ) -> PyResult<Model> {
        Model::load(py, path, source, engine)
    }

    /// The model file's path as given.
    #[getter]
    fn path(&self) -> &str {
        &self.path
    }

    /// The model file's bytes.
    #[getter]
    fn source<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.source)
    }

    /// The engine asked for ("auto", "compiled", "interpreted").
    #[getter]
    fn engine_choice(&self) -> &str {
        &self.engine_choice
    }

    /// The engine that runs the model: "compiled" or "interpreted".
    #[getter]
    fn engine(&self) -> &'static str {
        self.loaded.engine_name()
    }

    /// The derivation as JSON (the command line's `invsim derive --format json`).
    fn derive_json(&self, py: Python<'_>) -> PyResult<String> {
        let json = py.allow_threads(|| {
            let path = PathBuf::from(&self.path);
            self.loaded
                .derive_json(&path, &self.source)
                .map(str::to_string)
        });
        to_py(py, json)
    }

    /// Whether the model has operating modes.
    #[getter]
    fn modal(&self) -> bool {
        matches!(self.loaded.kind, engine::Kind::Modal(_))
    }

    /// The unit of every column an inverse run of a model without modes can have, as (name, unit or None)
    /// (runs of a model with modes and forward runs carry their units).
    fn column_units(&self) -> Vec<(String, Option<String>)> {
        self.loaded.units.clone()
    }

    /// One inverse simulation: (summary, column names, columns as float64 arrays, units).
    #[pyo3(signature = (cycle, dt, lookahead, params, verify, causal, include_extension, keep_series, signals, initial, switching, transition_time, gradient, strategy = None))]
    #[allow(clippy::too_many_arguments)]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        cycle: String,
        dt: f64,
        lookahead: Option<f64>,
        params: Vec<(String, f64)>,
        verify: bool,
        causal: bool,
        include_extension: bool,
        keep_series: bool,
        signals: Vec<PySignal>,
        initial: Vec<(String, f64)>,
        switching: String,
        transition_time: Option<f64>,
        gradient: Option<Vec<String>>,
        strategy: Option<PyStrategy>,
    ) -> PyResult<RunOutput<'py>> {
        let opts = RunOptions {
            dt,
            lookahead,
            verify,
            causal,
            include_extension,
            keep_series,
            signals,
            initial,
            switching,
            transition_time,
            gradient,
            strategy: strategy.unwrap_or_default().into(),
        };
        let model = (&self.loaded, &self.path[..], &self.keep);
        let out = py.allow_threads(|| simulate_any(model, &cycle, &params, &opts));
        Ok(to_python(py, to_py(py, out)?))
    }

    /// One forward simulation with the PI driver: (summary, column names, columns, units).
    #[pyo3(signature = (cycle, dt, kp, ki, response, feedforward, bounds, method, rtol, atol, max_steps, params, keep_series, signals, initial))]
    #[allow(clippy::too_many_arguments)]
    fn forward<'py>(
        &self,
        py: Python<'py>,
        cycle: String,
        dt: f64,
        kp: f64,
        ki: f64,
        response: f64,
        feedforward: bool,
        bounds: String,
        method: String,
        rtol: f64,
        atol: f64,
        max_steps: Option<usize>,
        params: Vec<(String, f64)>,
        keep_series: bool,
        signals: Vec<PySignal>,
        initial: Vec<(String, f64)>,
    ) -> PyResult<RunOutput<'py>> {
        let req = ForwardRequest {
            dt,
            kp,
            ki,
            response,
            feedforward,
            bounds,
            method,
            rtol,
            atol,
            max_steps,
            keep_series,
            signals,
            initial,
        };
        let out = py.allow_threads(|| forward_one(&self.loaded, &self.path, &cycle, &params, &req));
        Ok(to_python(py, to_py(py, out)?))
    }

    /// A sweep: every variant (`names[j]` = `values[j][i]`) on every cycle, after the `base` settings.
    /// Returns the model's parameter names and one row per variant × cycle (variant-major).
    #[pyo3(signature = (names, values, cycles, base, dt, lookahead, verify, threads, signals, initial, strategy = None))]
    #[allow(clippy::too_many_arguments)]
    fn sweep(
        &self,
        py: Python<'_>,
        names: Vec<String>,
        values: Vec<PyReadonlyArray1<'_, f64>>,
        cycles: Vec<String>,
        base: Vec<(String, f64)>,
        dt: f64,
        lookahead: Option<f64>,
        verify: bool,
        threads: Option<usize>,
        signals: Vec<PySignal>,
        initial: Vec<(String, f64)>,
        strategy: Option<PyStrategy>,
    ) -> PyResult<(Vec<String>, Vec<SweepRow>)> {
        let values = variant_columns(&names, &values)?;
        let variants = Variants { names, values };
        // The command line's limit of runs (the Python wrapper checks a grid before expanding it).
        let what = format!("a table of {} rows", variants.len());
        count_runs(vec![variants.len()], cycles.len(), &what)?;
        let opts = RunOptions {
            dt,
            lookahead,
            verify,
            causal: false,
            include_extension: false,
            keep_series: false,
            signals,
            initial,
            switching: "reentry".to_string(),
            transition_time: None,
            gradient: None,
            strategy: strategy.unwrap_or_default().into(),
        };
        let rows = py.allow_threads(|| {
            let loaded_cycles = cycles
                .iter()
                .map(|c| load_cycle(c))
                .collect::<Result<Vec<_>, _>>()?;
            let first = loaded_cycles.first().map_or("", |c| c.name.as_str());
            let opts = opts.build(self.loaded.engine_name(), &self.path, first)?;
            check_variants(&self.loaded, &variants)?;
            // A strategy the model cannot run is refused before any row, as on the command line.
            if opts.strategy.is_some() {
                let plant = self.loaded.plant(&[])?;
                invsim_runtime::sweep::check_strategy(&plant, &opts)
                    .map_err(|e| Failure::msg(format!("sweep of `{}`: {e}", self.path)))?;
            }
            run_sweep(
                &self.loaded,
                &self.path,
                (&loaded_cycles, &cycles),
                &variants,
                &base,
                &opts,
                threads,
            )
        });
        let rows = to_py(py, rows)?;
        let param_names = self.loaded.parameters();
        let rows = rows
            .into_iter()
            .map(|r| {
                let (ok, err) = match r.summary {
                    Ok(s) => (Some(s), None),
                    Err(e) => (None, Some(e)),
                };
                (r.variant, r.cycle, r.params, ok, err)
            })
            .collect();
        Ok((param_names, rows))
    }
}

/// A sweep's parameter names must be the model's and its columns of one length: else no row could run.
fn check_variants(model: &Loaded, v: &Variants) -> Result<(), Failure> {
    if let Some(c) = v.values.iter().find(|c| c.len() != v.len()) {
        return Err(Failure::msg(format!(
            "sweep parameters: every column must have one value per variant ({} and {})",
            v.len(),
            c.len()
        )));
    }
    let known = model.settable();
    if let Some(name) = v.names.iter().find(|n| !known.contains(n)) {
        return Err(Failure::msg(format!(
            "sweep parameter `{name}`: the model has no such parameter (its parameters: {})",
            known.join(", ")
        )));
    }
    Ok(())
}

/// The number of runs of a sweep whose variants are the product of `sizes` (one per grid axis, or a table's
/// row count) on `cycles` cycles, or an `InvsimError` when it exceeds the command line's limit
/// ([`invsim_runtime::sweep::MAX_RUNS`]), with its message (`what`: "2 grid axes", "a table of 20 rows").
#[pyfunction]
fn count_runs(sizes: Vec<usize>, cycles: usize, what: &str) -> PyResult<usize> {
    invsim_runtime::sweep::count_runs(&sizes, cycles, what)
        .map_err(|e| InvsimError::new_err(format!("sweep: {e}")))
}

/// The plausibility warnings of the cycle `spec` (none for a built-in cycle): a speed column whose values fit
/// another unit, a time column in ms, accelerations beyond a car's; the command line prints them before a run.
#[pyfunction]
fn cycle_warnings(py: Python<'_>, spec: &str) -> PyResult<Vec<String>> {
    to_py(
        py,
        run::load_cycle_checked(spec).map(|(_, warnings)| warnings),
    )
}

/// The extension module.
#[pymodule]
fn _invsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Model>()?;
    m.add_class::<RunSummary>()?;
    m.add("InvsimError", m.py().get_type::<InvsimError>())?;
    m.add("builtin_models", invsim_models::names())?;
    m.add_function(wrap_pyfunction!(count_runs, m)?)?;
    m.add_function(wrap_pyfunction!(cycle_warnings, m)?)?;
    m.add("max_sweep_runs", invsim_runtime::sweep::MAX_RUNS)?;
    // The command line's defaults of `invsim forward` (Model.forward's None).
    let defaults = pyo3::types::PyDict::new(m.py());
    use invsim_runtime::forward as f;
    for (name, value) in [
        ("kp", f::DRIVER_KP),
        ("ki", f::DRIVER_KI),
        ("response", f::RESPONSE_OMEGA),
        ("rtol", f::DEFAULT_RTOL),
        ("atol", f::DEFAULT_ATOL),
    ] {
        defaults.set_item(name, value)?;
    }
    m.add("forward_defaults", defaults)?;
    m.add(
        "builtin_cycles",
        invsim_runtime::Cycle::builtin_names().to_vec(),
    )?;
    Ok(())
}

/// The sweep's parameter columns as vectors. Reading an array as a slice of f64 needs it aligned; the Python
/// wrapper makes sure (`np.require(..., ["C", "A"])`), and an array that is not is refused here rather than
/// read.
fn variant_columns(
    names: &[String],
    values: &[PyReadonlyArray1<'_, f64>],
) -> PyResult<Vec<Vec<f64>>> {
    let mut out = Vec::with_capacity(values.len());
    for (i, a) in values.iter().enumerate() {
        let aligned: bool = a.as_any().getattr("flags")?.getattr("aligned")?.extract()?;
        if !aligned {
            let name = names.get(i).map_or("?", String::as_str);
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "sweep column {name:?}: the array is not aligned (pass np.require(a, requirements=[\"A\"]))"
            )));
        }
        out.push(a.as_array().to_vec());
    }
    Ok(out)
}
