"""latticesim: synchronized distributed algorithms on 2D square and 3D cubic lattice agents.

The engine of the ``latticesim`` command line, for scripts::

    import latticesim

    sim = latticesim.Simulation.from_files("rules.txt", "agents.txt")
    report = sim.run()              # to quiescence (GIL released, Ctrl-C stops it)
    sim.positions, sim.states       # NumPy arrays on the engine's memory
    sim.series()                    # per-step costs, a pandas DataFrame
    latticesim.sweep("rules.txt", sizes=[10, 100], seeds=3, state="INIT0")

Bad rules or agents raise :class:`CheckError`, which carries every diagnostic.
"""

from __future__ import annotations

from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union
import os
import uuid
import warnings

from ._latticesim import (
    CheckError,
    CheckWarning,
    Diagnostic,
    Record,
    Report,
    Simulation,
    __version__,
    sweep_runs as _sweep_runs,
)

__all__ = [
    "CheckError",
    "CheckWarning",
    "Diagnostic",
    "Record",
    "Report",
    "Simulation",
    "SweepWarning",
    "sweep",
    "__version__",
]


class SweepWarning(UserWarning):
    """Some runs of a sweep failed; ``df.attrs["failures"]`` lists them."""


def _runs(sizes: Sequence[int], seeds: Union[int, Iterable[int]]) -> list:
    """The runs of a sweep in the command line's order: (run number, n, seed)."""
    seed_list = list(range(1, seeds + 1)) if isinstance(seeds, int) else list(seeds)
    out = []
    for n in sizes:
        for s in seed_list:
            out.append((len(out) + 1, int(n), int(s)))
    return out


def _settings(set: Union[Mapping[str, str], Iterable[str], None]) -> list:
    """``{"C00": "id+1"}`` or ``["C00=id+1"]`` as the command line's ``--set`` strings."""
    if set is None:
        return []
    if isinstance(set, Mapping):
        return [f"{k}={v}" for k, v in set.items()]
    return [str(s) for s in set]


def _frame(parts: list, failures: list, errors: str):
    """The sweep's DataFrame from the column dicts of its parts, rows in run order."""
    import pandas as pd

    frames = [pd.DataFrame(cols) for cols in parts if len(next(iter(cols.values()), []))]
    if frames:
        df = pd.concat(frames, ignore_index=True).sort_values("run", kind="stable")
        df = df.reset_index(drop=True)
    else:
        df = pd.DataFrame({"run": pd.Series([], dtype="int64")})
    failures = sorted(failures)
    df.attrs["failures"] = [
        {"run": r, "n": n, "seed": s, "error": e} for (r, n, s, e) in failures
    ]
    if failures:
        text = "; ".join(f"run {r} (n={n}, seed {s}): {e}" for (r, n, s, e) in failures)
        message = f"{len(failures)} of {len(failures) + len(df)} runs failed: {text}"
        if errors == "raise":
            raise RuntimeError(message)
        warnings.warn(message, SweepWarning, stacklevel=3)
    return df


def sweep(
    rules: Union[str, os.PathLike],
    sizes: Sequence[int] = (10, 30, 100, 300, 1000),
    seeds: Union[int, Iterable[int]] = 3,
    shape: str = "connected",
    agents_fn: Optional[Callable[[int, int], str]] = None,
    *,
    dim: int = 2,
    state: Optional[str] = None,
    first_state: Optional[str] = None,
    first_east: bool = False,
    ids: Optional[str] = None,
    universe: bool = False,
    fill_holes: bool = False,
    set: Union[Mapping[str, str], Iterable[str], None] = None,
    max_steps: int = 100_000,
    order: str = "actions-first",
    static_first: bool = False,
    threads: Optional[int] = None,
    client: Any = None,
    errors: str = "warn",
    allow: Sequence[str] = (),
    warn: Sequence[str] = (),
    deny: Sequence[str] = (),
    counters: Optional[int] = None,
):
    """Run ``rules`` over agents of growing size n, several seeds each, and return a
    pandas DataFrame with a row per run and the columns of ``latticesim sweep``: run, n,
    seed, input, steps, stopped_by, firings, firings:RULE..., executing, moves, carried,
    swaps, sent, delivered, dropped, records, records:KIND..., wall_time_s.

    The agents of a run are a generated ``shape`` ("line", "block" or "connected") of
    about n agents in ``dim`` dimensions (with ``state``, ``first_state``,
    ``first_east``, ``ids``, ``universe``, ``fill_holes`` as ``latticesim gen`` takes
    them), or the text returned by ``agents_fn(n, seed)``. ``set`` sets counters from
    expressions (``{"C00": "id+1"}``, as ``--set``). ``seeds`` is K (seeds 1..K) or a list.
    ``allow``, ``warn`` and ``deny`` (lists of codes, names or ``"warnings"``) and
    ``counters`` (16 or 32) are ``--allow``, ``--warn``, ``--deny`` and ``--counters``: a
    denied warning fails every run.

    The runs go on ``threads`` Rust threads (default: all cores), or, with ``client`` (a
    ``dask.distributed.Client``), one Dask task per run, gathered into one DataFrame
    equal to the threaded one but for wall_time_s. A run that fails is left out and named
    in ``df.attrs["failures"]`` and a :class:`SweepWarning` (``errors="raise"``: a
    RuntimeError instead).
    """
    if errors not in ("warn", "raise"):
        raise ValueError('errors must be "warn" or "raise"')
    path = os.fspath(rules)
    with open(path, "rb") as f:
        rules_bytes = f.read()
    runs = _runs(sizes, seeds)
    options = dict(
        shape=shape,
        agents_fn=agents_fn,
        dim=dim,
        state=state,
        first_state=first_state,
        first_east=first_east,
        ids=ids,
        universe=universe,
        fill_holes=fill_holes,
        set=_settings(set),
        max_steps=max_steps,
        order=order,
        static_first=static_first,
        allow=list(allow),
        warn=list(warn),
        deny=list(deny),
        counters=counters,
    )
    if client is None:
        cols, failures = _sweep_runs(rules_bytes, path, runs, threads=threads, **options)
        return _frame([cols], failures, errors)
    sweep_id = uuid.uuid4().hex[:12]
    futures = [
        client.submit(
            _one_run, rules_bytes, path, run, options, key=f"latticesim-{sweep_id}-run-{run[0]}"
        )
        for run in runs
    ]
    parts, failures = [], []
    for run, fut in zip(runs, futures):
        try:
            cols, failed = fut.result()
        except Exception as e:  # a worker lost, or the task itself raised
            failures.append((run[0], run[1], run[2], f"{type(e).__name__}: {e}"))
            continue
        parts.append(cols)
        failures.extend(failed)
    return _frame(parts, failures, errors)


def _one_run(rules: bytes, path: str, run: tuple, options: dict):
    """One run of a sweep on a Dask worker (one thread: Dask gives the parallelism)."""
    from latticesim._latticesim import sweep_runs

    return sweep_runs(rules, path, [tuple(run)], threads=1, **options)
