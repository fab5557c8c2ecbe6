"""A generated tree in py_trees' own blackboard tools (docs/semantics.md#the-blackboard).

Every test leaf that reads or writes the blackboard has a py_trees client named
after it with its keys declared, so ``Blackboard.clients``,
``unicode_blackboard``, ``dot_tree(..., with_blackboard_variables=True)`` and -
when the host turns it on - the activity stream show who reads and writes what.
"""

from __future__ import annotations

from typing import Iterator

import py_trees
import pytest
from helpers import case, crit, entry
from py_trees.blackboard import Blackboard

import btgen_pytrees
from btgen_pytrees.run import run, run_tree


@pytest.fixture
def stream() -> Iterator[None]:
    """The activity stream on, as a host turns it on; put back as it was."""
    before = Blackboard.activity_stream
    Blackboard.enable_activity_stream(maximum_size=10_000)
    try:
        yield
    finally:
        Blackboard.activity_stream = before


def fig1(fig1_path: str, namespace: str) -> tuple[btgen_pytrees.model.TestCase, py_trees.behaviour.Behaviour]:
    loaded = btgen_pytrees.load(fig1_path)
    return loaded, btgen_pytrees.generate(loaded, namespace=namespace)


def test_the_activity_stream_shows_what_each_leaf_reads_and_writes(fig1_path: str, stream: None) -> None:
    loaded, root = fig1(fig1_path, "/stream/fig1")
    assert run_tree(root, loaded).verdict == "pass"
    items = [(i.key.removeprefix("/stream/fig1/"), i.client_name, i.activity_type) for i in Blackboard.activity_stream.data
             if i.key.startswith("/stream/fig1/")]  # fmt: skip
    assert items[:5] == [("t0", "start", "INITIALISED"), ("signals/mode", "start", "INITIALISED"),
                         ("signals/speed", "start", "INITIALISED"), ("signals/brake", "start", "INITIALISED"),
                         ("signals/target", "start", "INITIALISED")]  # fmt: skip
    assert items[5:12] == [("signals/mode", "B1", "WRITE"), ("signals/mode", "C1", "READ"),
                           ("signals/speed", "B2", "READ"), ("signals/speed", "B2", "WRITE"),
                           ("signals/speed", "R1", "READ"), ("signals/speed", "P1", "READ"),
                           ("signals/speed", "B2", "WRITE")]  # fmt: skip
    assert ("signals/target", "B4", "WRITE") in items and ("signals/target", "F1", "READ") in items
    assert ("execute_done", "F1", "READ") in items
    assert {name for _, name, _ in items} == {"start", "B1", "C1", "B2", "B3", "B4", "R1", "P1", "F1"}
    shown = py_trees.display.unicode_blackboard_activity_stream()
    assert "/stream/fig1/signals/mode" in shown and "| B1" in shown and "WRITE" in shown


def test_the_stream_changes_nothing_in_the_run(fig1_path: str, stream: None) -> None:
    loaded = btgen_pytrees.load(fig1_path)
    on = run(loaded)
    Blackboard.disable_activity_stream()
    off = run(loaded)
    assert on.to_json().replace("#2", "") == off.to_json().replace("#2", "")


def test_clients_and_key_metadata(fig1_path: str) -> None:
    _, root = fig1(fig1_path, "/meta/fig1")
    clients = {client.name: client for node in root.iterate() for client in node.blackboards}
    assert set(clients) == {"start", "B1", "C1", "B2", "B3", "B4", "R1", "P1", "F1"}  # wait/hold/wiring: none
    assert all(Blackboard.clients[c.id()] == name for name, c in clients.items())
    assert clients["B1"].write == {"/meta/fig1/signals/mode"} and clients["B1"].read == set()
    assert clients["R1"].read == {"/meta/fig1/signals/speed"}
    assert clients["F1"].read == {"/meta/fig1/signals/target", "/meta/fig1/execute_done"}
    shown = py_trees.display.unicode_blackboard(display_only_key_metadata=True)
    speed = next(line for line in shown.splitlines() if "/meta/fig1/signals/speed" in line)
    assert all(part in speed for part in ("R1 (r)", "P1 (r)", "B2 (w)", "start (w)"))


def test_dot_with_blackboard_variables_links_each_leaf_to_its_keys(fig1_path: str) -> None:
    _, root = fig1(fig1_path, "/dot/fig1")
    graph = py_trees.display.dot_tree(root, with_blackboard_variables=True)
    leaf = {node.get_label().strip('"'): node.get_name().strip('"') for node in graph.get_nodes() if node.get_label()}
    edges = {(e.get_source().strip('"'), e.get_destination().strip('"')) for e in graph.get_edges()}
    assert (leaf["B2"], "/dot/fig1/signals/speed") in edges  # a writer: leaf -> key
    assert ("/dot/fig1/signals/speed", leaf["R1"]) in edges  # a reader: key -> leaf
    assert ("/dot/fig1/execute_done", leaf["F1"]) in edges


def test_a_leaf_without_keys_has_no_client_and_run_releases_its_clients() -> None:
    before = dict(Blackboard.clients)
    loaded = btgen_pytrees.load(case(entry("A"), entry("B", ["A"], action="wait", kind="constraint"),
                                     criteria=[crit("F", "record", "true")]))  # fmt: skip
    root = btgen_pytrees.generate(loaded)
    assert [c.name for n in root.iterate() for c in n.blackboards] == ["start"]  # t0; hold, wait, 'true': no keys
    run_tree(root, loaded)
    root.btgen_env.release()  # a host's tree: the host releases it
    assert run(btgen_pytrees.load(case(entry("S", action="set", signal="x", value=1)))).passed
    assert dict(Blackboard.clients) == before  # run() unregisters the clients of the tree it made
