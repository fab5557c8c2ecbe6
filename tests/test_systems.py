"""Systems under test: the life cycle the runner drives, proven by ticking with a small recording system."""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys
from typing import Any

import py_trees
import pytest
from helpers import case, crit, entry
from py_trees.common import Status

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.run import Collector, run, run_tree
from btgen_pytrees.systems import SystemFailure, SystemInfo, SystemSpec
from btgen_pytrees.systems.simulated import SimulatedSystem


class Counter:
    """A system that owns signal ``n`` (its tick count) and logs every life-cycle call."""

    def __init__(self, tick: float, fail_at: str | None = None, fail_tick: int = 3):
        self.log: list[str] = []
        self.k, self.step, self.fail_at, self.fail_tick = 0, tick, fail_at, fail_tick

    def start(self, env: Any) -> None:
        self.log.append("start")
        if self.fail_at == "start":
            raise SystemFailure("cannot start")

    def now(self) -> float:
        return round(self.k * self.step, 9)

    def publish(self, env: Any) -> None:
        self.log.append(f"publish {self.k}")
        if self.fail_at == "publish" and self.k == self.fail_tick:
            raise SystemFailure("lost the connection")
        env.publish("n", self.k)

    def tick(self) -> None:
        self.log.append(f"tick {self.k}")
        if self.fail_at == "tick" and self.k == self.fail_tick:
            raise SystemFailure("the simulator ended early")
        if self.fail_at == "tick-bug" and self.k == self.fail_tick:
            raise ZeroDivisionError("division by zero")
        if self.fail_at == "tick-interrupt" and self.k == self.fail_tick:
            raise KeyboardInterrupt
        self.k += 1

    def close(self) -> None:
        self.log.append("close")
        if self.fail_at == "close":
            raise OSError("port 8813 still in use")


class CounterType:
    name = "counter"
    options = ("--fast",)

    def describe(self, spec: SystemSpec, case_data: Any) -> SystemInfo:
        return SystemInfo(signals=("n",))

    def create(self, spec: SystemSpec, case: Any) -> Counter:
        return Counter(case.tick)


class Boom(py_trees.behaviour.Behaviour):
    """``counter.boom {error}``: raises on its first tick (a SystemFailure, a KeyboardInterrupt or a ValueError)."""

    def __init__(self, entry: Any, env: Any):
        super().__init__(name=entry.name)
        self.env, self.error = env, entry.params.get("error", "value")

    def update(self) -> Status:
        assert isinstance(self.env.system, Counter)  # the running system is reachable from a leaf
        if self.error == "system":
            raise SystemFailure("vehicle 'ego' is gone")
        if self.error == "interrupt":
            raise KeyboardInterrupt
        if self.error == "bare":
            raise ValueError  # no message
        raise ValueError("bad value")


def registry() -> Any:
    r = default_registry()
    r.register_system(CounterType())
    r.register("counter.boom", Boom, description="raise")
    return r


def one_run(data: dict[str, Any], **system_kw: Any) -> tuple[Any, Counter]:
    reg = registry()
    loaded = btgen_pytrees.load(data, registry=reg, system=SystemSpec("counter"))
    system = Counter(loaded.tick, **system_kw)
    root = btgen_pytrees.generate(loaded, registry=reg)
    return run_tree(root, loaded, system=system), system


# -- the life cycle ------------------------------------------------------------------


def test_life_cycle_order_and_the_systems_time_is_the_runs_clock() -> None:
    report, system = one_run(case(entry("H", duration=0.2), criteria=[crit("F", "final", "n == 2")]))
    assert report.verdict == "pass", report.table()
    assert system.log == ["start", "publish 0", "tick 0", "publish 1", "tick 1", "publish 2", "close"]
    assert report.oracles[0].values == {"n": 2} and report.duration == 0.2 and report.ticks == 3


