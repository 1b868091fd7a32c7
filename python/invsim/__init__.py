"""invsim: inverse dynamic simulation of vehicle powertrains, from Python.

>>> import invsim
>>> model = invsim.Model("models/si_engine.toml")
>>> model.derive()["relative_degree"]
2
>>> run = model.simulate(cycle="nedc", dt=0.1, lookahead=5.0)
>>> run.summary["integrals"]["fuel"] > 0
True
>>> df = run.to_pandas()               # the CSV's columns; units in df.attrs["units"]
>>> grid = model.sweep(grid={"m": [1200.0, 1400.0], "C_d": [0.3, 0.34]}, cycles=["nedc"])  # 4 variants, as --grid
>>> table = model.sweep(table={"m": [1200.0, 1400.0], "C_d": [0.3, 0.34]}, cycles=["nedc"])  # 2, as --table

Everything runs in Rust without the GIL: `derive` is the command line's `invsim derive --format json`,
`simulate` its `invsim simulate` (summary = `--summary-json`, columns = `--out`), `sweep` its `invsim sweep`
(`grid=` every combination, `table=` one variant per row) with a row per variant x cycle in parallel. Errors
are `InvsimError` (a `ValueError`) with `file`, `line` and `column`.
"""

import functools
import json
import os
import warnings

from . import _invsim

__all__ = ["Model", "Result", "InvsimError", "builtin_models", "builtin_cycles", "max_sweep_runs", "sweep_frame"]

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
#: Most runs (variants x cycles) a sweep makes, as on the command line.
max_sweep_runs = _invsim.max_sweep_runs


def _warn_about_cycle(cycle, stacklevel=3):
    """The cycle file's plausibility warnings (a speed column whose values fit another unit, a time column in
    ms, accelerations beyond a car's), as `warnings.warn` before the run, as the command line prints them."""
    for w in _invsim.cycle_warnings(str(cycle)):
        warnings.warn(w, UserWarning, stacklevel=stacklevel)


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


def _gradient_list(gradient):
    """`gradient=` as the extension takes it: None, or the names (`"all"`: every parameter; a map's grid value
    `"bsfc[3,2]"`, whose comma the runtime joins back)."""
    if gradient is None:
        return None
    if isinstance(gradient, str):
        return [n.strip() for n in gradient.split(",")]
    return [str(n) for n in gradient]


#: The energy-management keyword arguments of `simulate` and `sweep` (hybrids; the command line's `--strategy`,
#: `--equivalence`, `--soc-tolerance`, `--soc-grid`, `--split-grid`, `--soc-window`, `--rb-*`) and their types.
_STRATEGY_KEYS = {
    "strategy": str,
    "equivalence": float,
    "soc_tolerance": float,
    "soc_grid": int,
    "split_grid": int,
    "soc_window": float,
    "rb_engine_power": float,
    "rb_soc_low": float,
    "rb_charge_power": float,
}


def _strategy_dict(strategy=None, **options):
    """The strategy's keyword arguments as the extension takes them: every key, None where not given (the
    command line's default), checked there as the command line checks its options."""
    unknown = sorted(set(options) - set(_STRATEGY_KEYS))
    if unknown:
        raise TypeError("unexpected keyword argument {!r}".format(unknown[0]))
    given = dict(options, strategy=strategy)
    out = {}
    for key, kind in _STRATEGY_KEYS.items():
        value = given.get(key)
        if value is None:
            out[key] = None
        elif kind is int:
            if isinstance(value, bool) or not float(value).is_integer() or float(value) < 0:
                raise InvsimError("{}={!r}: expected a whole number".format(key, value))
            out[key] = int(float(value))
        else:
            out[key] = kind(value)
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

    @property
    def hybrid(self):
        """The energy management's figures of a run with `strategy=` (the summary's `hybrid` block: `strategy`,
        `equivalence_factor`, `fuel_energy_j`, `fuel_energy_corrected_j` (SAE J1711), `delta_soc`,
        `engine_starts`, `engine_on_s`, ...; docs/hybrids.md) as a dict; None for a run without a strategy.
        The time per mode is in `summary["modes"]["per_mode"]`, the SOC, the decided input and the mode per
        sample in the columns."""
        return self.summary.get("hybrid")

    @property
    def gradient(self):
        """The exact derivatives of the summary's figures (a run with `gradient=`): a pandas DataFrame, one row
        per parameter, one column per figure (d figure / d parameter, as the summary's `gradient` block
        `{figure: {parameter: value}}`); None for a run without `gradient=`."""
        block = self.summary.get("gradient")
        if block is None:
            return None
        import pandas as pd

        return pd.DataFrame(block)

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


