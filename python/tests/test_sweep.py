"""Sweeps: threaded equals the command line, Dask equals threaded, shards merged equal whole."""

import pandas as pd
import pytest

import latticesim
from conftest import ROOT

RULES = ROOT / "examples/leader-election/rules.txt"
ARGS = dict(sizes=[5, 20, 40], seeds=2, state="INIT0", ids="C00")
CLI_ARGS = ["--sizes", "5,20,40", "--seeds", "2", "--state", "INIT0", "--ids", "C00"]


def same(a: pd.DataFrame, b: pd.DataFrame):
    """Equal but for the wall times."""
    a, b = a.drop(columns="wall_time_s"), b.drop(columns="wall_time_s")
    assert list(a.columns) == list(b.columns)
    pd.testing.assert_frame_equal(a.reset_index(drop=True), b.reset_index(drop=True), check_dtype=False)


def test_threaded_sweep_equals_the_command_line(cli, tmp_path):
    out = tmp_path / "sweep.csv"
    cli("sweep", RULES, *CLI_ARGS, "--out", out)
    df = latticesim.sweep(RULES, threads=2, **ARGS)
    same(df, pd.read_csv(out))
    assert list(df.columns[:6]) == ["run", "n", "seed", "input", "steps", "stopped_by"]
    assert "swaps" in df.columns and df.attrs["failures"] == []
    assert df["run"].tolist() == list(range(1, 7))


def test_agents_fn_and_settings_are_those_of_the_command_line(cli, tmp_path):
    def line(n, seed):
        return "".join(f"{x},0 SINIT0\n" for x in range(n))

    df = latticesim.sweep(RULES, sizes=[4, 9], seeds=[7], agents_fn=line, set={"C00": "(id*seed)%n+1"})
    assert df["input"].tolist() == ["agents_fn n=4", "agents_fn n=9"]
    assert df["seed"].tolist() == [7, 7]
    script = tmp_path / "line.py"
    script.write_text("import sys\nn=int(sys.argv[1])\nprint(''.join(f'{x},0 SINIT0\\n' for x in range(n)), end='')\n")
    out = tmp_path / "s.csv"
    cli("sweep", RULES, "--sizes", "4,9", "--seeds", "1", "--agents-cmd", f"python3 {script} {{n}}",
        "--set", "C00=(id*7)%n+1", "--out", out)
    want = pd.read_csv(out)
    cols = [c for c in df.columns if c not in ("input", "seed", "wall_time_s")]
    pd.testing.assert_frame_equal(df[cols], want[cols], check_dtype=False)


def test_failed_runs_are_reported_per_run():
    def sometimes(n, seed):
        if n == 20:
            raise RuntimeError("no agents of 20 today")
        return "".join(f"{x},0 SINIT0 C00 {x + 1}\n" for x in range(n))

    with pytest.warns(latticesim.SweepWarning, match="run 2 .*no agents of 20 today"):
        df = latticesim.sweep(RULES, sizes=[5, 20, 40], seeds=1, agents_fn=sometimes)
    assert df["n"].tolist() == [5, 40]
    assert [f["run"] for f in df.attrs["failures"]] == [2]
    with pytest.raises(RuntimeError, match="1 of 3 runs failed"):
        latticesim.sweep(RULES, sizes=[5, 20, 40], seeds=1, agents_fn=sometimes, errors="raise")


def test_dask_sweep_equals_the_threaded_sweep():
    distributed = pytest.importorskip("dask.distributed")
    threaded = latticesim.sweep(RULES, threads=2, **ARGS)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            on_dask = latticesim.sweep(RULES, client=client, **ARGS)
            # A run whose agents have errors fails alone, named.
            def broken(n, seed):
                return "0,0 SINIT0\n0,0 SINIT0\n" if n == 20 else "".join(f"{x},0 SINIT0 C00 {x + 1}\n" for x in range(n))

            with pytest.warns(latticesim.SweepWarning, match="E402"):
                partial = latticesim.sweep(RULES, sizes=[5, 20], seeds=1, agents_fn=broken, client=client)
    same(on_dask, threaded)
    assert partial["n"].tolist() == [5] and partial.attrs["failures"][0]["run"] == 2


def test_shards_merged_equal_the_whole_sweep(cli, tmp_path):
    whole = tmp_path / "whole.csv"
    cli("sweep", RULES, *CLI_ARGS, "--out", whole)
    parts = []
    for i, ext in [(1, "csv"), (2, "parquet"), (3, "csv")]:
        p = tmp_path / f"part{i}.{ext}"
        cli("sweep", RULES, *CLI_ARGS, "--shard", f"{i}/3", "--out", p)
        parts.append(p)
    # pandas and pyarrow read the parts as they are.
    assert len(pd.read_parquet(parts[1])) == 2
    for out in ("merged.csv", "merged.parquet"):
        merged = tmp_path / out
        cli("merge", *reversed(parts), "--out", merged)
        got = pd.read_parquet(merged) if out.endswith("parquet") else pd.read_csv(merged)
        same(got, pd.read_csv(whole))


def test_ctrl_c_stops_a_threaded_sweep():
    import os
    import signal
    import threading
    import time

    def long_line(n, seed):
        return "".join(f"{x},0 SINIT0 C00 {x + 1}\n" for x in range(n))

    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        latticesim.sweep(RULES, sizes=[3000, 3000], seeds=2, agents_fn=long_line, threads=2)
    timer.join()
    took = time.perf_counter() - start
    assert took < 5, f"the sweep stopped {took:.1f} s after it started"


def test_lint_levels_fail_every_run_when_denied():
    # Walls in a state no rule tests (W603): allowed, the runs go; denied, every run fails.
    def walls(n, seed):
        return "".join(f"{x},0 SXXXX0\n" for x in range(n))

    rules = ROOT / "examples/counting/rules.txt"
    df = latticesim.sweep(rules, sizes=[4], seeds=1, agents_fn=walls, allow=["W603"], errors="raise")
    assert len(df) == 1
    with pytest.raises(RuntimeError, match="W603"):
        latticesim.sweep(rules, sizes=[4], seeds=1, agents_fn=walls, deny=["W603"], errors="raise")
