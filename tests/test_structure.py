"""Golden structure of generated trees, checked both as data and by ticking them."""

from __future__ import annotations

from typing import Any

import py_trees
import pytest
from helpers import case, crit, entry, generate, run_case

import btgen_pytrees
from btgen_pytrees.render import tree_data


def shape(node: dict[str, Any]) -> Any:
    """A compact shape: (type:name, [children]) with leaves as their id/name."""
    kids = [shape(c) for c in node["children"]]
    label = node.get("id", node["name"])
    tag = node["type"]
    if node["type"] == "Parallel":
        tag += "/" + node["policy"]
    if node["type"] == "Trigger":
        return f"Trigger({node['join']}:{','.join(node['waits_for'])})"
    return (f"{tag} {label}", kids) if kids else f"{tag} {label}"


def execute_shape(data: dict[str, Any]) -> Any:
    root = tree_data(generate(data))
    return shape(root["children"][0]["children"][0])  # root -> Completion(execute) -> timeline


def test_fig1_golden(fig1_path: str) -> None:
    root = tree_data(btgen_pytrees.generate(btgen_pytrees.load(fig1_path)))
    assert root["policy"] == "SuccessOnSelected" and root["selected"] == ["oracle"]
    assert [c["name"] for c in root["children"]] == ["execute", "oracle"]
    assert shape(root["children"][0]["children"][0]) == (
        "Parallel/SuccessOnAll timeline", [
            ("Sequence begin", [
                "RunStart start",
                ("Parallel/SuccessOnAll roots", [
                    ("Sequence chain B1", [
                        "Set B1",
                        ("Parallel/SuccessOnAll fork B1", [
                            ("Sequence chain C1", ["Until C1"]),
                            ("Sequence chain B2", [("Completion B2 done", ["Ramp B2"])]),
                        ]),
                    ]),
                    ("Sequence chain C2", ["Wait C2", ("Completion B3 done", ["Set B3"])]),
                ]),
            ]),
            ("Sequence join B4", ["Trigger(any:B2,B3)", "Set B4"]),
        ],
    )  # fmt: skip
    oracle = root["children"][1]
    assert oracle["policy"] == "SuccessOnSelected" and oracle["selected"] == ["others &&"]
    assert shape(oracle) == (
        "Parallel/SuccessOnSelected oracle",
        [("Parallel/SuccessOnAll record &&", ["Record R1"]), ("Parallel/SuccessOnAll others &&", ["Period P1", "Final F1"])],
    )


def test_chain_appends_to_one_sequence() -> None:
    data = case(entry("A"), entry("B", ["A"]), entry("C", ["B"]))
    assert execute_shape(data)[1][0][1][1] == ("Parallel/SuccessOnAll roots", [("Sequence chain A", ["Hold A", "Hold B", "Hold C"])])


def test_fan_out_forks_under_a_parallel() -> None:
    data = case(entry("A"), entry("B", ["A"]), entry("C", ["A"]), entry("D", ["C"]))
    roots = execute_shape(data)[1][0][1][1]
    assert roots == ("Parallel/SuccessOnAll roots", [
        ("Sequence chain A", ["Hold A", ("Parallel/SuccessOnAll fork A", [
            ("Sequence chain B", ["Hold B"]), ("Sequence chain C", ["Hold C", "Hold D"])])])])  # fmt: skip


@pytest.mark.parametrize("join", ["any", "all"])
def test_fan_in_gets_a_trigger(join: str) -> None:
    data = case(entry("A"), entry("B"), entry("J", ["A", "B"], join=join), entry("K", ["J"]))
    top = execute_shape(data)
    assert top[1][1] == ("Sequence join J", [f"Trigger({join}:A,B)", "Hold J", "Hold K"])
    assert top[1][0][1][1] == ("Parallel/SuccessOnAll roots", [
        ("Sequence chain A", [("Completion A done", ["Hold A"])]),
        ("Sequence chain B", [("Completion B done", ["Hold B"])])])  # fmt: skip


def test_fan_in_with_further_fan_out_and_nested_join() -> None:
    data = case(entry("A"), entry("B"), entry("J", ["A", "B"]), entry("K", ["J"]), entry("L", ["J"]),
                entry("M", ["K", "L"], join="all"))  # fmt: skip
    top = execute_shape(data)
    assert [c[0] for c in top[1]] == ["Sequence begin", "Sequence join J", "Sequence join M"]
    assert top[1][1][1][2] == ("Parallel/SuccessOnAll fork J", [
        ("Sequence chain K", [("Completion K done", ["Hold K"])]),
        ("Sequence chain L", [("Completion L done", ["Hold L"])])])  # fmt: skip
    assert top[1][2][1][0] == "Trigger(all:K,L)"


def test_default_join_comes_from_the_file() -> None:
    data = case(entry("A"), entry("B"), entry("J", ["A", "B"]), join="all")
    assert execute_shape(data)[1][1][1][0] == "Trigger(all:A,B)"


def test_several_roots_start_together() -> None:
    data = case(entry("A"), entry("B"), entry("C"))
    roots = execute_shape(data)[1][0][1][1]
    assert [c[0] for c in roots[1]] == ["Sequence chain A", "Sequence chain B", "Sequence chain C"]
    report = run_case(data)
    assert [(e.id, e.start, e.end) for e in report.execute] == [("A", 0, 1), ("B", 0, 1), ("C", 0, 1)]


def test_no_oracle_exits_on_execute() -> None:
    root = generate(case(entry("A")))
    assert len(root.children) == 1 and root.policy.children == [root.children[0]]
    assert run_case(case(entry("A"))).duration == 1.0


def test_only_record_oracles_exit_on_execute() -> None:
    data = case(entry("A"), criteria=[crit("R", "record", "true")])
    root = generate(data)
    assert [c.name for c in root.children] == ["execute", "oracle"]
    assert root.policy.children == [root.children[0]]
    assert type(root.children[1].policy).__name__ == "SuccessOnAll"
    report = run_case(data)
    assert (report.verdict, report.duration, report.oracles[0].verdict) == ("pass", 1.0, "pass")


def test_or_groups_use_success_on_one() -> None:
    data = case(entry("A"), criteria=[crit("F1", "final", "true"), crit("F2", "final", "false")], relation="||")
    oracle = tree_data(generate(data))["children"][1]
    group = oracle["children"][0]
    assert group["policy"] == "SuccessOnOne" and [c["type"] for c in group["children"]] == ["OrMember", "OrMember"]


def test_sequences_have_memory_and_parallels_synchronise() -> None:
    root = generate(case(entry("A"), entry("B", ["A"]), entry("C", ["A"]), entry("J", ["B", "C"])))
    for node in root.iterate():
        if isinstance(node, py_trees.composites.Sequence):
            assert node.memory
        if isinstance(node, py_trees.composites.Parallel) and not isinstance(node.policy, py_trees.common.ParallelPolicy.SuccessOnOne):
            assert node.policy.synchronise


def test_same_input_same_tree(fig1_path: str) -> None:
    from btgen_pytrees.render import render
    from btgen_pytrees.timeline import timeline

    case_ = btgen_pytrees.load(fig1_path)
    outs = {fmt: {render(btgen_pytrees.generate(case_), timeline(case_), fmt) for _ in range(2)} for fmt in ("unicode", "json")}
    assert all(len(v) == 1 for v in outs.values())