def _column(name, values, how):
    """One parameter's values as a contiguous, aligned float64 array (an array that arrives unaligned, a slice of
    a buffer Dask or pickle deserialised in place, is copied: the extension reads it as a slice of f64); every
    value finite, as the command line's --grid and --table take them."""
    import numpy as np

    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        hint = ""
        if isinstance(values, str):
            hint = " (the command line's START:STOP:N is numpy.linspace(START, STOP, N))"
        raise ValueError(
            "sweep {} `{}`: the values must be numbers, not {!r}{}".format(how, name, values, hint)
        ) from None
    if a.ndim > 1:
        raise ValueError("sweep {} `{}`: give a flat sequence of values, not a {}-d array".format(how, name, a.ndim))
    a = np.require(np.atleast_1d(a), requirements=["C", "A"])
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ValueError(
            "sweep {} `{}`: value {} (index {}) is not a finite number".format(how, name, a[bad[0]], bad[0])
        )
    return a


def _named_columns(values, how):
    """(names, raw columns) of a DataFrame (pandas or polars) or a dict of sequences; names must be strings and
    appear once."""
    if hasattr(values, "to_dict") and hasattr(values, "columns"):
        names = list(values.columns)
        raw = [values[c] for c in values.columns]
    elif isinstance(values, dict):
        names = list(values)
        raw = list(values.values())
    else:
        raise TypeError(
            "sweep {}=: give a dict {{name: values}} or a DataFrame, not {}".format(how, type(values).__name__)
        )
    for n in names:
        if not isinstance(n, str):
            raise TypeError("sweep {}=: parameter names must be strings, not {!r}".format(how, n))
    dup = next((n for i, n in enumerate(names) if n in names[:i]), None)
    if dup is not None:
        raise ValueError("sweep {}=: parameter `{}` is given twice".format(how, dup))
    if not names:
        raise ValueError("sweep {}=: no parameter given".format(how))
    return names, raw


def _grid(grid, n_cycles):
    """The variants of `grid={name: values}`: every combination, the last name varying fastest, as the command
    line's repeated --grid (NAME=START:STOP:N gives the values of np.linspace(START, STOP, N), bit for bit)."""
    import numpy as np

    names, raw = _named_columns(grid, "grid")
    axes = [_column(n, v, "grid axis") for n, v in zip(names, raw)]
    for n, a in zip(names, axes):
        if a.size == 0:
            raise ValueError("sweep grid axis `{}`: needs at least one value".format(n))
    what = "1 grid axis" if len(axes) == 1 else "{} grid axes".format(len(axes))
    _invsim.count_runs([a.size for a in axes], n_cycles, what)  # before the product is made
    mesh = np.meshgrid(*axes, indexing="ij")
    return names, [np.require(m.ravel(), requirements=["C", "A"]) for m in mesh]


def _table(table, n_cycles, how="table"):
    """The variants of `table=` (a DataFrame, or a dict of equal-length columns): one per row, in order, as the
    command line's --table."""
    names, raw = _named_columns(table, how)
    cols = [_column(n, v, how + " column") for n, v in zip(names, raw)]
    for n, c in zip(names, cols):
        if c.size != cols[0].size:
            raise ValueError(
                "sweep {}=: column `{}` has {} value(s), `{}` has {}: every column needs one value per "
                "variant".format(how, n, c.size, names[0], cols[0].size)
            )
    if cols[0].size == 0:
        raise ValueError("sweep {}=: the table has no variants (no rows)".format(how))
    _invsim.count_runs([cols[0].size], n_cycles, "a table of {} rows".format(cols[0].size))
    return names, cols


def _check_not_set(base, names, how):
    """A parameter both overridden by `base` and swept is refused, as `--set` with `--grid`/`--table`: the
    sweep's values would silently win over the `base` value."""
    both = next((n for n, _ in base if n in names), None)
    if both is not None:
        raise ValueError(
            "sweep: parameter `{}` is both set (base=) and swept ({}): give one of the two".format(both, how)
        )


def _design(grid, table, params, n_cycles, stacklevel):
    """The sweep's variants as (names, columns) from exactly one of `grid=`, `table=` and the deprecated
    `params=` (the alias of `table=`, refused where it would be read otherwise than a user may mean)."""
    given = [n for n, v in (("grid", grid), ("table", table), ("params", params)) if v is not None]
    if len(given) > 1:
        raise ValueError(
            "sweep: give one of grid= (every combination, as --grid) and table= (one variant per row, as "
            "--table), not {}".format(" and ".join(g + "=" for g in given))
        )
    if not given:
        raise ValueError(
            "sweep needs grid={name: values, ...} (every combination, as --grid) or table= (a DataFrame or a "
            "dict of equal-length columns: one variant per row, as --table)"
        )
    if grid is not None:
        return _grid(grid, n_cycles)
    if table is not None:
        return _table(table, n_cycles)
    names, cols = _table(params, n_cycles, "params")
    if isinstance(params, dict) and len(names) > 1 and cols[0].size > 1:
        n, k = cols[0].size, len(names)
        raise ValueError(
            "sweep(params=...) of {k} parameters with {n} values each is ambiguous: grid= runs every "
            "combination ({p} variants, as the command line's --grid), table= pairs the values row by row "
            "({n} variants, as --table); params= is deprecated".format(k=k, n=n, p=n**k)
        )
    warnings.warn(
        "sweep(params=...) is deprecated: pass table= (one variant per row, what params= did) or grid= "
        "(every combination)",
        DeprecationWarning,
        stacklevel=stacklevel + 1,
    )
    return names, cols


