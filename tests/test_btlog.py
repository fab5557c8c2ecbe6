"""The ``.btlog`` (BehaviorTree.CPP FileLogger2 layout) is parsed back and must say what the trace says.

Layout checked byte by byte (magic, protocol, XML length, XML with ``_uid`` on
every node, first timestamp, 9-byte records); the XML's nodes are matched to
the py_trees nodes in pre-order, and the records, without the export's
wrappers, are exactly the trace's status changes with their times.
"""

from __future__ import annotations

import pathlib
import struct
import xml.etree.ElementTree as ET
from typing import Any

import pytest

import btgen_pytrees
from btgen_pytrees.cli import main
from btgen_pytrees.run import btlog as btlog_module
from btgen_pytrees.run import run
from btgen_pytrees.run.btlog import MAGIC, BtlogError, btlog_bytes, parse_btlog

ROOT = pathlib.Path(__file__).resolve().parent.parent
FAILING = str(ROOT / "examples" / "fig1_failing.json")
WRAPPER = (" (not selected)", " finished")


def logged(path: str) -> tuple[Any, bytes]:
    loaded = btgen_pytrees.load(path)
    report = run(loaded)
    return report, btlog_bytes(report.trace, btgen_pytrees.generate(loaded))


@pytest.mark.parametrize("path", [FAILING, str(ROOT / "examples" / "fig1.json")])
def test_parsed_back_it_is_the_trace(path: str) -> None:
    report, data = logged(path)
    trace = report.trace
    # the header, by hand
    assert data[:18] == b"BTCPP4-FileLogger2" == MAGIC and data[18] == 1
    (size,) = struct.unpack_from("<i", data, 19)
    xml = data[23:23 + size].decode("utf-8")
    assert struct.unpack_from("<q", data, 23 + size) == (0,)
    assert (len(data) - 23 - size - 8) % 9 == 0
    log = parse_btlog(data)
    assert log.xml == xml and log.first_timestamp == 0
    # the XML: BT.CPP's compact form, every node numbered 1..N in document order
    document = ET.fromstring(xml)
    tree = document.find("BehaviorTree")
    assert tree is not None and tree.get("_fullpath") == ""
    elements = [e for e in tree.iter() if e is not tree]
    assert [int(e.get("_uid", "0")) for e in elements] == list(range(1, len(elements) + 1))
    assert not [e for e in elements if e.tag in ("Action", "Decorator", "Control") or "ID" in e.attrib]
    assert document.find("TreeNodesModel") is not None
    # the nodes: the trace's, in pre-order, once the export's wrappers are set aside
    own = [e for e in elements if not e.get("name", "").endswith(WRAPPER) and e.tag != "AlwaysSuccess"]
    assert [e.get("name") for e in own] == [n.name for n in trace.nodes]
    uid_of = {i: int(e.get("_uid", "0")) for i, e in enumerate(own)}
    wrappers = {int(e.get("_uid", "0")) for e in elements} - set(uid_of.values())
    records = [(t, u, s) for t, u, s in log.transitions if u not in wrappers]
    expected = [(round(trace.times[k] * 1e6), uid_of[i], ["invalid", "running", "success", "failure"].index(s))
                for k, i, s in trace.transitions()]  # fmt: skip
    assert records == expected
    assert [t for t, _, _ in log.transitions] == sorted(t for t, _, _ in log.transitions)


def test_wrappers_follow_their_child() -> None:
    report, data = logged(FAILING)
    log = parse_btlog(data)
    names = log.names()
    by_name = {name: uid for uid, name in names.items()}
    execute = [(t, s) for t, u, s in log.transitions if u == by_name["execute"]]
    wrapper = [(t, s) for t, u, s in log.transitions if u == by_name["execute (not selected)"]]
    assert execute == wrapper == [(0, 1), (1_600_000, 0)]  # running from the first tick, halted when R1 failed
    record = [(t, s) for t, u, s in log.transitions if u == by_name["record && (not selected)"]]
    assert record == [(0, 1), (1_600_000, 3)]  # fails with its child


def test_same_run_same_bytes() -> None:
    assert logged(FAILING)[1] == logged(FAILING)[1]


def test_cli_btlog(tmp_path: pathlib.Path, capsys: Any, monkeypatch: Any) -> None:
    out = tmp_path / "run.btlog"
    assert main(["run", FAILING, "--btlog", str(out)]) == 1
    assert out.read_bytes() == logged(FAILING)[1]
    capsys.readouterr()
    assert main(["run", FAILING, "--btlog", str(tmp_path / "run.xml")]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "must end in .btlog" in captured.err and captured.err.count("\n") == 1
    assert main(["run", FAILING, "--btlog", "-"]) == 2 and main(["run", FAILING, "--replay", "-"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("give a file name") == 2
    monkeypatch.setattr(btlog_module, "MAX_UID", 10)
    too_big = tmp_path / "big.btlog"
    assert main(["run", FAILING, "--btlog", str(too_big)]) == 2
    captured = capsys.readouterr()
    assert "at most 10" in captured.err and captured.out == "" and not too_big.exists()  # before the run
    with pytest.raises(BtlogError):
        logged(FAILING)


def test_not_a_btlog() -> None:
    with pytest.raises(ValueError):
        parse_btlog(b"BTCPP4-FileLogger2\x02" + b"\0" * 20)
    with pytest.raises(ValueError):
        parse_btlog(b"hello")


def test_a_run_that_never_ticked_logs_the_tree_alone(tmp_path: pathlib.Path) -> None:
    """A leaf whose setup() raises ends the run before its first tick: the page and the log still come."""
    import py_trees

    from btgen_pytrees.leaves import default_registry

    class Broken(py_trees.behaviour.Behaviour):
        def __init__(self, entry: Any, env: Any):
            super().__init__(name=entry.name)

        def setup(self, **kwargs: Any) -> None:
            raise RuntimeError("no hardware")

        def update(self) -> py_trees.common.Status:
            return py_trees.common.Status.SUCCESS

    registry = default_registry()
    registry.register("broken", Broken, kind="behavior", params_schema={"type": "object"})
    data = {"name": "t", "execute": [{"id": "B1", "kind": "behavior", "action": "broken", "params": {}}]}
    loaded = btgen_pytrees.load(data, registry=registry)
    report = run(loaded, registry=registry)
    assert report.verdict == "error" and report.trace is None
    log = parse_btlog(btlog_bytes(None, btgen_pytrees.generate(loaded, registry=registry)))
    assert log.transitions == [] and "B1" in log.names().values()


def test_a_sweep_is_refused(tmp_path: pathlib.Path, capsys: Any) -> None:
    sweep = str(ROOT / "examples" / "fig1_sweep.json")
    for option, name in (("--btlog", "x.btlog"), ("--replay", "x.html")):
        assert main(["run", sweep, option, str(tmp_path / name)]) == 2
        assert "not a sweep" in capsys.readouterr().err and not (tmp_path / name).exists()
