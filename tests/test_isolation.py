"""Batch isolation (issue 13, class 1): user code that dies, exits or raises costs only its own file.

A plugin here registers one misbehaving action per way user code can go wrong:
killing its process (``os._exit``, SIGKILL as the out-of-memory killer does),
raising ``SystemExit``/``KeyboardInterrupt`` (from a leaf, a factory, ``setup()``
or ``terminate()``), or returning a non-Behaviour from its factory. Each is run
in a batch next to good files; every other file must still be processed and
reported, and the CLI's exit code must say something went wrong. Ctrl-C and
SIGTERM stop a batch quickly, leave no worker process and no temporary file.
"""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time
import uuid

import pytest
from helpers import case, entry

ROOT = pathlib.Path(__file__).resolve().parent.parent

PLUGIN = '''
import os, signal, time
import py_trees
from py_trees.common import Status

MODE = os.environ.get("KILLER_AT_IMPORT")
if MODE == "exit0":
    raise SystemExit(0)


class Leaf(py_trees.behaviour.Behaviour):
    def __init__(self, entry, env):
        super().__init__(name=entry.name)
        self.how = entry.action

    def setup(self, **kwargs):
        if self.how == "bad_setup":
            raise SystemExit(0)

    def update(self):
        how = self.how
        if how == "die":
            os._exit(0)
        if how == "sigkill":
            os.kill(os.getpid(), signal.SIGKILL)
        if how == "sysexit":
            raise SystemExit(0)
        if how == "kbint":
            raise KeyboardInterrupt
        if how == "none":
            return None
        if how == "block":  # a run that cannot end by itself: says it is running, then waits for a signal
            ready = os.environ.get("KILLER_READY")
            if ready:
                open(os.path.join(ready, str(os.getpid())), "w").close()
            time.sleep(3600)
            return Status.RUNNING
        if how == "bad_terminate":
            return Status.RUNNING
        return Status.SUCCESS

    def terminate(self, new_status):
        if self.how == "bad_terminate":
            raise SystemExit(3)


def factory(entry, env):
    if entry.action == "raising_factory":
        raise SystemExit(0)
    if entry.action == "bad_factory":
        return 42
    return Leaf(entry, env)


ACTIONS = ("die", "sigkill", "sysexit", "kbint", "bad_setup", "bad_terminate", "raising_factory", "bad_factory",
           "block", "ok", "none")


def register(registry):
    if os.environ.get("KILLER_AT_IMPORT") == "register":
        raise SystemExit(0)
    for action in ACTIONS:
        registry.register(action, factory, kind="behavior")
'''

BAD = ("die", "sigkill", "sysexit", "kbint", "bad_setup", "bad_terminate", "raising_factory", "bad_factory")


@pytest.fixture
def plugin_env(tmp_path: pathlib.Path) -> dict[str, str]:
    (tmp_path / "killer_plugin.py").write_text(PLUGIN)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT)]), BTGEN_TEST_MARK=uuid.uuid4().hex)
    env.pop("KILLER_AT_IMPORT", None)
    return env


def cli(env: dict[str, str], *args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=ROOT, env=env)  # fmt: skip


def one(action: str, **top: object) -> dict[str, object]:
    return case(entry("A", action=action), name=action, timeout=top.pop("timeout", 1), **top)


def marked_processes(mark: str) -> list[int]:
    """Pids of live processes whose environment carries *mark* (our workers, if any survived)."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/environ", "rb") as fh:
                if f"BTGEN_TEST_MARK={mark}".encode() in fh.read():
                    with open(f"/proc/{pid}/stat") as st:
                        if st.read().split(")")[-1].split()[0] != "Z":
                            found.append(int(pid))
        except OSError:
            continue
    return found


def test_every_bad_file_is_its_own_error_and_the_others_are_reported(tmp_path: pathlib.Path, plugin_env: dict[str, str]) -> None:
    cases = tmp_path / "cases"
    cases.mkdir()
    for action in BAD:
        (cases / f"{action}.json").write_text(json.dumps(one(action)))
    for i in range(4):
        (cases / f"good{i}.json").write_text(json.dumps(one("ok")))
    shutil.copy(ROOT / "examples" / "fig1.json", cases / "zz_fig1.json")
    out = tmp_path / "out"
    result = cli(plugin_env, "run", str(cases), "--plugin", "killer_plugin", "-j", "2", "--out-dir", str(out))
    assert "Traceback" not in result.stderr and "BrokenProcessPool" not in result.stderr, result.stderr
    rows = {pathlib.Path(line.split()[0]).stem: line for line in result.stdout.splitlines() if line.startswith(str(cases))}
    assert set(rows) == {*BAD, "good0", "good1", "good2", "good3", "zz_fig1"}, result.stdout
    for name in ("good0", "good1", "good2", "good3", "zz_fig1"):
        assert rows[name].split()[1] == "ok", rows[name]
        assert (out / f"{name}.report.json").exists()
    for name in BAD:
        assert rows[name].split()[1] in ("ERROR", "INVALID"), rows[name]
    assert "exited with status 0" in rows["die"] and "SIGKILL" in rows["sigkill"]
    assert "SystemExit" in rows["sysexit"] and "KeyboardInterrupt" in rows["kbint"]
    assert "setup()" in rows["bad_setup"] and "terminate()" in rows["bad_terminate"]
    assert "returned int" in rows["bad_factory"] and "SystemExit" in rows["raising_factory"]
    assert "13 files: 5 ok, 8 error" in result.stdout
    assert result.returncode >= 1
    assert not marked_processes(plugin_env["BTGEN_TEST_MARK"])


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_dying_worker_with_one_job_still_costs_one_file(tmp_path: pathlib.Path, plugin_env: dict[str, str], jobs: str) -> None:
    cases = tmp_path / "cases"
    cases.mkdir()
    (cases / "a.json").write_text(json.dumps(one("ok")))
    (cases / "b.json").write_text(json.dumps(one("die")))
    (cases / "c.json").write_text(json.dumps(one("ok")))
    result = cli(plugin_env, "validate", str(cases), "--plugin", "killer_plugin", "-j", jobs)
    assert result.returncode == 0  # validation runs no leaf
    result = cli(plugin_env, "run", str(cases), "--plugin", "killer_plugin", "-j", jobs)
    assert result.returncode == 1, result.stderr
    assert "3 files: 2 ok, 1 error" in result.stdout


@pytest.mark.parametrize("action", ["sysexit", "kbint", "bad_setup", "bad_terminate", "raising_factory", "bad_factory"])
def test_single_file_user_code_is_the_runs_error_not_the_clis_exit(tmp_path: pathlib.Path, plugin_env: dict[str, str], action: str) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps(one(action)))
    report = tmp_path / "r.json"
    result = cli(plugin_env, "run", str(path), "--plugin", "killer_plugin", "--json", str(report))
    assert result.returncode == 1, (result.returncode, result.stdout, result.stderr)
    assert json.loads(report.read_text())["verdict"] == "error"
    assert "ERROR" in result.stdout and "Traceback" not in result.stderr
    shown = cli(plugin_env, "show", str(path), "--plugin", "killer_plugin")
    assert shown.returncode != 0 or action in ("sysexit", "kbint", "bad_setup", "bad_terminate")


@pytest.mark.parametrize("where", ["exit0", "register"])
def test_plugin_exiting_at_import_or_register_is_exit_2(tmp_path: pathlib.Path, plugin_env: dict[str, str], where: str) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps(one("ok")))
    env = dict(plugin_env, KILLER_AT_IMPORT=where)
    for command in ("validate", "show", "run"):
        result = cli(env, command, str(path), "--plugin", "killer_plugin")
        assert result.returncode == 2, (command, result.stdout, result.stderr)
        assert "SystemExit" in result.stderr and len(result.stderr.strip().splitlines()) == 1
    batch = cli(env, "run", str(path), str(path), "--plugin", "killer_plugin")
    assert batch.returncode == 2 and "2 files: 2 invalid" in batch.stdout


STOPPED_WITHIN = 60
"""How long a signalled command may take to end, in seconds: a liveness bound, not a speed check.

