"""invsim: inverse dynamic simulation of vehicle powertrains, from Python.

>>> import invsim
>>> model = invsim.Model("models/si_engine.toml")
>>> model.derive()["relative_degree"]
2
>>> run = model.simulate(cycle="nedc", dt=0.1, lookahead=5.0)
>>> run.summary["integrals"]["fuel"] > 0
True
>>> df = run.to_pandas()               # the CSV's columns; units in df.attrs["units"]
>>> sweep = model.sweep(params={"m": [1200.0, 1400.0]}, cycles=["nedc", "udds"])   # one row per variant x cycle

Everything runs in Rust without the GIL: `derive` is the command line's `invsim derive --format json`,
`simulate` its `invsim simulate` (summary = `--summary-json`, columns = `--out`), `sweep` a loop of such runs
over variants in parallel. Errors are `InvsimError` (a `ValueError`) with `file`, `line` and `column`.
"""

import functools
import json
import os

from . import _invsim

__all__ = ["Model", "Result", "InvsimError", "builtin_models", "builtin_cycles", "sweep_frame"]

InvsimError = _invsim.InvsimError
InvsimError.__module__ = "invsim"
# Defaults for errors raised without a position.
InvsimError.file = None
InvsimError.line = None
InvsimError.column = None

#: Names of the models compiled into the extension (files in the repository's models/).
builtin_models = list(_invsim.builtin_models)
#: Names of the built-in drive cycles (`invsim cycles`).
builtin_cycles = list(_invsim.builtin_cycles)


def _lookahead(lookahead):
    """`lookahead` for the engine: seconds, or None for "auto" (the longest look-ahead whose reference stays
    inside the cycle's tolerance band with its cycle energy within 1 % of the trace's, as `--lookahead auto`)."""
    if isinstance(lookahead, str) and lookahead.strip().lower() == "auto":
        return None
    return float(lookahead)


def _params_list(params):
    """A dict of parameter overrides as a list of (name, float), in the dict's order."""
    if params is None:
        return []
    return [(str(k), float(v)) for k, v in dict(params).items()]


def _signals_list(signals):
    """`signals={name: value}` as the extension takes them: a number (constant over the run, like
    `--signal grade=0.02`), a path (a signal file, like `--signal grade=FILE.csv`) or a pair (times, values)
    of sequences or numpy arrays (linear between samples, held outside them)."""
    out = []
    for name, value in (signals or {}).items():
        if isinstance(value, (str, os.PathLike)):
            out.append((str(name), None, os.fspath(value), None))
        elif isinstance(value, (tuple, list)) and len(value) == 2 and not isinstance(value[0], (int, float)):
            times, values = value
            out.append((str(name), None, None, ([float(t) for t in times], [float(v) for v in values])))
        else:
            try:
                out.append((str(name), float(value), None, None))
            except (TypeError, ValueError):
                raise InvsimError(
                    "signals[{!r}]: give a number, a file path or (times, values), not {!r}".format(name, value)
                ) from None
    return out


def _initial_list(initial):
    """`initial={state: value}` (the command line's `--initial NAME=VALUE`)."""
    return [(str(k), float(v)) for k, v in (initial or {}).items()]


class Result:
    """One inverse simulation: `summary` (dict), `columns` (names), `arrays` (name -> numpy float64 array,
    handed over from Rust without a copy) and `units` (column name -> unit or None)."""

    def __init__(self, summary, columns, arrays, units):
        # The run's summary as Rust keeps it: written as JSON and parsed when `summary` is first read.
        self._summary = summary
        self.columns = list(columns)
        self.arrays = dict(zip(self.columns, arrays))
        self.units = {c: units.get(c) for c in self.columns}

    @functools.cached_property
    def summary(self):
        """The summary (dict), as `invsim simulate --summary-json` writes it."""
        return json.loads(self._summary.json())

    def __getstate__(self):
        # Pickled with its summary as a dict (the Rust object does not pickle).
        state = dict(self.__dict__, summary=self.summary)
        del state["_summary"]
        return state

    def __len__(self):
        return self.summary["samples"] if not self.arrays else len(self.arrays["t"])

    def __getitem__(self, name):
        return self.arrays[name]

    def __repr__(self):
        return "<invsim.Result {} on {}: {} samples, columns {}>".format(
            self.summary.get("model"), self.summary.get("cycle"), self.summary.get("samples"), self.columns
        )

    def to_pandas(self):
        """A pandas DataFrame with the CSV's columns (same names, same order); the units are in
        `df.attrs["units"]` (column -> unit or None)."""
        import pandas as pd

        df = pd.DataFrame(self.arrays, columns=self.columns, copy=False)
        df.attrs["units"] = dict(self.units)
        df.attrs["summary"] = self.summary
        return df

    def to_polars(self, units_in_names=False):
        """A polars DataFrame with the CSV's columns. Polars frames carry no metadata: the units are in
        `Result.units`, or in the names (`"v [m/s]"`) with `units_in_names=True`."""
        import polars as pl

        def name(c):
            u = self.units.get(c)
            return "{} [{}]".format(c, u) if units_in_names and u else c

        return pl.DataFrame({name(c): self.arrays[c] for c in self.columns})