def sweep_frame(param_names, rows, cycles, names, cols, variant_offset=0):
    """The sweep's DataFrame from the extension's rows (one per variant x cycle)."""
    import pandas as pd

    records = []
    for variant, cycle, values, summary, error in rows:
        rec = {"variant": variant + variant_offset, "cycle": cycles[cycle]}
        if values:
            rec.update(zip(param_names, values))
        # The variant's own values: all of them where the parameters could not be set, else those that are no
        # declared parameter (one gear's value of a gearbox parameter, `i_g[3]`).
        rec.update({n: float(c[variant]) for n, c in zip(names, cols) if not values or n not in param_names})
        rec["error"] = error
        if summary is not None:
            rec.update(_flatten(json.loads(summary)))
        records.append(rec)
    df = pd.DataFrame.from_records(records)
    front = ["variant", "cycle"] + list(param_names) + [n for n in names if n not in param_names] + ["error"]
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
        gradient=None,
        strategy=None,
        **strategy_options,
    ):
        """Inverse simulation on `cycle` (a built-in name or a cycle CSV path), like `invsim simulate`:
        `params` overrides parameters (`--set`), `signals` gives the model's `[signals]` (`--signal`: a number,
        a signal file's path, or (times, values)), `initial` start values of internal states (`--initial`),
        `verify` replays the input through the original model. `keep_series=False` computes every sample but
        keeps only the summary. Models with modes: `switching` is "reentry" or "quasi-static" and
        `transition_time` the re-entry's transition time in s (`--switching`, `--transition-time`).
        `gradient` ("all", a parameter's name or a list of names; `--gradient`) differentiates the summary's
        figures exactly with respect to those parameters: `Result.gradient`. Hybrids (a `[hybrid]` table):
        `strategy` is "ecms", "dp" or "rule-based" (`--strategy`) with its options as keywords of the command
        line's names — `equivalence`, `soc_tolerance` (ECMS), `soc_grid`, `split_grid`, `soc_window` (DP),
        `rb_engine_power`, `rb_soc_low`, `rb_charge_power` (the rules) — checked as there; the figures are
        in `Result.hybrid`."""
        strategy = _strategy_dict(strategy, **strategy_options)
        _warn_about_cycle(cycle)
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
            _gradient_list(gradient),
            strategy,
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
        _warn_about_cycle(cycle)
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
        *,
        grid=None,
        table=None,
        strategy=None,
        **strategy_options,
    ):
        """Many variants of the model on every cycle, in parallel (rayon; `threads` = None: all cores), like
        `invsim sweep`. The variants come from exactly one of:

        - `grid={name: values, ...}`: every combination of the values (full factorial), the last name varying
          fastest, as the command line's repeated `--grid` (its `NAME=START:STOP:N` are the values
          `np.linspace(START, STOP, N)`, bit for bit): `grid={"m": [1100, 1300], "C_d": [0.28, 0.32, 0.36]}`
          is 6 variants;
        - `table=`: a DataFrame (pandas or polars) or a dict of equal-length columns, one variant per row in
          the given order, as `--table PARAMS.csv`: `table={"m": [1100, 1300], "C_d": [0.28, 0.32]}` is 2.

        `params=` is the deprecated name of `table=` (a DeprecationWarning); a dict of several parameters with
        several values each is refused there, since it reads as a grid too. Giving none or two of them is a
        ValueError, as are non-finite values, an empty axis or table, and more than `max_sweep_runs`
        (10**6) runs (variants x cycles), as on the command line. `base` overrides parameters of every
        variant (`--set`; a parameter both in `base` and swept is refused), `signals` and `initial` apply to
        every run (as in `simulate`), and so do `strategy` and its options (hybrids, as `--strategy` of the
        command line's sweep: the rows gain the summary's `hybrid.*` keys).

        Returns a pandas DataFrame with one row per variant x cycle, in the command line's order (variant 0
        on each cycle, then variant 1, ...): `variant`, `cycle`, every model parameter, `error` (None, or why
        the run failed: a failing variant never aborts the sweep) and the flattened summary
        (`integrals.fuel`, ...). A row's figures equal those of the single run of its variant bit for bit."""
        if isinstance(cycles, str):
            cycles = [cycles]
        cycles = [str(c) for c in cycles]
        if not cycles:
            raise ValueError("sweep needs a cycle: cycles=[...] is empty")
        strategy = _strategy_dict(strategy, **strategy_options)
        names, cols = _design(grid, table, params, len(cycles), stacklevel=2)
        for cycle in cycles:
            _warn_about_cycle(cycle)
        base = _params_list(base)
        _check_not_set(base, names, "grid=" if grid is not None else "table=")
        param_names, rows = self._m.sweep(
            names,
            cols,
            cycles,
            base,
            float(dt),
            _lookahead(lookahead),
            bool(verify),
            threads,
            _signals_list(signals),
            _initial_list(initial),
            strategy,
        )
        return sweep_frame(param_names, rows, cycles, names, cols)