The runs it interrupts block for an hour and never end by themselves, so a command that waited
for them (rather than stopping its workers, SIGKILL after a 0.5 s grace) would not end at all;
one that stops them ends in about a second. The bound only has to separate "ends" from "never
ends" on any machine, so it is generous."""


def wait_until_running(ready: pathlib.Path, proc: subprocess.Popen[str], *also: pathlib.Path) -> None:
    """Return once a ``block`` leaf has started (it writes a file into *ready*) and every path in *also* exists."""
    deadline = time.monotonic() + 120  # a hang guard only: readiness is the file, not the time
    while not (any(ready.iterdir()) and all(p.exists() for p in also)):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the blocking leaf never started"
        time.sleep(0.02)


def stop_leftovers(mark: str) -> None:
    """Kill (by pid) whatever this test's command left running, so a failing test leaks no process."""
    for pid in marked_processes(mark):
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_a_batch_at_once_with_a_partial_summary(tmp_path: pathlib.Path, plugin_env: dict[str, str], signum: int) -> None:
    cases = tmp_path / "cases"
    cases.mkdir()
    (cases / "a_quick.json").write_text(json.dumps(one("ok")))
    for i in range(6):  # runs that never end by themselves (the leaf blocks for an hour)
        (cases / f"slow{i}.json").write_text(json.dumps(one("block", timeout=20)))
    out = tmp_path / "out"
    ready = tmp_path / "ready"
    ready.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", str(cases), "--plugin", "killer_plugin",
                             "-j", "2", "--out-dir", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT, env=dict(plugin_env, KILLER_READY=str(ready)))  # fmt: skip
    try:
        wait_until_running(ready, proc, out / "a_quick.report.json")  # one file done, a slow one running
        proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=STOPPED_WITHIN)
    finally:
        proc.kill()
        stop_leftovers(plugin_env["BTGEN_TEST_MARK"])
    assert proc.returncode == 128 + signum, (stdout, stderr)
    assert "Traceback" not in stderr
    assert "a_quick.json" in stdout and "NOT RUN" in stdout and "7 files: 1 ok, 6 not run" in stdout
    assert not marked_processes(plugin_env["BTGEN_TEST_MARK"])
    assert not [p.name for p in out.iterdir() if ".tmp" in p.name]


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_a_single_run_and_writes_nothing(tmp_path: pathlib.Path, plugin_env: dict[str, str], signum: int) -> None:
    path = tmp_path / "slow.json"
    path.write_text(json.dumps(one("block", timeout=20)))
    report = tmp_path / "r.json"
    ready = tmp_path / "ready"
    ready.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", str(path), "--plugin", "killer_plugin",
                             "--json", str(report)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=ROOT, env=dict(plugin_env, KILLER_READY=str(ready)))  # fmt: skip
    try:
        wait_until_running(ready, proc)  # the run is under way: its leaf is being ticked
        proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=STOPPED_WITHIN)
    finally:
        proc.kill()
        stop_leftovers(plugin_env["BTGEN_TEST_MARK"])
    assert proc.returncode == 128 + signum, (stdout, stderr)
    assert stderr.strip() == f"btgen_pytrees: interrupted by {signal.Signals(signum).name}"
    assert not report.exists() and not [p for p in tmp_path.iterdir() if ".tmp" in p.name]
