"""A long single run shows progress on a terminal, and only there (issue 23 item 11).

The CLI runs in a real pseudo-terminal (``pty``: stderr is a TTY, as in an
interactive shell): the line ``long: t = … / 2000 s · tick … · … ticks/s``
appears while the run goes on and is erased before the table. On a pipe, or
with ``CI`` set, stderr gets nothing. The run (200,000 ticks) must last well over the half second
before the line first shows: 30,000 ticks did once, but took 0.34 s once ticks got faster (about 2 s now).
"""

from __future__ import annotations

import io
import json
import os
import pathlib
import pty
import re
import subprocess
import sys

import pytest

from btgen_pytrees.progress import Progress, terminal_progress

ROOT = pathlib.Path(__file__).resolve().parent.parent
LONG = {"name": "long", "tick": 0.01, "timeout": 2000,
        "execute": [{"id": "B1", "kind": "behavior", "action": "hold", "params": {"duration": 10000}}]}  # fmt: skip


def _run(path: pathlib.Path, *, tty: bool, ci: bool) -> tuple[int, str, bytes]:
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    env["PYTHONPATH"] = str(ROOT)
    if ci:
        env["CI"] = "true"
    command = [sys.executable, "-m", "btgen_pytrees", "run", str(path)]
    if not tty:
        done = subprocess.run(command, capture_output=True, env=env, timeout=300, check=False)
        return done.returncode, done.stdout.decode(), done.stderr
    leader, follower = pty.openpty()
    try:
        child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=follower, stdin=subprocess.DEVNULL, env=env)
        os.close(follower)
        err = b""
        while True:
            try:
                chunk = os.read(leader, 4096)
            except OSError:  # the child closed its end
                break
            if not chunk:
                break
            err += chunk
        out = child.stdout.read().decode()  # type: ignore[union-attr]
        return child.wait(timeout=300), out, err
    finally:
        os.close(leader)


@pytest.fixture(scope="module")
def long_case(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    path = tmp_path_factory.mktemp("progress") / "long.json"
    path.write_text(json.dumps(LONG), encoding="utf-8")
    return path


def test_a_terminal_sees_progress_then_a_clean_line(long_case: pathlib.Path) -> None:
    code, out, err = _run(long_case, tty=True, ci=False)
    assert code == 1 and "long: TIMEOUT after 2000 s (200001 ticks)" in out
    text = err.decode("utf-8")
    lines = re.findall(r"\rlong: t = ([\d.]+) / 2000 s \u00b7 tick ([\d,]+) \u00b7 ([\d,]+) ticks/s\x1b\[K", text)
    assert lines, repr(text[:300])
    for now, ticks, rate in lines:
        assert float(now) == pytest.approx((int(ticks.replace(",", "")) - 1) * 0.01, abs=0.051)  # tick k at (k-1)·tick
        assert int(rate.replace(",", "")) > 0
    assert text.endswith("\r\x1b[K")  # erased before the table


@pytest.mark.parametrize("ci", [False, True])
def test_a_pipe_or_ci_sees_nothing(long_case: pathlib.Path, ci: bool) -> None:
    code, out, err = _run(long_case, tty=False, ci=ci)
    assert code == 1 and err == b""  # stderr is a pipe here (and CI is set in one case): no line at all


def test_ci_on_a_terminal_sees_nothing_either(long_case: pathlib.Path) -> None:
    code, _, err = _run(long_case, tty=True, ci=True)
    assert code == 1 and err == b""


def test_the_line_waits_half_a_second_and_updates_four_times_a_second() -> None:
    wall = [0.0]
    stream = io.StringIO()
    progress = Progress("x", 10, stream, clock=lambda: wall[0])
    progress(1, 0.0)
    assert stream.getvalue() == ""  # a short run shows nothing
    wall[0] = 0.5
    progress(100, 0.99)
    assert stream.getvalue() == "\rx: t = 1.0 / 10 s \u00b7 tick 100 \u00b7 200 ticks/s\x1b[K"
    wall[0] = 0.6
    progress(120, 1.19)
    assert stream.getvalue().count("\r") == 1  # not again within a quarter second
    progress.done()
    assert stream.getvalue().endswith("\r\x1b[K")
    assert terminal_progress("x", 1, io.StringIO()) is None  # not a terminal
