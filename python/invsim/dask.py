"""A sweep across a Dask cluster, partitioned by variants (see docs/scaling.md).

>>> from distributed import Client, LocalCluster
>>> import invsim, invsim.dask
>>> client = Client(LocalCluster(n_workers=2, processes=True, threads_per_worker=1))
>>> model = invsim.Model("models/si_engine.toml")
>>> df = invsim.dask.sweep(model, grid={"m": [1200.0, 1300.0, 1400.0, 1500.0], "C_d": [0.3, 0.34]},
...                        cycles=["nedc"], npartitions=2, client=client, threads=1)

The variants are those of `Model.sweep` (`grid=` every combination, `table=` one variant per row, checked and
limited the same way). Each partition is one `Model.sweep(table=...)` call on a slice of them, run on a worker
(which runs it on `threads` rayon threads); the model travels once per worker as its file's bytes
(`client.scatter`), so the workers need neither the model file nor a shared file system (cycle files named by
path do need to exist on the workers; the built-in cycles do not). The partitions' rows are concatenated in
variant order: the result equals `model.sweep(grid=..., cycles=...)` (or `table=`) on one machine, row for row.
"""

import numpy as np

from . import _check_not_set, _design, _params_list

__all__ = ["sweep"]


def _part(model, names, cols, offset, cycles, kwargs):
    df = model.sweep(table=dict(zip(names, cols)), cycles=cycles, **kwargs)
    df["variant"] += offset
    return df


def _slices(n, npartitions):
    edges = np.linspace(0, n, max(1, min(npartitions, n)) + 1).round().astype(int)
    return [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def sweep(model, params=None, cycles=("nedc",), npartitions=None, client=None, *, grid=None, table=None, **kwargs):
    """`model.sweep(grid=..., cycles=..., **kwargs)` (or `table=`; `params=` is its deprecated name, as in
    `Model.sweep`) split into `npartitions` slices of the variants (default: two per worker of `client`, else
    4), run on the Dask cluster of `client` (default: the current client, else Dask's default scheduler through
    `dask.delayed`). Returns one pandas DataFrame, variant-major, with `variant` numbered over the whole sweep."""
    import pandas as pd

    if isinstance(cycles, str):
        cycles = [cycles]
    cycles = [str(c) for c in cycles]
    if not cycles:
        raise ValueError("sweep needs a cycle: cycles=[...] is empty")
    names, cols = _design(grid, table, params, len(cycles), stacklevel=2)
    _check_not_set(_params_list(kwargs.get("base")), names, "grid=" if grid is not None else "table=")
    n = len(cols[0])
    if client is None:
        client = _current_client()
    if npartitions is None:
        npartitions = 2 * len(client.scheduler_info()["workers"]) if client is not None else 4
    chunks = [([c[a:b] for c in cols], a) for a, b in _slices(n, npartitions)]
    if client is not None:
        # hash=False: a key of its own for every sweep. With the default (a key from the model's contents), a
        # second sweep of the same model reuses the first one's key, and when the first sweep's future is
        # released the scheduler forgets the data the second one's tasks need ("lost dependencies").
        shared = client.scatter(model, broadcast=True, hash=False)
        futures = [client.submit(_part, shared, names, c, a, cycles, kwargs, pure=False) for c, a in chunks]
        parts = client.gather(futures)
    else:
        import dask

        parts = dask.compute(*[dask.delayed(_part)(model, names, c, a, cycles, kwargs) for c, a in chunks])
    return pd.concat(parts, ignore_index=True)


def _current_client():
    try:
        from distributed import get_client

        return get_client()
    except (ImportError, ValueError):
        return None
