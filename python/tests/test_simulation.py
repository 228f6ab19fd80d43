"""The Simulation class against the command line, and its arrays, GIL and Ctrl-C."""

import json
import os
import signal
import threading
import time

import numpy as np
import pytest

import latticesim
from conftest import ROOT, example_pairs

# How the command line's run went, left out with --no-timing (a Simulation keeps the
# agents in the file's order).
TIMES = ("wall_time_s", "times", "peak_memory_bytes", "agents_in_space_order")
MAX_STEPS = 300


@pytest.mark.parametrize("rules,agents", example_pairs(), ids=lambda p: str(p))
def test_run_equals_the_command_line(rules, agents, cli, tmp_path):
    out, stats = tmp_path / "cli-out.txt", tmp_path / "cli-stats.json"
    cli("run", rules, agents, "--max-steps", MAX_STEPS, "--out", out, "--stats", stats, "--quiet", check=False)
    sim = latticesim.Simulation.from_files(ROOT / rules, ROOT / agents)
    report = sim.run(MAX_STEPS)
    mine = tmp_path / "py-out.txt"
    sim.write(mine)
    assert mine.read_bytes() == out.read_bytes()
    assert sim.to_text().encode() == out.read_bytes()
    want = {k: v for k, v in json.loads(stats.read_text()).items() if k not in TIMES}
    assert sim.stats() == want
    assert report.step == want["steps"] and report.quiescent == want["quiescent"]
    assert report.firings == {f["rule"]: f["firings"] for f in want["firings"]}
    assert (report.moves, report.swaps, report.messages) == (want["moves"], want["swaps"], want["messages"]["sent"])


def test_series_equals_run_series(cli, tmp_path):
    rules, agents = "examples/counting/rules.txt", "examples/counting/agents-40.txt"
    series = tmp_path / "s.csv"
    cli("run", rules, agents, "--series", series, "--no-timing", "--quiet")
    import pandas as pd

    sim = latticesim.Simulation.from_files(ROOT / rules, ROOT / agents)
    sim.run()
    want = pd.read_csv(series)
    got = sim.series()
    assert list(got.columns) == list(want.columns)
    pd.testing.assert_frame_equal(got, want, check_dtype=False)
    # Its sums are the run's totals.
    assert got["moves"].sum() == sim.stats()["moves"]


def test_step_reports_add_up_to_a_run():
    sim = latticesim.Simulation.from_files(ROOT / "examples/gravity/rules.txt", ROOT / "examples/gravity/agents.txt")
    whole = latticesim.Simulation.from_files(ROOT / "examples/gravity/rules.txt", ROOT / "examples/gravity/agents.txt").run()
    moves, steps = 0, 0
    while True:
        r = sim.step()
        moves, steps = moves + r.moves, steps + r.steps
        if r.quiescent:
            break
    assert (moves, steps) == (whole.moves, whole.steps)
    assert sim.step(5).steps == 0, "a quiescent run takes no more steps"
    assert "Report(steps=" in repr(whole)


def test_a_report_keeps_its_first_records_and_counts_all():
    # 2,000 divisions by zero a step, 60 steps: 120,000 records, of which a report keeps
    # the first 100,000 (steps 1 to 50); the others are counted, and a later report keeps
    # its own.
    rules = "d\n1\nS*****\nC00 / C00 0000\n"
    agents = "".join(f"{x},{y}\n" for y in range(20) for x in range(100))
    sim = latticesim.Simulation.from_text(rules, agents)
    r = sim.run(60)
    assert r.record_count == 120_000
    assert len(r.records) == 100_000
    assert (r.records[0].step, r.records[-1].step) == (1, 50)
    assert [a[0] for a in r.records[0].agents] == [0]
    assert str(r.records[-1]) == "error[division-by-zero] step 50: agent 1999, rule `d`: division by zero; the target is unchanged"
    assert sim.stats()["records"]["by_kind"]["division-by-zero"] == 120_000
    assert sim.series()["records"].sum() == 120_000
    r = sim.step(2)
    assert (r.record_count, len(r.records)) == (4_000, 4_000)
    assert (r.records[0].step, r.records[-1].step) == (61, 62)


