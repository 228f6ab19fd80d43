"""Shared fixtures of the Python package's tests: the repository, the command line."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _binary() -> pathlib.Path:
    given = os.environ.get("LATTICESIM_BIN")
    if given:
        return pathlib.Path(given)
    for profile in ("debug", "release"):
        p = ROOT / "target" / profile / "latticesim"
        if p.exists():
            return p
    raise RuntimeError("build the command line first (cargo build) or set LATTICESIM_BIN")


@pytest.fixture(scope="session")
def root() -> pathlib.Path:
    return ROOT


@pytest.fixture(scope="session")
def cli():
    """Runs `latticesim ARGS...` from the repository's root; returns the CompletedProcess."""
    binary = _binary()

    def run(*args, check=True, cwd=ROOT):
        p = subprocess.run(
            [str(binary), *map(str, args)],
            cwd=cwd,
            capture_output=True,
            text=True,
        )
        if check and p.returncode != 0:
            raise AssertionError(f"latticesim {' '.join(map(str, args))}: {p.returncode}\n{p.stderr}")
        return p

    return run


def example_pairs():
    """Every example's rules file with each of its agents files (3D with 3D)."""
    pairs = []
    for d in sorted((ROOT / "examples").iterdir()):
        for agents in sorted(d.glob("agents*.txt")):
            rules = d / ("rules-3d.txt" if agents.name == "agents-3d.txt" and (d / "rules-3d.txt").exists() else "rules.txt")
            pairs.append((rules.relative_to(ROOT), agents.relative_to(ROOT)))
    return pairs