def _flatten(d, prefix=""):
    """A summary dict flattened for a table row: nested objects as `outer.inner`, lists as JSON text."""
    out = {}
    for k, v in d.items():
        key = prefix + k
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        elif isinstance(v, list):
            out[key] = json.dumps(v)
        else:
            out[key] = v
    return out


def _variants(params):
    """Sweep variants from a DataFrame (pandas or polars) or a dict of equal-length arrays: (names, columns)."""
    import numpy as np

    def column(v):
        # Contiguous and aligned float64: an array that arrives unaligned (a slice of a buffer Dask or pickle
        # deserialised in place) is copied, since the extension reads it as a slice of f64.
        return np.require(np.atleast_1d(np.asarray(v, dtype=np.float64)), requirements=["C", "A"])

    if params is None:
        return [], []
    if hasattr(params, "to_dict") and hasattr(params, "columns"):
        names = [str(c) for c in params.columns]
        cols = [column(params[c]) for c in params.columns]
    else:
        names = [str(k) for k in params]
        cols = [column(v) for v in params.values()]
    return names, cols


def sweep_frame(param_names, rows, cycles, names, cols, variant_offset=0):
    """The sweep's DataFrame from the extension's rows (one per variant x cycle)."""
    import pandas as pd

    records = []
    for variant, cycle, values, summary, error in rows:
        rec = {"variant": variant + variant_offset, "cycle": cycles[cycle]}
        if values:
            rec.update(zip(param_names, values))
        else:  # the parameters could not be set: the variant's own values
            rec.update({n: float(c[variant]) for n, c in zip(names, cols)})
        rec["error"] = error
        if summary is not None:
            rec.update(_flatten(json.loads(summary)))
        records.append(rec)
    df = pd.DataFrame.from_records(records)
    front = ["variant", "cycle"] + list(param_names) + ["error"]
    rest = [c for c in df.columns if c not in front]
    return df.reindex(columns=[c for c in front if c in df.columns] + rest)


