"""Leader election from Python: one run and its per-step costs, then a sweep over n on a
local Dask cluster, with plots (matplotlib).

    pip install ./python matplotlib "dask[distributed]"
    python examples/python/leader_election.py --out figures

Writes figures/series.png (messages and firings per step of one run) and
figures/sweep.png (steps and messages against n, log-log) and prints the tables.
"""

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")  # files only, no window
import matplotlib.pyplot as plt

import latticesim

HERE = pathlib.Path(__file__).resolve().parent
RULES = HERE.parent / "leader-election" / "rules.txt"
AGENTS = HERE.parent / "leader-election" / "agents-30.txt"


def one_run(out: pathlib.Path) -> None:
    sim = latticesim.Simulation.from_files(RULES, AGENTS)
    report = sim.run()
    print(report)
    leaders = (sim.states == b"LEAD0").sum()
    print(f"{sim.agents} agents, {leaders} leader after {sim.steps} steps")
    series = sim.series()
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(series["step"], series["sent"], label="messages sent")
    ax.plot(series["step"], series["firings"], label="rule firings")
    ax.set_xlabel("step")
    ax.set_ylabel("per step")
    ax.set_title("leader election, 30 agents")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "series.png", dpi=120)
    plt.close(fig)


def sweep(out: pathlib.Path, sizes: list, seeds: int, dask: bool) -> None:
    options = dict(sizes=sizes, seeds=seeds, state="INIT0", ids="C00")
    if dask:
        from dask.distributed import Client, LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster, Client(cluster) as client:
            df = latticesim.sweep(RULES, client=client, **options)
    else:
        df = latticesim.sweep(RULES, **options)
    means = df.groupby("n")[["steps", "sent"]].mean()
    print(means)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for column, label in [("steps", "steps"), ("sent", "messages")]:
        (line,) = ax.loglog(means.index, means[column], "-", label=f"{label} (mean)")
        ax.loglog(df["n"], df[column], "o", alpha=0.4, color=line.get_color())
    ax.set_xlabel("n (agents)")
    ax.set_title("leader election on random polyominoes")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "sweep.png", dpi=120)
    plt.close(fig)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="figures", help="folder of the figures")
    p.add_argument("--sizes", default="10,30,100,300", help="n of the sweep")
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--no-dask", action="store_true", help="sweep on threads, without Dask")
    a = p.parse_args()
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    one_run(out)
    sweep(out, [int(n) for n in a.sizes.split(",")], a.seeds, not a.no_dask)
    print(f"wrote {out / 'series.png'} and {out / 'sweep.png'}")


if __name__ == "__main__":
    main()
