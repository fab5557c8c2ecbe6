"""The full tree: execute and oracle subtrees under one Parallel.

The root is ``Parallel(case.name, SuccessOnSelected([exit]))`` (a
:class:`~btgen_pytrees.leaves.wiring.TreeRoot`, which reads the clock once per
tick) with children
``[execute, oracle]``. The exit condition is the oracle subtree when it has
*others* criteria (the paper), else the execute subtree. A failure of either
child fails the root. The execute subtree is wrapped in a
:class:`~btgen_pytrees.leaves.wiring.Completion` that marks ``execute_done`` on
the blackboard, which ``period``/``final`` criteria without explicit times wait
for.

>>> from btgen_pytrees import load, generate
>>> root = generate(load("examples/fig1.json"))
>>> [c.name for c in root.children]
['execute', 'oracle']
"""

from __future__ import annotations

from typing import Any

import py_trees
from ..clock import Clock
from ..leaves import Environment, Registry, default_registry, unique_namespace
from ..leaves.control import StopGuard
from ..leaves.wiring import EXECUTE, Completion, TreeRoot
from ..model import STATES, TestCase, state_signal
from ..timeline import timeline
from .execute import EXECUTE_DEPTH, MAX_DEPTH, walk_consuming
from .oracle import oracle_subtree

__all__ = ["generate"]


def generate(
    case: TestCase,
    *,
    registry: Registry | None = None,
    clock: Clock | None = None,
    namespace: str | None = None,
    max_depth: int = MAX_DEPTH,
) -> py_trees.behaviour.Behaviour:
    """Generate the behaviour tree of a loaded test case.

    Args:
        case: from :func:`btgen_pytrees.load`
        registry: leaf factories (default: the built-in simulated leaves)
        clock: what leaves read time from (default: wall-clock time), read
            once at the start of each tick of the root; the runner gives the
            system's time (see :func:`btgen_pytrees.run.run_tree`)
        namespace: blackboard namespace for the tree's keys (default: derived
            from the test name, unique in this process)
        max_depth: deepest level a node may sit at (root = 1)

    Returns:
        the root behaviour; ``root.btgen_env`` is its
        :class:`~btgen_pytrees.leaves.Environment`, ``root.btgen_case`` the case.
    """
    registry = registry if registry is not None else default_registry()
    env = Environment(namespace or unique_namespace(case.name), clock, case.signals)
    for entry in case.entries:  # the states of the entries a `when` or a `stop` reads: false until they change
        if entry.control is not None and entry.control.watched:
            env.initial_signals.update((state_signal(entry.id, state), False) for state in STATES)
    graph = timeline(case, attributes=False)  # the timeline; the walk takes each node's entry from the case
    try:
        entries = {e.id: e for e in case.entries}
        walked = walk_consuming(graph, entries, env, registry, depth=EXECUTE_DEPTH, max_depth=max_depth)
    finally:
        graph.clear()  # networkx caches views that refer back to the graph: free it now, not at the next gc
    if case.stop:  # the case's stop conditions, checked before any entry on every tick
        walked = StopGuard(walked, case.stop, env)
    execute = Completion(walked, env, marks=EXECUTE, name="execute")
    oracle, others = oracle_subtree(case.criteria, dict(case.relation), env, registry)
    children: list[Any] = [execute] if oracle is None else [execute, oracle]
    exit_condition = oracle if others is not None else execute
    policy = py_trees.common.ParallelPolicy.SuccessOnSelected([exit_condition], synchronise=True)
    root = TreeRoot(case.name, policy, children, env)
    root.btgen_env = env  # type: ignore[attr-defined]
    root.btgen_case = case  # type: ignore[attr-defined]
    return root
