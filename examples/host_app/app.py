"""A small py_trees host application that embeds a generated test tree.

It owns its root, its tick loop and its display; btgen_pytrees only supplies
one subtree. Run it from the repository root::

    python examples/host_app/app.py examples/host_app/pick.json

The app registers its own leaves (``robot.register``), loads and validates the
test case, puts the generated tree under its own root next to a leaf of its
own, ticks the whole tree with wall-clock time using py_trees'
``BehaviourTree.tick_tock`` and prints py_trees' snapshot display after every
tick. A :class:`btgen_pytrees.run.Collector` visitor collects the run; at the
end the app prints its verdict table - the same table ``python -m btgen_pytrees
run`` prints (``collector.report()`` also gives the JSON report and JUnit XML).
Exit code 0 if the test passed.
"""

from __future__ import annotations

import pathlib
import sys

import py_trees
from py_trees.common import Status

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))  # so `import robot` works from anywhere

import robot  # noqa: E402

import btgen_pytrees  # noqa: E402
from btgen_pytrees.leaves import default_registry  # noqa: E402
from btgen_pytrees.run import Collector  # noqa: E402


class Heartbeat(py_trees.behaviour.Behaviour):
    """The host's own leaf: counts ticks, never finishes."""

    def __init__(self) -> None:
        super().__init__(name="heartbeat")
        self.count = 0

    def update(self) -> Status:
        self.count += 1
        self.feedback_message = f"tick {self.count}"
        return Status.RUNNING


def build(path: str) -> tuple[py_trees.trees.BehaviourTree, py_trees.behaviour.Behaviour]:
    registry = default_registry()
    robot.register(registry)
    case = btgen_pytrees.load(path, registry=registry)
    test_tree = btgen_pytrees.generate(case, registry=registry)  # wall-clock time by default
    policy = py_trees.common.ParallelPolicy.SuccessOnSelected([test_tree], synchronise=False)
    root = py_trees.composites.Parallel("host app", policy, children=[Heartbeat(), test_tree])
    return py_trees.trees.BehaviourTree(root), test_tree


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    path = args[0] if args else str(pathlib.Path(__file__).resolve().parent / "pick.json")
    try:
        tree, test_tree = build(path)
    except btgen_pytrees.InvalidTestCase as error:
        print(error, file=sys.stderr)
        return 2
    snapshot = py_trees.visitors.DisplaySnapshotVisitor(display_only_visited_behaviours=True)
    tree.add_visitor(snapshot)
    collector = Collector(test_tree)  # the test's results, exactly as `run` reports them
    tree.add_visitor(collector)
    tree.setup(timeout=5)
    tree.tick_tock(period_ms=20, number_of_iterations=500, stop_on_terminal_state=True)
    tree.shutdown()
    print(f"test {test_tree.name}: {test_tree.status.value}")
    print(collector.report().table(), end="")
    return 0 if test_tree.status == Status.SUCCESS else 1


if __name__ == "__main__":
    sys.exit(main())
