"""One clock per run, read once per tick: the system's time is every time of the run (docs/systems.md).

* a tree ticked by a host reads its clock once per tick, so every leaf, oracle
  and report time of one tick is the same time, even with a clock that moves
  while the tick runs (the default wall clock);
* the runner reads ``system.now()`` once per tick and that is the run's time; a
  system whose ``now()`` is not a finite number or goes back in time ends the
  run with verdict ``error`` naming the system and what it returned.

The SUMO side of the same rule (SUMO's own time is the run's clock, ticks SUMO
cannot step are refused at load) is in tests/test_sumo.py.
"""

from __future__ import annotations

import json
import math
import pathlib
import subprocess
import sys
from typing import Any

import py_trees
import pytest
from helpers import case, crit, entry
from py_trees.common import Status

import btgen_pytrees
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.run import Collector, run
from btgen_pytrees.systems import SystemInfo

ROOT = pathlib.Path(__file__).resolve().parent.parent


class Moving:
    """A clock the host sets before each tick that also moves on by 2**-16 s at every read (as a wall clock does)."""

    def __init__(self) -> None:
        self.base, self.reads, self.per_tick = 0.0, 0, 0

    def set(self, base: float) -> None:
        self.base, self.per_tick = base, 0

    def now(self) -> float:
        self.reads += 1
        self.per_tick += 1
        return self.base + self.per_tick * 2**-16


def test_a_host_ticked_tree_reads_its_clock_once_per_tick_and_every_leaf_of_a_tick_sees_that_time() -> None:
    loaded = btgen_pytrees.load(ROOT / "examples" / "fig1.json")
    clock = Moving()
    root = btgen_pytrees.generate(loaded, clock=clock)
    tree = py_trees.trees.BehaviourTree(root)
    collector = Collector(root, record=True)
    tree.add_visitor(collector)
    tree.setup()
    for k in range(100):
        clock.set(k * loaded.tick)
        tree.tick()
        if root.status != Status.RUNNING:
            break
    report = collector.report()
    assert report.verdict == "pass"
    assert clock.reads == report.ticks == 31  # one read per tick, none in between
    r1, p1, f1 = report.oracles
    assert r1.at == p1.at == report.duration == report.trace.times[-1]  # the last tick: one time for all
    assert f1.at == 2.0 and {e.end for e in report.execute if e.id in ("B3", "B4")} == {1.5}  # exact: one read
    expected = run(loaded)
    assert [o.at for o in report.oracles] == pytest.approx([o.at for o in expected.oracles], abs=1e-9)
    assert report.trace.times == pytest.approx(expected.trace.times, abs=1e-9)


def test_between_ticks_the_time_is_the_last_tick_s() -> None:
    clock = Moving()
    root = btgen_pytrees.generate(btgen_pytrees.load(case(entry("H", duration=1))), clock=clock)
    root.setup_with_descendants()
    clock.set(0.0)
    root.tick_once()
    clock.set(0.5)
    root.tick_once()
    env = root.btgen_env
    reads = clock.reads
    assert env.now() == env.now() == 0.5  # read when the tick began, not again
    assert clock.reads == reads


# -- systems that break the clock's contract ------------------------------------------------------


class Drifting:
    """A system owning ``n``; its ``now()`` follows the list *times* (then keeps its last value)."""

    def __init__(self, times: list[Any]):
        self.times, self.k = times, 0

    def start(self, env: Any) -> None:
        pass

    def now(self) -> Any:
        return self.times[min(self.k, len(self.times) - 1)]

    def publish(self, env: Any) -> None:
        env.publish("n", self.k)

    def tick(self) -> None:
        self.k += 1

    def close(self) -> None:
        pass


class DriftingType:
    name = "drifting"
    options = ()

    def __init__(self, times: list[Any]):
        self.times = times

    def describe(self, spec: Any, case_data: Any) -> SystemInfo:
        return SystemInfo(signals=("n",))

    def create(self, spec: Any, case: Any) -> Drifting:
        return Drifting(self.times)


def drifting_run(times: list[Any]) -> Any:
    registry = default_registry()
    registry.register_system(DriftingType(times))
    data = case(entry("W", action="wait", duration=1), criteria=[crit("R", "record", "n >= 0")],
                system={"type": "drifting"}, tick=0.1, timeout=5)  # fmt: skip
    return run(btgen_pytrees.load(data, registry=registry), registry=registry)


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        (math.nan, "the 'drifting' system's now() returned nan, not a finite number of seconds"),
        (math.inf, "the 'drifting' system's now() returned inf, not a finite number of seconds"),
        ("0.3", "the 'drifting' system's now() returned '0.3', not a finite number of seconds"),
        (None, "the 'drifting' system's now() returned None, not a finite number of seconds"),
        (True, "the 'drifting' system's now() returned True, not a finite number of seconds"),
        (0.1, "the 'drifting' system's time ran backwards: now() returned 0.1 after 0.2 (a system's time never decreases)"),
    ],
)
def test_a_system_whose_time_is_not_a_number_or_runs_backwards_ends_the_run_with_an_error(bad: Any, message: str) -> None:
    report = drifting_run([0.0, 0.1, 0.2, bad])
    assert (report.verdict, report.message) == ("error", message)
    assert report.ticks == 3 and report.duration == 0.2  # the ticks before it, at the times the system gave
    json.loads(report.to_json())


def test_the_run_s_times_are_the_system_s_own_times() -> None:
    """A system whose steps are not ``k * tick``: every time in the report is the time it said."""
    times = [round(0.13 * k, 9) for k in range(40)]
    report = drifting_run(times)
    assert report.verdict == "pass"
    (w,) = report.execute
    assert (w.start, w.end) == (0.0, 1.04)  # the first of its times at least 1 s after the start
    assert report.trace.times == times[: report.ticks]


PLUGIN = '''
import math
from btgen_pytrees.systems import SystemInfo

class Broken:
    def __init__(self):
        self.k = 0
    def start(self, env):
        pass
    def now(self):
        return self.k * 0.1 if self.k < 3 else math.nan
    def publish(self, env):
        env.publish("n", self.k)
    def tick(self):
        self.k += 1
    def close(self):
        pass

class BrokenType:
    name = "broken"
    options = ()
    def describe(self, spec, case_data):
        return SystemInfo(signals=("n",))
    def create(self, spec, case):
        return Broken()

def register(registry):
    registry.register_system(BrokenType())
'''


def test_a_system_with_a_nan_clock_gives_an_error_verdict_and_a_valid_json_report(tmp_path: pathlib.Path) -> None:
    (tmp_path / "broken.py").write_text(PLUGIN, encoding="utf-8")
    data = case(entry("W", action="wait", duration=1), criteria=[crit("R", "record", "n >= 0")],
                system={"type": "broken"}, tick=0.1, timeout=5)  # fmt: skip
    (tmp_path / "t.json").write_text(json.dumps(data), encoding="utf-8")
    result = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", "t.json", "--plugin", "broken.py",
                             "--json", "out.json"], capture_output=True, text=True, cwd=tmp_path, timeout=120,
                            check=False)  # fmt: skip
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr and "nan s" not in result.stdout
    assert "t: ERROR after 0.2 s (3 ticks) - the 'broken' system's now() returned nan" in result.stdout
    report = json.loads((tmp_path / "out.json").read_text(encoding="utf-8"))
    assert report["verdict"] == "error"
    assert report["message"] == "the 'broken' system's now() returned nan, not a finite number of seconds"