def test_arrays_view_the_engine_and_follow_each_step():
    sim = latticesim.Simulation.from_files(ROOT / "examples/gravity/rules.txt", ROOT / "examples/gravity/agents.txt")
    pos, states, attach = sim.positions, sim.states, sim.attachments
    assert pos.shape == (sim.agents, 2) and pos.dtype == np.int32
    assert states.dtype == np.dtype("S5") and attach.dtype == np.uint8
    for a in (pos, states, attach):
        assert not a.flags.writeable, "views of the engine are read-only"
        assert a.base is sim, "the array keeps the simulation alive"
    with pytest.raises(ValueError):
        pos[0, 0] = 7
    seen_move = False
    for _ in range(40):
        before = pos.copy()
        r = sim.step()
        df = sim.to_pandas()
        # The same arrays, taken before the step, show the state after it.
        assert (pos[:, 0] == df["x"].to_numpy()).all() and (pos[:, 1] == df["y"].to_numpy()).all()
        assert [s.decode() for s in states] == list(df["state"])
        assert (attach == df["attach"].to_numpy()).all()
        seen_move |= r.moves > 0 and (before != pos).any()
        if r.quiescent:
            break
    assert seen_move, "gravity moves agents: the view must have seen it"


def test_counters_inboxes_and_tables():
    sim = latticesim.Simulation.from_files(ROOT / "examples/leader-election/rules.txt", ROOT / "examples/leader-election/agents-30.txt")
    c00 = sim.counter("C00")
    assert c00.base is sim and not c00.flags.writeable
    sim.step(3)
    assert sim.counter_names == ["C00", "C01"]
    assert sim.counters.shape == (30, 2)
    assert (sim.counters[:, 0] == c00).all(), "the view follows the steps"
    assert (sim.counter("C05") == 0).all(), "a counter without a column reads 0"
    with pytest.raises(KeyError):
        sim.counter("C99")
    assert sim.inbox.shape == (30, 4, len(sim.inbox_slots)) and sim.inbox_slots == [1]
    assert sim.text_inbox.shape == (30, 4)
    df = sim.to_pandas()
    assert list(df.columns) == ["x", "y", "state", "attach", "C00", "C01"]
    table = sim.to_arrow()
    assert table.num_rows == 30 and table.column_names == list(df.columns)


def test_counters_of_32_bits_are_int32():
    # The rules file chooses 32-bit counters (`// latticesim: counters 32`): ids past 32767.
    rules = (ROOT / "examples/leader-election/rules.txt").read_text()
    agents = "".join(f"{i},0 SINIT0 C00 {40000 + i}\n" for i in range(10))
    sim = latticesim.Simulation.from_text(rules, agents)
    assert sim.counter("C00").dtype == np.int32 and sim.counters.dtype == np.int32
    sim.run()
    assert (sim.counter("C01") == 40009).all()
    assert sim.inbox.dtype == np.int32
    assert sim.to_pandas()["C00"].max() == 40009
    # Without the directive, the paper's 16 bits: the agents file is refused, by name.
    with pytest.raises(ValueError, match="counters 32"):
        latticesim.Simulation.from_text(rules.replace("// latticesim: counters 32", ""), agents)
    small = latticesim.Simulation.from_files(ROOT / "examples/counting/rules.txt", ROOT / "examples/counting/agents-40.txt")
    assert small.counters.dtype == np.int16


def test_three_d_positions_have_three_columns():
    sim = latticesim.Simulation.from_files(ROOT / "examples/leader-election/rules-3d.txt", ROOT / "examples/leader-election/agents-3d.txt")
    assert sim.dim == 3 and sim.positions.shape == (sim.agents, 3)
    assert sim.to_pandas().columns[:3].tolist() == ["x", "y", "z"]


