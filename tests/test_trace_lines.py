"""``run --trace`` prints every start, finish, stop and the end, to the nanosecond (issue 10, defect 10)."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys
from typing import Any

from helpers import case, crit, entry


def trace(tmp_path: pathlib.Path, data: dict[str, Any]) -> list[str]:
    path = tmp_path / "case.json"
    path.write_text(json.dumps(data))
    result = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", str(path), "--trace"], capture_output=True, text=True)
    return result.stderr.splitlines()


def test_stopped_entries_and_the_end_are_traced(tmp_path: pathlib.Path) -> None:
    data = case(entry("A", duration=3), entry("B", ["A"]), entry("Q", duration=0), criteria=[crit("F", "final", "true", at=0.25)])
    assert trace(tmp_path, data) == [
        "           0  start    A",
        "           0  start    Q",
        "           0  success  Q",
        "         0.3  stopped  A",
        "         0.3  end      pass",
    ]


def test_a_timeout_leaves_entries_running_and_failures_carry_their_message(tmp_path: pathlib.Path) -> None:
    assert trace(tmp_path, case(entry("A", duration=9), timeout=0.2))[-2:] == ["         0.2  running  A", "         0.2  end      timeout"]
    lines = trace(tmp_path, case(entry("U", action="until", expect="x > 1", timeout=0.1), signals={"x": 0}))
    assert lines == ["           0  start    U", "         0.1  failure  U  x > 1 still false after 0.1 s (x=0)",
                     "         0.1  end      fail"]  # fmt: skip


def test_times_keep_every_decimal_of_the_tick(tmp_path: pathlib.Path) -> None:
    data = case(entry("A", duration=0.004), entry("B", ["A"], duration=0.0005), tick=0.0001, timeout=1)
    assert trace(tmp_path, data) == [
        "           0  start    A",
        "       0.004  success  A",
        "       0.004  start    B",
        "      0.0045  success  B",
        "      0.0045  end      pass",
    ]