@pytest.mark.parametrize(
    "data, kw, verdict, message",
    [
        (case(entry("H", duration=0.2)), {}, "pass", ""),
        (case(entry("H", duration=0.2), criteria=[crit("R", "record", "n < 1")]), {}, "fail", "R failed"),
        (case(entry("H", duration=5), timeout=0.3), {}, "timeout", "no verdict after 0.3 s"),
        (case(entry("B", action="counter.boom")), {}, "error", "B raised ValueError: bad value"),
        (case(entry("B", action="counter.boom", error="bare")), {}, "error", "B raised ValueError"),
        (case(entry("B", action="counter.boom", error="system")), {}, "error", "B: vehicle 'ego' is gone"),
        (case(entry("H", duration=1)), {"fail_at": "start"}, "error", "cannot start"),
        (case(entry("H", duration=1)), {"fail_at": "publish"}, "error", "lost the connection"),
        (case(entry("H", duration=1)), {"fail_at": "tick"}, "error", "the simulator ended early"),
        (case(entry("H", duration=1)), {"fail_at": "tick-bug"}, "error", "the 'counter' system raised ZeroDivisionError: division by zero"),
        (case(entry("H", duration=0.2)), {"fail_at": "close"}, "error", "closing the system failed: the 'counter' system raised OSError: port 8813 still in use"),
    ],
)
def test_close_on_every_ending(data: dict[str, Any], kw: dict[str, Any], verdict: str, message: str) -> None:
    report, system = one_run(data, **kw)
    assert (report.verdict, report.message) == (verdict, message)
    assert system.log[-1] == "close" and system.log.count("close") == 1
    assert report.ticks == sum(1 for line in system.log if line.startswith("publish")) - (kw.get("fail_at") == "publish")


@pytest.mark.usefixtures("pythons_ctrl_c")  # a plain KeyboardInterrupt is Ctrl-C only under Python's own handler
def test_close_on_keyboard_interrupt_and_the_interrupt_goes_on() -> None:
    reg = registry()
    loaded = btgen_pytrees.load(case(entry("H", duration=0.1), entry("B", ["H"], action="counter.boom", error="interrupt"),
                                     system={"type": "counter"}), registry=reg)  # fmt: skip
    system = Counter(loaded.tick)
    root = btgen_pytrees.generate(loaded, registry=reg)
    with pytest.raises(KeyboardInterrupt):
        run_tree(root, loaded, system=system)
    assert system.log[-1] == "close" and root.status == Status.INVALID
    assert root.btgen_env.system is None  # the environment is given back as it was


@pytest.mark.usefixtures("pythons_ctrl_c")
def test_close_when_the_system_itself_is_interrupted() -> None:
    reg = registry()
    loaded = btgen_pytrees.load(case(entry("H", duration=1)), registry=reg)
    system = Counter(loaded.tick, fail_at="tick-interrupt")
    root = btgen_pytrees.generate(loaded, registry=reg)
    with pytest.raises(KeyboardInterrupt):
        run_tree(root, loaded, system=system)
    assert system.log[-1] == "close" and system.log.count("close") == 1 and root.status == Status.INVALID


@pytest.mark.usefixtures("sigint_ignored")
@pytest.mark.parametrize("data, kw, message", [
    (case(entry("H", duration=0.1), entry("B", ["H"], action="counter.boom", error="interrupt")), {}, "B raised KeyboardInterrupt"),
    (case(entry("H", duration=1)), {"fail_at": "tick-interrupt"}, "the 'counter' system raised KeyboardInterrupt"),
])  # fmt: skip
def test_where_no_ctrl_c_can_come_a_plain_keyboard_interrupt_is_the_runs_error(data: dict[str, Any], kw: dict[str, Any],
                                                                               message: str) -> None:  # fmt: skip
    """SIGINT ignored (a host started under nohup or in a script's background): no Ctrl-C can reach the
    process, so a plain KeyboardInterrupt comes from the leaf or system that raised it - that run's error."""
    report, system = one_run(data, **kw)
    assert (report.verdict, report.message) == ("error", message)
    assert system.log[-1] == "close" and system.log.count("close") == 1


