"""The examples of docs/python.md, the example script and the notebook, run as a user would."""

import json
import os
import re
import subprocess
import sys

import pytest

from conftest import ROOT


@pytest.fixture
def in_a_copy(tmp_path, monkeypatch):
    """A folder where `examples/` is the repository's, and outputs land apart."""
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_the_examples_of_docs_python_md_run(in_a_copy):
    text = (ROOT / "docs/python.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 8
    namespace = {"__name__": "docs_python"}
    for i, code in enumerate(blocks):
        if _starts_processes(code):
            continue  # run as a script below
        try:
            exec(compile(code, f"docs/python.md block {i + 1}", "exec"), namespace)
        except Exception as e:  # name the block
            raise AssertionError(f"block {i + 1} of docs/python.md:\n{code}") from e
    assert (in_a_copy / "gravity-out.txt").exists() and (in_a_copy / "reconfigure.ck.zst").exists()


def _starts_processes(code: str) -> bool:
    return "LocalCluster" in code or "multiprocessing" in code or "subprocess" in code


def test_the_examples_that_start_processes_run_as_scripts(in_a_copy):
    # Their workers import the script again: run as a user runs them, each block a file.
    text = (ROOT / "docs/python.md").read_text()
    blocks = [b for b in re.findall(r"```python\n(.*?)```", text, re.S) if _starts_processes(b)]
    assert blocks, "the Dask example"
    for i, code in enumerate(blocks):
        script = in_a_copy / f"example_{i}.py"
        script.write_text(code)
        p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, f"{code}\n{p.stderr[-3000:]}"
        assert p.stdout.strip(), code


def test_the_example_script_runs(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "figs"
    p = subprocess.run(
        [sys.executable, str(ROOT / "examples/python/leader_election.py"), "--out", str(out), "--sizes", "10,30", "--seeds", "2"],
        capture_output=True, text=True,
    )
    assert p.returncode == 0, p.stderr
    assert "1 leader after 9 steps" in p.stdout
    for f in ("series.png", "sweep.png"):
        assert (out / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_notebook_runs(monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(ROOT / "examples/python")
    nb = json.loads((ROOT / "examples/python/leader_election.ipynb").read_text())
    namespace = {"__name__": "notebook"}
    for cell in nb["cells"]:
        if cell["cell_type"] == "code":
            exec("".join(cell["source"]), namespace)
    assert namespace["report"].quiescent
    assert list(namespace["means"].index) == [10, 30, 100]