def long_simulation():
    """A run of many steps: leader election on a line of 1,500 agents (steps ~ n)."""
    agents = "".join(f"{x},0 SINIT0 C00 {x + 1}\n" for x in range(1500))
    rules = (ROOT / "examples/leader-election/rules.txt").read_text()
    return latticesim.Simulation.from_text(rules, agents, series=False)


def test_run_releases_the_gil():
    sim = long_simulation()
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    start = time.perf_counter()
    sim.run(100_000)
    took = time.perf_counter() - start
    done.set()
    t.join()
    during = [x for x in ticks if start <= x <= start + took]
    assert took > 0.2, f"the run must take a while to show it ({took:.3f} s)"
    assert len(during) > 20, f"{len(during)} ticks of another thread in a {took:.2f} s run"


def test_ctrl_c_stops_after_the_step(cli, tmp_path):
    sim = long_simulation()
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        sim.run(1_000_000)
    timer.join()
    steps = sim.steps
    assert 0 < steps and not sim.quiescent
    assert sim.stats()["stopped_by"] == "interrupted"
    # The state is that of a whole step: the command line's after as many steps.
    agents = tmp_path / "agents.txt"
    agents.write_text("".join(f"{x},0 SINIT0 C00 {x + 1}\n" for x in range(1500)))
    out = tmp_path / "out.txt"
    cli("run", "examples/leader-election/rules.txt", agents, "--max-steps", steps, "--out", out, "--quiet")
    assert sim.to_text() == out.read_text()
    sim.run(5)  # it goes on where it stopped
    assert sim.steps == steps + 5


def test_bad_files_raise_with_every_diagnostic(cli, tmp_path):
    rules = (ROOT / "examples/leader-election/rules.txt").read_text() + "\nbroken\nx\nSINIT0\nSLEAD0\n\nfixable\nl\nSINIT0\nSLEAD0\n"
    agents = "0,0 SINIT0\n0,0 SINIT0\n"
    with pytest.raises(latticesim.CheckError) as info:
        latticesim.Simulation.from_text(rules, agents, rules_name="le.txt", agents_name="a.txt")
    e = info.value
    assert {d.file for d in e.diagnostics} == {"le.txt", "a.txt"}, e.diagnostics
    for d in e.diagnostics:
        assert d.code[0] in "EW" and d.code[1:].isdigit()
        assert d.severity in ("error", "warning")
        assert d.line >= 1 and d.column >= 1
        assert d.end_line >= d.line and d.message
        assert d.labels[0]["primary"] and d.labels[0]["file"] == d.file
        assert str(d).startswith(f"{d.file}:{d.line}:{d.column}: {d.severity}[{d.code}]")
    # Rendered as `latticesim check` renders it, with the same diagnostics as its JSON.
    (tmp_path / "le.txt").write_text(rules)
    (tmp_path / "a.txt").write_text(agents)
    p = cli("check", "le.txt", "--agents", "a.txt", "--color", "never", check=False, cwd=tmp_path)
    assert p.returncode == 1
    assert str(e) in p.stderr
    p = cli("check", "le.txt", "--agents", "a.txt", "--format", "json", check=False, cwd=tmp_path)
    want = json.loads(p.stdout)["diagnostics"]
    assert [(d.code, d.line, d.column, d.message) for d in e.diagnostics] == [
        (d["code"], d["line"], d["column"], d["message"]) for d in want
    ]
    # The fixes too: `l` for the priority 1.
    assert [d.fixes for d in e.diagnostics] == [d["fixes"] for d in want]
    assert any(f["edits"][0]["replacement"] == "1" for d in e.diagnostics for f in d.fixes)


def test_warnings_are_python_warnings():
    rules = (ROOT / "examples/counting/rules.txt").read_text()
    with pytest.warns(latticesim.CheckWarning, match="W603"):
        sim = latticesim.Simulation.from_text(rules, "0,0 SXXXX0\n")
    assert [d.code for d in sim.warnings] == ["W603"]