def test_the_ctrl_c_tests_hold_when_pytest_starts_with_sigint_ignored() -> None:
    """This file's tests pass however pytest was started, run here with SIGINT ignored.

    A Python started with SIGINT ignored (``nohup``, or ``cmd &`` in a script: the shell ignores
    SIGINT for it) keeps it ignored and installs no Ctrl-C handler, so there a plain KeyboardInterrupt
    is the run's error (the test above); a test that expects one to go on through a run asks for
    Python's own handler (the ``pythons_ctrl_c`` fixture)."""
    ignoring = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                "os.execv(sys.executable, [sys.executable, '-m', 'pytest', *sys.argv[1:]])")  # SIG_IGN survives exec
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    env["PYTHONPATH"] = str(ROOT)  # this checkout, whatever the venv's install points at
    done = subprocess.run([sys.executable, "-c", ignoring, "-q", str(pathlib.Path(__file__).resolve()),
                           "-k", "not test_the_ctrl_c_tests_hold_when_pytest_starts_with_sigint_ignored"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
    assert " passed" in done.stdout and "failed" not in done.stdout


def test_a_system_type_that_cannot_create_gives_verdict_error() -> None:
    class Refusing(CounterType):
        def create(self, spec: SystemSpec, case: Any) -> Counter:
            raise SystemFailure("sumo binary not found")

    reg = registry()
    reg.register_system(Refusing(), replace=True)
    report = run(btgen_pytrees.load(case(entry("H"), system=COUNTER), registry=reg), registry=reg)
    assert (report.verdict, report.message, report.ticks) == ("error", "sumo binary not found", 0)


def test_simulated_system_is_the_default_and_keeps_todays_clock() -> None:
    system = SimulatedSystem(0.1)
    system.start(None)
    seen = []
    for _ in range(31):
        seen.append(system.now())
        system.tick()
    assert seen == [round(k * 0.1, 9) for k in range(31)] and seen[3] == 0.3
    reg = default_registry()
    assert reg.system("simulated") is not None and "simulated" in reg.systems()
    assert btgen_pytrees.load(case(entry("A"))).system == SystemSpec("simulated", None, ())


def test_registering_a_system_twice_needs_replace() -> None:
    reg = registry()
    with pytest.raises(ValueError, match="already registered"):
        reg.register_system(CounterType())
    reg.register_system(CounterType(), replace=True)
    assert reg.copy().system("counter") is not None


def test_dotted_signal_names_are_stored_as_written() -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(case(entry("A"))))
    root.btgen_env.write("ego.speed", 3.5)
    assert root.btgen_env.read("ego.speed") == 3.5 and root.btgen_env.values(["ego.speed"]) == {"ego.speed": 3.5}


# -- host-ticked trees: the Collector --------------------------------------------------


def host_ticked(loaded: Any, *, stop_early: int | None = None) -> tuple[Collector, Any]:
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    tree = py_trees.trees.BehaviourTree(root)
    collector = Collector(root)
    tree.add_visitor(collector)
    tree.add_visitor(py_trees.visitors.SnapshotVisitor())
    tree.setup()
    for k in range(1000):
        clock.set(round(k * loaded.tick, 9))
        tree.tick()
        if root.status != Status.RUNNING or k == stop_early:
            break
    return collector, root


@pytest.mark.parametrize("name", ["fig1.json", "fig1_failing.json"])
def test_host_ticked_tree_reports_exactly_what_run_reports(name: str, fig1_path: str) -> None:
    loaded = btgen_pytrees.load(fig1_path.replace("fig1.json", name))
    collector, _ = host_ticked(loaded)
    expected = run(loaded)
    report = collector.report()
    assert report.to_json() == expected.to_json()
    assert report.table() == expected.table() and report.to_junit() == expected.to_junit()
    assert collector.report().to_json() == expected.to_json()  # asking again changes nothing


def test_collector_mid_run_says_running_and_a_rerun_starts_a_new_report(fig1_path: str) -> None:
    loaded = btgen_pytrees.load(fig1_path)
    collector, root = host_ticked(loaded, stop_early=10)
    mid = collector.report()
    assert (mid.verdict, mid.ticks, mid.duration) == ("running", 11, 1.0)
    assert json.loads(mid.to_json())["verdict"] == "running"
    statuses = {e.id: e.status for e in mid.execute}
    assert statuses["B2"] == "running" and statuses["B4"] == "not-started"
    # the host stops the tree and runs it again from the start: the collector follows
    root.stop(Status.INVALID)
    tree = py_trees.trees.BehaviourTree(root)
    tree.add_visitor(collector)
    clock = root.btgen_env.clock
    for k in range(100):
        clock.set(round(k * loaded.tick, 9))
        tree.tick()
        if root.status != Status.RUNNING:
            break
    assert collector.report().to_json() == run(loaded).to_json()
    assert mid.execute[2].id == "B2" and mid.execute[2].status == "running"  # an earlier report is not changed afterwards


# -- the 'system' key, owned signals, the initial-signal rule ------------------------------


def problems(data: dict[str, Any], **kw: Any) -> list[str]:
    with pytest.raises(btgen_pytrees.InvalidTestCase) as info:
        btgen_pytrees.load(data, registry=registry(), **kw)
    return [f"{p.pointer}: {p.message}" for p in info.value.problems]


COUNTER = {"type": "counter"}


def test_system_key_is_checked_with_json_paths() -> None:
    assert problems(case(entry("A"), system={"type": "countr"})) == [
        "/system/type: unknown system 'countr' (did you mean 'counter'?); installed: counter, simulated, sumo "
        "(a plugin may add it: --plugin MODULE or FILE.py)"]  # fmt: skip
    assert problems(case(entry("A"), system={"type": "counter", "option": []})) == [
        "/system/option: unknown key 'option' (did you mean 'options'?)"]  # fmt: skip
    assert problems(case(entry("A"), system={"type": "counter", "options": ["--fast", "1", "--output", "x", "/etc/passwd"]})) == [
        "/system/options/2: option '--output' is not allowed for the 'counter' system (allowed: --fast)",
        "/system/options/4: '/etc/passwd' is not an option (options start with '-', each followed by at most one value)"]  # fmt: skip
    assert problems(case(entry("A"), system={"type": "simulated", "config": "x.cfg"})) == [
        "/system/config: the simulated system takes no config file"]  # fmt: skip
    loaded = btgen_pytrees.load(case(entry("A"), system={"type": "counter", "options": ["--fast=1"]}), registry=registry())
    assert loaded.system == SystemSpec("counter", None, ("--fast=1",))


def test_config_is_resolved_relative_to_the_case_file(tmp_path: Any) -> None:
    path = tmp_path / "sub" / "case.json"
    path.parent.mkdir()
    path.write_text(json.dumps(case(entry("A"), system={"type": "counter", "config": "../scenario/x.cfg"})))
    assert btgen_pytrees.load(path, registry=registry()).system.config == str(tmp_path / "scenario" / "x.cfg")


def test_expression_names_are_checked_against_the_systems_signals() -> None:
    data = case(entry("A"), system=COUNTER, criteria=[crit("F", "final", "n >= 0 && m.x > 1")])
    assert problems(data) == ["/oracle/criteria/0/expect: unknown signal 'm.x' in 'n >= 0 && m.x > 1'"]
    data = case(entry("A"), system=COUNTER, signals={"v": 0}, criteria=[crit("F", "final", "v + nn > 1")])
    assert problems(data) == ["/oracle/criteria/0/expect: unknown signal 'nn' in 'v + nn > 1' (did you mean 'n'?)"]


def test_signals_a_system_owns_are_read_only_for_set_and_ramp() -> None:
    data = case(entry("S", action="set", signal="n", value=3), entry("R", action="ramp", signal="n", to=1, duration=1),
                system=COUNTER)  # fmt: skip
    assert problems(data) == [
        "/execute/0/params/signal: signal 'n' belongs to the 'counter' system and is read-only for the test; "
        "use an action of the 'counter' system to change it",
        "/execute/1/params/signal: signal 'n' belongs to the 'counter' system and is read-only for the test; "
        "use an action of the 'counter' system to change it"]  # fmt: skip

    class Named(CounterType):
        def describe(self, spec: SystemSpec, case_data: Any) -> SystemInfo:
            return SystemInfo(signals=("n",), writers={"n": "counter.set"})

    reg = registry()
    reg.register_system(Named(), replace=True)
    with pytest.raises(btgen_pytrees.InvalidTestCase, match="use the action 'counter.set' instead"):
        btgen_pytrees.load(case(entry("S", action="set", signal="n", value=3), system=COUNTER), registry=reg)


def test_describe_that_raises_is_a_problem_not_a_traceback() -> None:
    class Broken(CounterType):
        def describe(self, spec: SystemSpec, case_data: Any) -> SystemInfo:
            raise RuntimeError("oops")

    reg = registry()
    reg.register_system(Broken(), replace=True)
    with pytest.raises(btgen_pytrees.InvalidTestCase, match="/system: system 'counter' could not check the case: RuntimeError: oops"):
        btgen_pytrees.load(case(entry("A"), system=COUNTER), registry=reg)


def test_a_case_naming_a_system_runs_against_it() -> None:
    reg = registry()
    loaded = btgen_pytrees.load(case(entry("H", duration=0.2), system=COUNTER, criteria=[crit("F", "final", "n == 2")]), registry=reg)
    report = run(loaded, registry=reg)
    assert (report.verdict, report.oracles[0].values) == ("pass", {"n": 2})


def test_initial_signals_never_overwrite_a_hosts_value_and_a_rerun_starts_clean() -> None:
    data = case(entry("S", action="set", signal="speed", value=70, duration=0.2), entry("H", ["S"], duration=0.1),
                signals={"speed": 50, "brake": 0}, criteria=[crit("F", "final", "speed == 70")])  # fmt: skip
    loaded = btgen_pytrees.load(data)
    clock = VirtualClock()
    root = btgen_pytrees.generate(loaded, clock=clock)
    env = root.btgen_env
    env.write("speed", 30)  # the host, before the first tick
    seen = []
    for k in range(2):
        clock.set(k * 0.1)
        root.tick_once()
        seen.append(env.read("speed"))
    assert seen == [70, 70] and env.read("brake") == 0  # the set leaf wrote 70; brake got its initial value
    env.write("brake", 1)
    root.stop(Status.INVALID)
    root.tick_once()  # a re-run: what the test wrote is forgotten, the initial values apply again
    assert env.read("brake") == 0

    first = btgen_pytrees.generate(btgen_pytrees.load(case(entry("H"), signals={"speed": 50})), clock=VirtualClock())
    first.btgen_env.write("speed", 30)
    first.tick_once()
    assert first.btgen_env.read("speed") == 30  # write 30 before the first tick, read back 30 (not 50)
    first.stop(Status.INVALID)
    first.tick_once()
    assert first.btgen_env.read("speed") == 30  # the host's value, not the test's: kept on a re-run
    second = btgen_pytrees.generate(btgen_pytrees.load(case(entry("H"), signals={"speed": 50})), clock=VirtualClock())
    second.tick_once()
    second.btgen_env.write("speed", 40)
    second.stop(Status.INVALID)
    second.tick_once()
    assert second.btgen_env.read("speed") == 50  # written during a run: a re-run starts clean
    second.btgen_env.publish("speed", 45)  # a system's (or host's) value between runs is kept
    second.stop(Status.INVALID)
    second.tick_once()
    assert second.btgen_env.read("speed") == 45


def test_a_systems_published_value_wins_over_the_initial_value() -> None:
    reg = registry()
    loaded = btgen_pytrees.load(case(entry("H", duration=0.1), system=COUNTER, signals={"n": 99},
                                     criteria=[crit("F", "final", "n == 1")]), registry=reg)  # fmt: skip
    assert run(loaded, registry=reg).verdict == "pass"


# -- plugins by file path and --system, through the CLI -------------------------------------

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent

PLUGIN = '''
import os
from btgen_pytrees.errors import Problem
from btgen_pytrees.systems import SystemInfo
from helper_module import STEP  # a neighbour of this file: its directory is importable while it loads


class Clock:
    def __init__(self, tick):
        self.k, self.tick_s = 0, tick
    def start(self, env):
        pass
    def now(self):
        return round(self.k * self.tick_s, 9)
    def publish(self, env):
        env.publish("clock.k", self.k * STEP)
    def tick(self):
        self.k += 1
    def close(self):
        pass


class ClockType:
    name = "clock"
    options = ()
    def describe(self, spec, case_data):
        if spec.config is not None and not os.path.isfile(spec.config):
            return SystemInfo(problems=(Problem(("system", "config"), f"no such file: {spec.config}", "system"),))
        return SystemInfo(signals=("clock.k",))
    def create(self, spec, case):
        return Clock(case.tick)


def register(registry):
    registry.register_system(ClockType())
'''


def cli(*args: str, cwd: Any = ROOT) -> Any:
    import subprocess
    import sys

    env = {k: v for k, v in __import__("os").environ.items() if k != "PYTHONPATH"}
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True, timeout=120, cwd=cwd, env=env)


