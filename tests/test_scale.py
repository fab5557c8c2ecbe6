"""Large timelines in CI: a 2,000-step comb and a 2,000-entry chain are shown, run and exported.

(The benchmarks in ``benchmarks/`` go to 100,000 entries; these keep the suite fast.)
"""

from __future__ import annotations

import json
from typing import Any

import pytest
from helpers import case, entry

import btgen_pytrees
from btgen_pytrees.construct.execute import CHUNK, MAX_DEPTH
from btgen_pytrees.render import FORMATS, render
from btgen_pytrees.run import run
from btgen_pytrees.timeline import timeline

N = 2000


def comb(n: int) -> dict[str, Any]:
    entries = []
    for i in range(n):
        entries.append(entry(f"S{i}", [f"S{i - 1}"] if i else [], duration=0.1))
        entries.append(entry(f"C{i}", [f"S{i}"], action="wait", duration=0.1))
    return case(*entries, timeout=10 * n)


def chain(n: int) -> dict[str, Any]:
    return case(*[entry(f"S{i}", [f"S{i - 1}"] if i else [], duration=0.1) for i in range(n)], timeout=10 * n)


def depth(root: Any) -> int:
    deepest, stack = 0, [(1, root)]
    while stack:
        d, node = stack.pop()
        deepest = max(deepest, d)
        stack.extend((d + 1, c) for c in node.children)
    return deepest


@pytest.fixture(scope="module", params=["comb", "chain"])
def big(request: Any) -> Any:
    data = comb(N) if request.param == "comb" else chain(N)
    return request.param, btgen_pytrees.load(data)


def test_depth_is_bounded(big: Any) -> None:
    _, loaded = big
    assert depth(btgen_pytrees.generate(loaded)) <= MAX_DEPTH


def test_every_text_format_renders(big: Any) -> None:
    _, loaded = big
    root = btgen_pytrees.generate(loaded)
    graph = timeline(loaded)
    for fmt in sorted(FORMATS):
        if fmt in ("svg", "png"):
            continue  # need Graphviz; tested with a smaller tree in test_dot.py
        text = render(root, graph, fmt)
        assert "S1999" in text, fmt
    tree = json.loads(render(root, graph, "json"))
    assert tree["name"] == "t"


def test_runs_in_order(big: Any) -> None:
    kind, loaded = big
    report = run(loaded)
    assert report.verdict == "pass"
    result = {e.id: e for e in report.execute}
    for i in range(N):
        assert result[f"S{i}"].start == pytest.approx(i * 0.1) and result[f"S{i}"].end == pytest.approx((i + 1) * 0.1)
        if kind == "comb":
            assert result[f"C{i}"].start == pytest.approx((i + 1) * 0.1)


def test_long_chain_is_split_into_parts() -> None:
    loaded = btgen_pytrees.load(chain(2 * CHUNK + 10))
    seq = btgen_pytrees.generate(loaded).children[0].children[0].children[0].children[1].children[0]
    assert [c.name for c in seq.children] == ["chain S0 part 1", "chain S0 part 2", "chain S0 part 3"]
    assert [len(c.children) for c in seq.children] == [CHUNK, CHUNK, 10]


def test_matrix_goes_sparse_when_large() -> None:
    text = render(btgen_pytrees.generate(btgen_pytrees.load(comb(150))), timeline(btgen_pytrees.load(comb(150))), "matrix")
    assert text.splitlines()[1] == "S0: C0 S1" and text.startswith("# adjacency matrix of 300 entries")


def test_depth_bound_counts_the_part_sequence_of_a_long_branch() -> None:
    """Issue 10, defect 9: a >CHUNK chain in the deepest branch, its last leaf waited on by a join.

    Forks nest the branch Sequences two levels apart (6, 8, ..., 98); the chain after the 46th
    fork goes into part Sequences one level deeper, and its last leaf is wrapped in a Completion:
    it sat at level 101 when the hoisting rule reserved only four levels below a fork.
    """
    forks = 46
    entries = []
    for k in range(forks + 1):
        entries.append(entry(f"A{k}", [f"A{k - 1}"] if k else [], duration=0))
        if k < forks:
            entries.append(entry(f"X{k}", [f"A{k}"], duration=0))
    previous = f"A{forks}"
    for i in range(CHUNK + 44):
        entries.append(entry(f"L{i}", [previous], duration=0))
        previous = f"L{i}"
    entries.append(entry("J", [previous, "X0"], join="all", duration=0))
    loaded = btgen_pytrees.load(case(*entries))
    assert depth(btgen_pytrees.generate(loaded)) <= MAX_DEPTH
    report = run(loaded)
    assert report.verdict == "pass" and {e.id: e.start for e in report.execute}["J"] == 0.0