class Model:
    """A model file, read, checked and derived once. `engine` is "auto" (compiled code when the file is
    byte for byte one of `builtin_models`, else the interpreter), "compiled" or "interpreted"."""

    def __init__(self, path, engine="auto"):
        self._m = _invsim.Model(str(path), engine)
        self._units = dict(self._m.column_units())

    @classmethod
    def _from_source(cls, path, source, engine):
        self = cls.__new__(cls)
        self._m = _invsim.Model.from_source(path, source, engine)
        self._units = dict(self._m.column_units())
        return self

    def __reduce__(self):
        # Pickled with the file's bytes: a worker process (Dask, multiprocessing) needs no copy of the file.
        return (Model._from_source, (self._m.path, self._m.source, self._m.engine_choice))

    def __repr__(self):
        return "<invsim.Model {} ({})>".format(self._m.path, self.engine)

    @property
    def path(self):
        """The model file's path as given."""
        return self._m.path

    @property
    def engine(self):
        """The engine that runs the model: "compiled" or "interpreted"."""
        return self._m.engine

    @property
    def modal(self):
        """Whether the model has operating modes (a gearbox, idle, a friction brake: `[modes]`)."""
        return self._m.modal

    def derive(self):
        """The derivation as a dict: exactly the JSON of `invsim derive MODEL --format json`."""
        return json.loads(self._m.derive_json())

    def simulate(
        self,
        cycle="nedc",
        dt=0.1,
        lookahead=5.0,
        params=None,
        signals=None,
        verify=False,
        causal=False,
        include_extension=False,
        keep_series=True,
        initial=None,
        switching="reentry",
        transition_time=None,
    ):
        """Inverse simulation on `cycle` (a built-in name or a cycle CSV path), like `invsim simulate`:
        `params` overrides parameters (`--set`), `signals` gives the model's `[signals]` (`--signal`: a number,
        a signal file's path, or (times, values)), `initial` start values of internal states (`--initial`),
        `verify` replays the input through the original model. `keep_series=False` computes every sample but
        keeps only the summary. Models with modes: `switching` is "reentry" or "quasi-static" and
        `transition_time` the re-entry's transition time in s (`--switching`, `--transition-time`)."""
        summary, columns, arrays, units = self._m.simulate(
            str(cycle),
            float(dt),
            _lookahead(lookahead),
            _params_list(params),
            bool(verify),
            bool(causal),
            bool(include_extension),
            bool(keep_series),
            _signals_list(signals),
            _initial_list(initial),
            str(switching),
            None if transition_time is None else float(transition_time),
        )
        return Result(summary, columns, arrays, dict(units) if units else self._units)

    def forward(
        self,
        cycle="nedc",
        dt=0.1,
        kp=None,
        ki=None,
        response=None,
        feedforward=True,
        bounds="ignore",
        method="dopri5",
        rtol=None,
        atol=None,
        max_steps=None,
        params=None,
        signals=None,
        initial=None,
        keep_series=True,
    ):
        """Forward simulation of the original model on `cycle`, closed by a PI driver on the raw cycle, like
        `invsim forward` (with or without modes): `kp`, `ki` the driver's gains, `response` the engine
        management's bandwidth, `feedforward` the driver's feed-forward of the cycle's slope, `bounds` "ignore"
        or "enforce", `method` "dopri5" or "rosenbrock23", `rtol`, `atol` and `max_steps` the integrator's
        tolerances and step budget (None: the command line's defaults); `params`, `signals`, `initial` as in
        `simulate`. The summary is `invsim forward --summary-json`'s, the columns its `--out`."""
        d = _invsim.forward_defaults
        summary, columns, arrays, units = self._m.forward(
            str(cycle),
            float(dt),
            float(d["kp"] if kp is None else kp),
            float(d["ki"] if ki is None else ki),
            float(d["response"] if response is None else response),
            bool(feedforward),
            str(bounds),
            str(method),
            float(d["rtol"] if rtol is None else rtol),
            float(d["atol"] if atol is None else atol),
            None if max_steps is None else int(max_steps),
            _params_list(params),
            bool(keep_series),
            _signals_list(signals),
            _initial_list(initial),
        )
        return Result(summary, columns, arrays, dict(units))

    def sweep(
        self,
        params=None,
        cycles=("nedc",),
        dt=0.1,
        lookahead=5.0,
        base=None,
        verify=False,
        threads=None,
        signals=None,
        initial=None,
    ):
        """Every variant on every cycle, in parallel (rayon; `threads` = None: all cores). `params` is a
        DataFrame (one row per variant, one column per parameter) or a dict of equal-length arrays; `base`
        overrides parameters for all variants, `signals` and `initial` apply to every run (as in `simulate`). Returns a pandas DataFrame with one row per variant x cycle
        (variant-major): `variant`, `cycle`, every model parameter, `error` (None, or why the run failed: a
        failing variant never aborts the sweep) and the flattened summary (`integrals.fuel`, ...)."""
        if isinstance(cycles, str):
            cycles = [cycles]
        cycles = [str(c) for c in cycles]
        names, cols = _variants(params)
        # No parameter varies: one variant, the model's defaults (with `base`).
        param_names, rows = self._m.sweep(
            names,
            cols,
            cycles,
            _params_list(base),
            float(dt),
            _lookahead(lookahead),
            bool(verify),
            threads,
            _signals_list(signals),
            _initial_list(initial),
        )
        return sweep_frame(param_names, rows, cycles, names, cols)
