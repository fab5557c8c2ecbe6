"""btgen_pytrees.parallel: the executors know no leaf, system or view; input errors are one family.

The worker pool's guard and the CLI both classify "the user's input was wrong" (exit 2) by the one
``errors.UserError`` family, not by importing the error types of the modules that raise them.
"""

from __future__ import annotations

import ast
import pathlib

import pytest

from btgen_pytrees.errors import ExitCode, InvalidTestCase, Problem, UsageError, UserError
from btgen_pytrees.leaves.plugins import PluginError
from btgen_pytrees.contracts.registry import FactoryError
from btgen_pytrees.writing import OutputError
from btgen_pytrees.parallel import guard, process
from btgen_pytrees.parallel.dask import DaskUnavailable
from btgen_pytrees.parallel.shipping import ShippingError
from btgen_pytrees.render.dot import GraphvizMissing, GraphvizTimeout
from btgen_pytrees.sweep.overrides import ParameterError

PARALLEL = pathlib.Path(__file__).resolve().parent.parent / "btgen_pytrees" / "parallel"


class Unusable(UserError):
    """An input error of a kind the pool has never heard of."""


def refuse(path: str, message: str) -> None:
    raise Unusable(message)


def test_every_input_error_is_a_user_error() -> None:
    for kind in (InvalidTestCase, UsageError, PluginError, FactoryError, GraphvizMissing, GraphvizTimeout, ParameterError,
                 OutputError, DaskUnavailable, ShippingError):  # fmt: skip
        assert issubclass(kind, UserError), kind


def test_the_guard_classifies_by_the_family() -> None:
    outcome = guard(refuse, "f.json", "no such tool\nsecond line")
    assert (outcome.code, outcome.summary, outcome.problems) == (ExitCode.INVALID, "no such tool", ["f.json: no such tool\nsecond line"])
    invalid = guard(lambda path: (_ for _ in ()).throw(InvalidTestCase([Problem(("a",), "bad")], path)), "g.json")
    assert (invalid.code, invalid.summary, invalid.problems) == (ExitCode.INVALID, "invalid (1 problem)", ["g.json: /a: bad"])


def test_a_worker_process_classifies_alike() -> None:
    outcomes = process(refuse, [("one",), ("two",)], ["a.json", "b.json"], workers=2)
    assert [(o.path, o.code, o.summary) for o in outcomes] == [("a.json", 2, "one"), ("b.json", 2, "two")]


def test_a_parameter_error_prints_a_line_per_problem() -> None:
    assert ParameterError(["--set a=1: unknown", "--set b=2: unknown"]).messages() == ["--set a=1: unknown", "--set b=2: unknown"]
    assert UsageError("x\ny").messages() == ["x\ny"]


@pytest.mark.parametrize("path", sorted(PARALLEL.glob("*.py")), ids=lambda p: p.name)
def test_the_executors_import_nothing_of_the_domain(path: pathlib.Path) -> None:
    """Only the vocabulary (``errors``) and each other: no leaves, systems, views, loader or run."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level:
            found.add("." * node.level + (node.module or ""))
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("btgen_pytrees")}
    assert found <= {"..errors", ".outcome", ".pool", ".shipping"}, found