def test_repr_counts_in_words():
    one = latticesim.Simulation.from_text("fall\n1\nN***0\nP0,-1\n", "0,0\n")
    assert ": 1 agent, 2D, 1 rule, step 0" in repr(one), repr(one)
    two = latticesim.Simulation.from_text(
        "fall\n1\nN***0\nP0,-1\n\nrest\n2\nN***1\nC00 + C00 0001\n", "0,0\n0,1\n"
    )
    assert ": 2 agents, 2D, 2 rules, step 0" in repr(two), repr(two)


def test_lint_levels_and_counters_as_keywords():
    rules = (ROOT / "examples/counting/rules.txt").read_text()
    # As --allow: no warning; as --deny: an error; a bad code: ValueError.
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = latticesim.Simulation.from_text(rules, "0,0 SXXXX0\n", allow=["W603"])
    assert sim.warnings == []
    with pytest.raises(latticesim.CheckError, match="W603"):
        latticesim.Simulation.from_text(rules, "0,0 SXXXX0\n", deny=["warnings"])
    with pytest.raises(ValueError, match="W999"):
        latticesim.Simulation.from_text(rules, "0,0 SXXXX0\n", allow=["W999"])
    # As --counters: a counter past 16 bits is an error without it.
    plain = "walk\n1\nSWALK0 >C01 0000\nC01 - C01 0001\n"
    agents = "0,0 SWALK0 C01 40000\n"
    with pytest.raises(latticesim.CheckError, match="E404"):
        latticesim.Simulation.from_text(plain, agents)
    sim = latticesim.Simulation.from_text(plain, agents, counters=32)
    sim.run()
    assert sim.counter("C01").dtype == np.int32 and sim.counter("C01")[0] == 0
    with pytest.raises(ValueError, match="counters=8"):
        latticesim.Simulation.from_text(plain, agents, counters=8)


def test_missing_files_and_bad_options_raise():
    with pytest.raises(OSError, match="nothing.txt"):
        latticesim.Simulation.from_files(ROOT / "examples/tour/rules.txt", "nothing.txt")
    with pytest.raises(ValueError, match="order"):
        latticesim.Simulation.from_files(ROOT / "examples/tour/rules.txt", ROOT / "examples/tour/agents.txt", order="sideways")


def test_checkpoint_and_resume(cli, tmp_path):
    rules, agents = ROOT / "examples/reconfigure-line/rules.txt", ROOT / "examples/reconfigure-line/agents-30.txt"
    straight = latticesim.Simulation.from_files(rules, agents)
    straight.run()
    sim = latticesim.Simulation.from_files(rules, agents)
    sim.step(7)
    ck = tmp_path / "ck.zst"
    sim.checkpoint(ck)
    again = latticesim.Simulation.resume(rules, ck)
    assert again.steps == 7
    again.run()
    assert again.to_text() == straight.to_text()
    assert again.stats() == straight.stats()
    # The command line resumes it too.
    out = tmp_path / "out.txt"
    cli("run", rules, "--resume", ck, "--out", out, "--quiet")
    assert out.read_text() == straight.to_text()
    with pytest.raises(ValueError, match="cannot resume"):
        latticesim.Simulation.resume(ROOT / "examples/counting/rules.txt", ck)


def test_help_reads_well():
    import pydoc

    text = pydoc.render_doc(latticesim.Simulation, renderer=pydoc.plaintext)
    for word in ("from_files", "from_text", "resume", "positions", "series", "checkpoint", "Ctrl-C", "CheckError"):
        assert word in text, word
    assert latticesim.__version__


def test_no_agents_is_an_empty_configuration():
    rules = (ROOT / "examples/leader-election/rules.txt").read_text()
    sim = latticesim.Simulation.from_text(rules, "")
    assert sim.agents == 0 and sim.positions.shape == (0, 2) and sim.states.shape == (0,)
    assert sim.to_pandas().shape[0] == 0 and sim.to_text() == ""
    assert sim.run().quiescent