@pytest.fixture
def clock_plugin(tmp_path: Any) -> Any:
    (tmp_path / "plugins").mkdir()
    (tmp_path / "plugins" / "clock_system.py").write_text(PLUGIN)
    (tmp_path / "plugins" / "helper_module.py").write_text("STEP = 2\n")
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "clock.cfg").write_text("")
    data = case(entry("H", duration=0.3), name="clocked", system={"type": "clock", "config": "clock.cfg"},
                criteria=[crit("F", "final", "clock.k == 6")])  # fmt: skip
    (tmp_path / "cases" / "clocked.json").write_text(json.dumps(data))
    return tmp_path


def test_plugin_by_file_path_from_the_repository_root() -> None:
    result = cli("run", "examples/host_app/pick.json", "--plugin", "examples/host_app/robot.py")
    assert result.returncode == 0 and "pick: PASS" in result.stdout, result.stderr
    missing = cli("run", "examples/host_app/pick.json", "--plugin", "examples/host_app/nope.py")
    assert missing.returncode == 2 and "plugin 'examples/host_app/nope.py': no such file" in missing.stderr


def test_a_third_party_system_from_a_plugin_file_and_the_system_override(clock_plugin: Any) -> None:
    plugin = str(clock_plugin / "plugins" / "clock_system.py")
    ok = cli("run", "cases/clocked.json", "--plugin", plugin, cwd=clock_plugin)
    assert ok.returncode == 0 and "clocked: PASS after 0.3 s" in ok.stdout, ok.stderr + ok.stdout
    # the case names a system nobody installed: the error says where systems come from
    no_plugin = cli("run", "cases/clocked.json", cwd=clock_plugin)
    assert no_plugin.returncode == 2 and "cases/clocked.json: /system/type: unknown system 'clock'; installed: simulated, sumo " \
        "(a plugin may add it: --plugin MODULE or FILE.py)" in no_plugin.stderr  # fmt: skip
    # --system replaces the case's system: the simulated one does not own clock.k
    simulated = cli("run", "cases/clocked.json", "--plugin", plugin, "--system", "simulated", cwd=clock_plugin)
    assert simulated.returncode == 2 and "/oracle/criteria/0/expect: unknown signal 'clock.k'" in simulated.stderr
    # --system TYPE:CONFIG resolves CONFIG against the current directory, not the case file's
    wrong = cli("run", "cases/clocked.json", "--plugin", plugin, "--system", "clock:clock.cfg", cwd=clock_plugin)
    assert wrong.returncode == 2 and f"no such file: {clock_plugin / 'clock.cfg'}" in wrong.stderr
    right = cli("run", "cases/clocked.json", "--plugin", plugin, "--system", "clock:cases/clock.cfg", cwd=clock_plugin)
    assert right.returncode == 0, right.stderr


def test_module_plugin_imports_from_the_current_directory_and_puts_sys_path_back(clock_plugin: Any, monkeypatch: Any) -> None:
    import sys

    monkeypatch.chdir(clock_plugin / "plugins")
    before = list(sys.path)
    reg = default_registry(["clock_system"])
    assert reg.system("clock") is not None and sys.path == before
    unknown = btgen_pytrees.InvalidTestCase
    with pytest.raises(unknown, match=r"unknown behavior action 'clock.wind'; known: hold, profile, ramp, set \(a plugin may add it"):
        btgen_pytrees.load(case(entry("W", action="clock.wind")), registry=reg)
    with pytest.raises(unknown, match=r"'sumx.speed'; known: hold, profile, ramp, set \(system 'sumx' is not installed; installed: clock, simulated, sumo; a plugin"):
        btgen_pytrees.load(case(entry("W", action="sumx.speed")), registry=reg)
