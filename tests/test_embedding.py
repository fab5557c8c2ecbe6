"""Embedding: user leaves through the registry and plugins, and the host-app contract."""

from __future__ import annotations

import logging
import os
import pathlib
import subprocess
import sys
import textwrap
from typing import Any

import py_trees
import pytest
from helpers import case, crit, entry
from py_trees.common import Status

import btgen_pytrees
from btgen_pytrees.clock import VirtualClock
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.run import run

ROOT = pathlib.Path(__file__).resolve().parent.parent
HOST = ROOT / "examples" / "host_app"
sys.path.insert(0, str(HOST))
import robot  # noqa: E402


def robot_registry() -> Any:
    registry = default_registry()
    robot.register(registry)
    return registry


def test_user_leaves_run_with_unchanged_wiring() -> None:
    registry = robot_registry()
    report = run(btgen_pytrees.load(HOST / "pick.json", registry=registry), registry=registry)
    assert report.verdict == "pass", report.table()
    result = {e.id: e for e in report.execute}
    # grip joins (all) after the user leaf `reach` (0.25 s at 4 units/s) and `settle` (0.1 s)
    assert result["grip"].start == result["reach"].end == 0.25


def test_decorator_registration_and_params_schema() -> None:
    registry = default_registry()

    @registry.register("beep", params_schema={"type": "object", "required": ["hz"], "properties": {"hz": {"type": "number"}}})
    def beep(e: Any, env: Any) -> py_trees.behaviour.Behaviour:
        return py_trees.behaviours.Success(name=e.name)

    good = case(entry("B", action="beep", hz=440), entry("H", ["B"]))
    assert run(btgen_pytrees.load(good, registry=registry), registry=registry).verdict == "pass"
    bad = case(entry("B", action="beep", hz="loud"))
    with pytest.raises(btgen_pytrees.InvalidTestCase) as info:
        btgen_pytrees.load(bad, registry=registry)
    assert info.value.problems[0].pointer == "/execute/0/params/hz"
    with pytest.raises(btgen_pytrees.InvalidTestCase, match="unknown behavior action 'beep'; known: hold, profile, ramp, set"):
        btgen_pytrees.load(good)


def test_user_oracle_selected_by_action() -> None:
    registry = default_registry()
    seen = []

    def always(c: Any, env: Any) -> py_trees.behaviour.Behaviour:
        seen.append(c.params["level"])
        return py_trees.behaviours.Success(name=c.name)

    registry.register("custom", always, kind="final", params_schema={"type": "object"})
    data = case(entry("A"), criteria=[crit("F", "final", "false", action="custom", params={"level": 3})])
    assert run(btgen_pytrees.load(data, registry=registry), registry=registry).verdict == "pass" and seen == [3]
    with pytest.raises(btgen_pytrees.InvalidTestCase, match="unknown final action 'custom'; known: none"):
        btgen_pytrees.load(data)


def cli(*args: str, env: dict[str, str] | None = None, python: str = sys.executable) -> subprocess.CompletedProcess[str]:
    return subprocess.run([python, "-m", "btgen_pytrees", *args], capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)


def test_cli_plugin_option() -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HOST), str(ROOT)])}
    ok = cli("run", "examples/host_app/pick.json", "--plugin", "robot", env=env)
    assert ok.returncode == 0, ok.stderr
    missing = cli("run", "examples/host_app/pick.json", env=env)
    assert missing.returncode == 2
    assert "examples/host_app/pick.json: /execute/0/action: unknown behavior action 'move_arm'; known: hold, profile, ramp, set" in missing.stderr
    broken = cli("validate", "examples/fig1.json", "--plugin", "no_such_module", env=env)
    assert broken.returncode == 2 and "plugin 'no_such_module': cannot import" in broken.stderr and "Traceback" not in broken.stderr


