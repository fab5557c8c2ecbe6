"""btgen_pytrees.parallel: the executors know no leaf, system or view; input errors are one family.

The worker pool's guard and the CLI both classify "the user's input was wrong" (exit 2) by the one
``errors.UserError`` family, not by importing the error types of the modules that raise them.
"""

from __future__ import annotations

import ast
import os
import pathlib

import pytest

from btgen_pytrees.errors import ExitCode, InvalidTestCase, Problem, UsageError, UserError
from btgen_pytrees.leaves.plugins import PluginError
from btgen_pytrees.contracts.registry import FactoryError
from btgen_pytrees.writing import OutputError
from btgen_pytrees.parallel import Interrupted, Outcome, Workers, guard, process
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


# -- workers kept across calls (a search's batches) -------------------------------------------------------

_STARTS: list[int] = []


def _started() -> None:
    """A kept pool's initializer: counts, in the worker process, how often it ran there."""
    _STARTS.append(os.getpid())


def whoami(path: str, leave: bool = False) -> Outcome:
    """The worker's process id and how often its initializer ran there (*leave*: the process dies instead)."""
    if leave:
        os._exit(7)
    return Outcome(path, ExitCode.OK, f"{os.getpid()} {len(_STARTS)}")


def alive(pid: int | None) -> bool:
    """Whether process *pid* still exists (the pool joins its workers: a stopped one is gone, not a zombie)."""
    try:
        os.kill(pid, 0)  # type: ignore[arg-type]
    except ProcessLookupError:
        return False
    return True


def test_kept_workers_serve_every_call_and_start_once() -> None:
    """Three calls of ``process`` on one :class:`Workers`: the same two processes run every job (even a
    call of one job goes to a worker, not to this process), each ran its initializer once; closed, they
    are gone."""
    with Workers(2, _started) as pool:
        seen = [process(whoami, [()] * n, [f"{k}-{i}" for i in range(n)], workers=2, pool=pool) for k, n in enumerate((4, 1, 3))]
        pids = pool.pids
    summaries = [o.summary for call in seen for o in call]
    assert {s.split()[0] for s in summaries} <= {str(p) for p in pids} and len(pids) == 2, (summaries, pids)
    assert {s.split()[1] for s in summaries} == {"1"} and str(os.getpid()) not in {s.split()[0] for s in summaries}
    assert [o.path for o in seen[0]] == ["0-0", "0-1", "0-2", "0-3"] and not _STARTS  # in input order; none ran here
    assert not any(alive(p) for p in pids)
    assert pool.pids == [] and Workers(3).take(0) == []


def test_a_kept_worker_that_dies_costs_its_job_only_and_is_replaced() -> None:
    with Workers(2, _started) as pool:
        first = process(whoami, [()] * 2, ["a", "b"], workers=2, pool=pool)
        before = set(pool.pids)
        second = process(whoami, [(False,), (True,), (False,)], ["c", "d", "e"], workers=2, pool=pool)
        after = set(pool.pids)
        third = process(whoami, [()] * 2, ["f", "g"], workers=2, pool=pool)
    assert [o.code for o in first + third] == [ExitCode.OK] * 4
    assert [o.code for o in second] == [ExitCode.OK, ExitCode.FAIL, ExitCode.OK]
    assert "exited with status 7" in second[1].summary
    assert len(before & after) == 1 and len(after) == 2  # the one that died was replaced
    assert {o.summary.split()[0] for o in third} <= {str(p) for p in after}


def test_ctrl_c_stops_every_kept_worker() -> None:
    def interrupt(outcome: Outcome) -> None:
        raise KeyboardInterrupt

    pool = Workers(2, _started)
    process(whoami, [()] * 2, ["a", "b"], workers=2, pool=pool)
    pids = pool.pids
    with pytest.raises(Interrupted):
        process(whoami, [()] * 4, ["c", "d", "e", "f"], workers=2, pool=pool, on_result=interrupt)
    assert not any(alive(p) for p in pids) and pool.pids == []
    pool.close()  # nothing left: nothing to do


def test_a_call_that_fails_midway_leaves_no_busy_kept_worker_behind() -> None:
    """*on_result* raising (not Ctrl-C) ends the call with workers still running its other jobs: they are
    stopped, so no result of that call can come back as one of the next call's."""
    def fail(outcome: Outcome) -> None:
        raise RuntimeError("the caller's own error")

    with Workers(2, _started) as pool:
        process(whoami, [()] * 2, ["a", "b"], workers=2, pool=pool)
        before = pool.pids
        with pytest.raises(RuntimeError):
            process(whoami, [()] * 4, ["c", "d", "e", "f"], workers=2, pool=pool, on_result=fail)
        assert pool.pids == [] and not any(alive(p) for p in before)
        after = process(whoami, [()] * 3, ["g", "h", "i"], workers=2, pool=pool)
    assert [o.path for o in after] == ["g", "h", "i"] and all(o.code == ExitCode.OK for o in after)
