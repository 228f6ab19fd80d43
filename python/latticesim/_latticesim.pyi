"""Type stubs of latticesim's Rust extension (see docs/python.md)."""

import os
from typing import Any, Callable, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, os.PathLike[str]]

__version__: str

class CheckError(ValueError):
    """The rules or agents have errors; ``str(e)`` renders them as ``latticesim check``."""

    diagnostics: list[Diagnostic]

class CheckWarning(UserWarning):
    """Warnings of the checker about files that were loaded all the same."""

class Diagnostic:
    """One problem in the rules or agents file, as ``check --format json`` gives it."""

    code: str
    severity: str
    message: str
    file: str
    line: int
    column: int
    end_line: int
    end_column: int
    help: Optional[str]
    labels: list[dict[str, Any]]
    fixes: list[dict[str, Any]]

class Record:
    """Something that happened in a step: a conflict, a blocked move, a saturation..."""

    step: int
    kind: str
    severity: str
    agents: list[tuple[int, list[int]]]
    message: str

class Report:
    """What one call of ``step`` or ``run`` did, summed over its steps."""

    steps: int
    step: int
    firings: dict[str, int]
    executing: int
    moves: int
    carried: int
    swaps: int
    messages: int
    delivered: int
    dropped: int
    records: list[Record]
    record_count: int
    quiescent: bool
    stopped_by: str
    @property
    def total_firings(self) -> int: ...

class Simulation:
    """Rules running on agents, in lock-step, as ``latticesim run`` runs them."""

    @staticmethod
    def from_files(
        rules: _Path,
        agents: _Path,
        *,
        order: str = "actions-first",
        static_first: bool = False,
        threads: Optional[int] = None,
        series: bool = True,
        allow: Sequence[str] = (),
        warn: Sequence[str] = (),
        deny: Sequence[str] = (),
        counters: Optional[int] = None,
    ) -> Simulation: ...
    @staticmethod
    def from_text(
        rules_text: str,
        agents_text: str,
        *,
        rules_name: str = "rules.txt",
        agents_name: str = "agents.txt",
        order: str = "actions-first",
        static_first: bool = False,
        threads: Optional[int] = None,
        series: bool = True,
        allow: Sequence[str] = (),
        warn: Sequence[str] = (),
        deny: Sequence[str] = (),
        counters: Optional[int] = None,
    ) -> Simulation: ...
    @staticmethod
    def resume(
        rules: _Path,
        checkpoint: _Path,
        *,
        order: str = "actions-first",
        static_first: bool = False,
        threads: Optional[int] = None,
        series: bool = True,
        allow: Sequence[str] = (),
        warn: Sequence[str] = (),
        deny: Sequence[str] = (),
        counters: Optional[int] = None,
    ) -> Simulation: ...
    def step(self, n: int = 1) -> Report: ...
    def run(self, max_steps: int = 100_000) -> Report: ...
    @property
    def steps(self) -> int: ...
    @property
    def quiescent(self) -> bool: ...
    @property
    def agents(self) -> int: ...
    @property
    def dim(self) -> int: ...
    @property
    def rules(self) -> list[str]: ...
    @property
    def warnings(self) -> list[Diagnostic]: ...
    @property
    def positions(self) -> npt.NDArray[np.int32]: ...
    @property
    def states(self) -> npt.NDArray[np.bytes_]: ...
    @property
    def attachments(self) -> npt.NDArray[np.uint8]: ...
    @property
    def counter_names(self) -> list[str]: ...
    @property
    def counters(self) -> npt.NDArray[np.int16]: ...
    def counter(self, name: str) -> npt.NDArray[np.int16]: ...
    @property
    def inbox_slots(self) -> list[int]: ...
    @property
    def inbox(self) -> npt.NDArray[np.int16]: ...
    @property
    def text_inbox(self) -> npt.NDArray[np.bytes_]: ...
    def to_text(self) -> str: ...
    def write(self, path: _Path) -> None: ...
    def checkpoint(self, path: _Path) -> None: ...
    def stats(self) -> dict[str, Any]: ...
    def series_columns(self) -> dict[str, npt.NDArray[np.int64]]: ...
    def series(self) -> Any: ...
    def to_pandas(self) -> Any: ...
    def to_arrow(self) -> Any: ...

def sweep_runs(
    rules: bytes,
    rules_name: str,
    runs: list[tuple[int, int, int]],
    *,
    shape: str = "connected",
    agents_fn: Optional[Callable[[int, int], str]] = None,
    dim: int = 2,
    state: Optional[str] = None,
    first_state: Optional[str] = None,
    first_east: bool = False,
    ids: Optional[str] = None,
    universe: bool = False,
    fill_holes: bool = False,
    set: list[str] = ...,
    max_steps: int = 100_000,
    order: str = "actions-first",
    static_first: bool = False,
    threads: Optional[int] = None,
    allow: Sequence[str] = (),
    warn: Sequence[str] = (),
    deny: Sequence[str] = (),
    counters: Optional[int] = None,
) -> tuple[dict[str, Any], list[tuple[int, int, int, str]]]: ...