def test_plugin_package_installed_in_a_fresh_venv(tmp_path: pathlib.Path) -> None:
    """A distribution with a `btgen_pytrees.leaves` entry point, pip-installed into a new venv."""
    pkg = tmp_path / "btgen_robot_plugin"
    (pkg / "btgen_robot_plugin").mkdir(parents=True)
    (pkg / "btgen_robot_plugin" / "__init__.py").write_text((HOST / "robot.py").read_text())
    (pkg / "pyproject.toml").write_text(textwrap.dedent("""
        [build-system]
        requires = ["setuptools"]
        build-backend = "setuptools.build_meta"
        [project]
        name = "btgen-robot-plugin"
        version = "1.0"
        [project.entry-points."btgen_pytrees.leaves"]
        robot = "btgen_robot_plugin:register"
    """))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = str(venv / "bin" / "python")
    site = subprocess.run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    # the new venv sees this environment's packages (pip, setuptools, py_trees, ...) and the repo, nothing else
    parent = [p for p in sys.path if p.endswith("site-packages")]
    pathlib.Path(site, "_parent.pth").write_text("\n".join([*parent, str(ROOT)]) + "\n")
    install = subprocess.run([python, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation", "--no-index", str(pkg)],
                             capture_output=True, text=True, timeout=300)  # fmt: skip
    assert install.returncode == 0, install.stderr
    result = cli("run", "examples/host_app/pick.json", python=python, env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    assert result.returncode == 0, result.stderr + result.stdout
    assert "pick: PASS" in result.stdout
    assert cli("run", "examples/host_app/pick.json").returncode == 2  # this environment has no such plugin


def test_host_app_example_runs_headless() -> None:
    result = subprocess.run([sys.executable, str(HOST / "app.py"), str(HOST / "pick.json")],
                            capture_output=True, text=True, timeout=60, cwd=ROOT)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "test pick: SUCCESS" in result.stdout and "/_/ host app" in result.stdout and "--> heartbeat" in result.stdout
    assert "\npick: PASS after " in result.stdout and "\nexecute " in result.stdout  # the Collector's table, at the end


def test_embedded_under_a_host_root_with_visitors_and_rerun() -> None:
    registry = robot_registry()
    loaded = btgen_pytrees.load(HOST / "pick.json", registry=registry)
    clock = VirtualClock()
    generated = btgen_pytrees.generate(loaded, registry=registry, clock=clock, namespace="/host/test")
    host_root = py_trees.composites.Sequence("host", memory=True, children=[py_trees.behaviours.Success("prepare"), generated])
    tree = py_trees.trees.BehaviourTree(host_root)
    snapshot = py_trees.visitors.SnapshotVisitor()
    display = py_trees.visitors.DisplaySnapshotVisitor()
    tree.add_visitor(snapshot)
    tree.add_visitor(display)
    tree.setup()

    def tick_until_done() -> int:
        for k in range(200):
            clock.set(k * loaded.tick)
            tree.tick()
            if host_root.status != Status.RUNNING:
                return k
        raise AssertionError("did not finish")

    first = tick_until_done()
    assert generated.status == Status.SUCCESS and generated.id in snapshot.visited
    assert generated.btgen_env.namespace == "/host/test"
    tree.root.stop(Status.INVALID)  # the host stops everything
    assert generated.status == Status.INVALID
    assert tick_until_done() == first and generated.status == Status.SUCCESS


def host_state() -> tuple[Any, ...]:
    """Everything a host owns that the library must leave alone."""
    return (
        sys.getrecursionlimit(), logging.getLogger().level, list(logging.getLogger().handlers),
        py_trees.logging.level, dict(logging.Logger.manager.loggerDict),
        {k: v for k, v in py_trees.blackboard.Blackboard.storage.items() if not k.startswith("/btgen_pytrees/")},
        dict(py_trees.blackboard.Blackboard.clients), py_trees.blackboard.Blackboard.activity_stream,
    )  # fmt: skip


def test_library_leaves_host_global_state_alone(fig1_path: str) -> None:
    py_trees.blackboard.Blackboard.set("/host/key", 42)
    before = host_state()
    loaded = btgen_pytrees.load(fig1_path)
    assert run(loaded).verdict == "pass"
    assert host_state() == before  # run() unregistered the blackboard clients of the tree it made
    root = btgen_pytrees.generate(loaded)
    root.tick_once()
    ours = {c.id(): c.name for node in root.iterate() for c in node.blackboards}
    assert dict(py_trees.blackboard.Blackboard.clients) == {**before[-2], **ours}  # the tree's leaves' clients, added
    root.btgen_env.release()
    assert host_state() == before


def test_views_show_a_user_oracle_action_and_params() -> None:
    from btgen_pytrees.render import render, tree_data
    from btgen_pytrees.timeline import timeline

    registry = default_registry()
    registry.register("probe", lambda c, env: py_trees.behaviours.Success(name=c.name), kind="final", params_schema={"type": "object"})
    loaded = btgen_pytrees.load(case(entry("A"), criteria=[crit("F", "final", "true", action="probe", params={"port": 3})]), registry=registry)
    root = btgen_pytrees.generate(loaded, registry=registry)
    assert "--> F · final [probe(port=3)]: true" in render(root, timeline(loaded), "unicode")
    leaf = tree_data(root)["children"][1]["children"][0]["children"][0]
    assert (leaf["action"], leaf["params"]) == ("probe", {"port": 3})
