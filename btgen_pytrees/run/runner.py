"""The runner: drive a system under test and a generated tree, tick by tick, and report.

One run drives the case's :class:`~btgen_pytrees.systems.System` (the built-in
``simulated`` one unless the case names another) through its life cycle::

    create -> start -> [publish, tree tick, system tick]* -> close

and the system's time is the run's one clock: the runner reads ``system.now()``
once before each tree tick, and that reading is the time every leaf, oracle,
report, trace and view of the tick sees (minus the reading at the first tick,
which is 0 for the simulated and SUMO systems: run time *is* their time). A
system whose ``now()`` is not a finite number, or goes back in time, breaks
that contract: the run ends with verdict ``error`` naming the system and what
it returned. With the simulated system tick *k* happens at ``t = k * tick``
(t = 0 on the first tick); nothing sleeps, so a 60 s test runs as fast as its
tree ticks, and the same input gives the same run to the byte. The run ends when the root finishes (its exit condition succeeded, or
something failed) or after the tick at ``timeout`` (``timeout / tick`` steps);
the system is not stepped after the last tree tick. ``close`` is always called:
on pass, fail, timeout, a leaf that raised, a :class:`SystemFailure` (verdict
``error`` with its message; any other exception from the system: ``error`` naming
it) and Ctrl-C (the ``KeyboardInterrupt`` goes on).

The runner ticks the root's generator directly rather than through
:class:`py_trees.trees.BehaviourTree` (which walks the whole tree after every
tick) and hands each ticked node to a :class:`~btgen_pytrees.run.Collector`,
the same visitor a host application attaches to its own tree.

>>> from btgen_pytrees import load
>>> report = run(load("examples/fig1.json"))
>>> report.verdict, report.duration, report.ticks
('pass', 3.0, 31)
"""

from __future__ import annotations

import math
from numbers import Real
from typing import Any, Callable

import py_trees
from py_trees.common import Status

from ..clock import VirtualClock
from ..construct import generate
from ..errors import is_interrupt
from ..leaves import Registry, default_registry
from ..model import TestCase
from ..contracts.system import System, SystemFailure
from .collector import Collector, Trace
from .report import Report
from .scene import Scene

__all__ = ["run", "run_tree", "create_system", "take_apart", "Trace"]

_DONE = (Status.SUCCESS, Status.FAILURE)
_PACKAGE = __name__.split(".")[0] + "."
"""This package's module prefix (``btgen_pytrees.``): its nodes declare every signal they read."""


def create_system(case: TestCase, registry: Registry | None = None) -> System:
    """A new, not yet started, instance of the system *case* names (``case.system``).

    Raises:
        SystemFailure: no system type of that name is registered
    """
    registry = registry if registry is not None else default_registry()
    system_type = registry.system(case.system.type)
    if system_type is None:
        installed = ", ".join(registry.systems()) or "none"
        raise SystemFailure(f"unknown system {case.system.type!r} (installed: {installed}; a plugin may add it: --plugin)")
    return system_type.create(case.system, case)


def run_tree(
    root: py_trees.behaviour.Behaviour,
    case: TestCase,
    clock: Any = None,
    *,
    system: System | None = None,
    registry: Registry | None = None,
    trace: Trace | None = None,
    require_complete: bool | None = None,
    progress: Callable[[int, float], None] | None = None,
    max_work: int | None = None,
    record: bool = True,
) -> Report:
    """Run *root* (generated from *case*) against *system* until it finishes or times out.

    Args:
        root, case: from :func:`~btgen_pytrees.generate` and :func:`~btgen_pytrees.load`
        clock: ignored; kept so that older callers work. The tree reads the
            system's time during the run (its environment's clock holds
            ``system.now()``, read once per tick; it is put back afterwards)
        system: a new, not started instance; default: :func:`create_system`
            for ``case.system`` from *registry* (default: the default registry)
        trace: called with one line per entry start/end
        require_complete: a run that passes while entries are unfinished fails
            instead (default: the case's ``require_complete``)
        progress: called after every tick with the number of ticks done and the
            run time (``run``'s terminal line, :mod:`btgen_pytrees.progress`)
        max_work: the work budget (:data:`~btgen_pytrees.load.MAX_WORK`; ``None``: none).
            Each tick charges the tree's size (entries + criteria + 10); a run whose
            next tick would exceed the budget ends there with verdict ``error``,
            keeping what it found so far
        record: record the run's trace (``report.trace``: what ``--plot``, ``--replay``
            and ``--btlog`` draw, and the SUMO scene); ``False`` when nothing will read it
            (a sweep's or a search's runs): the verdicts, margins and entries are the same
    """
    if system is None:
        system = create_system(case, registry)
    env = root.btgen_env  # type: ignore[attr-defined]
    collector = Collector(root, trace=trace, record=record)  # record: report.trace, for --plot/--replay/--btlog
    visit = collector.visit
    last = case.ticks - 1
    stop = last if max_work is None else min(last, max_work // work_per_tick(case) - 1)  # the budget's last tick
    saved = env.clock, env.system, env.wanted
    clock = VirtualClock()  # holds the system's time, read once per tick
    env.clock, env.system = clock, system
    env.wanted = None if record or not _ours(root) else env.declared_signals()  # what the system must publish
    then = -math.inf
    try:
        try:
            root.setup_with_descendants()
        except BaseException as exc:  # noqa: BLE001 - a leaf's setup(): the run's error, not the CLI's
            if is_interrupt(exc):
                raise
            collector.end("error", f"setup() raised {_described(exc)}")
            return collector.report()
        system.start(env)
        scene, places = _scene(system, collector)
        now_of, publish = system.now, system.publish
        stops = bool(case.stop)
        for k in range(stop + 1):
            now = now_of()
            if type(now) is float and now >= then and now - now == 0.0:  # the usual answer, checked inline
                then = now
            else:
                then = _system_time(case, now, then)
            clock.set(then)
            publish(env)
            if record:  # the collector's hooks only reach its recorder, which it has only when it records
                collector.initialise()
            try:
                visit(root.tick())  # the collector sees every node the tick yields (Collector.run, inline)
            except BaseException as exc:  # noqa: BLE001 - a leaf raised (SystemExit, a SystemFailure too): report it
                if is_interrupt(exc):
                    raise
                if record:
                    collector.finalise()
                if scene is not None:
                    scene.record(k, places())
                collector.raised(exc)
                break
            if record:
                collector.finalise()
            if scene is not None:
                scene.record(k, places())
            if progress is not None:
                progress(k + 1, then)
            if root.status in _DONE:
                break
            if stops and env.stopped() is not None:  # the case's stop fired, and a criterion is still undecided
                label, at = env.stopped()
                collector.end("fail", f"stopped by {label} at {at:g} s before every criterion was decided")
                break
            if k < stop:
                system.tick()
        else:
            if stop < last:
                collector.end("error", _spent(case, max_work or 0, stop + 1))
            else:
                collector.end("timeout", f"no verdict after {case.timeout:g} s")
    except BaseException as exc:  # noqa: BLE001 - start, publish or tick: the run's error, never a traceback
        if is_interrupt(exc):
            raise
        collector.end("error", _system_error(case, exc))
    finally:
        try:
            if root.status == Status.RUNNING or collector.ending is not None and collector.ending[0] == "error":
                try:
                    root.stop(Status.INVALID)
                except BaseException as exc:  # noqa: BLE001 - a leaf's terminate() raised
                    if is_interrupt(exc):
                        raise
                    if collector.ending is None or collector.ending[0] != "error":
                        collector.end("error", f"terminate() raised {_described(exc)}")
        finally:
            try:
                system.close()
            except BaseException as exc:  # noqa: BLE001
                if is_interrupt(exc):
                    raise
                if collector.ending is None or collector.ending[0] != "error":
                    collector.end("error", f"closing the system failed: {_system_error(case, exc)}")
            finally:
                env.clock, env.system, env.wanted = saved
    collector.trace_end()
    return collector.report(require_complete=case.require_complete if require_complete is None else require_complete)


def run(case: TestCase, *, registry: Registry | None = None, trace: Trace | None = None,
        require_complete: bool | None = None, progress: Callable[[int, float], None] | None = None,
        max_work: int | None = None, record: bool = True) -> Report:  # fmt: skip
    """Generate *case*'s tree, run it against its system and return the :class:`Report`.

    *max_work*: the work budget, *record*: record the trace (see :func:`run_tree`; default none, yes)."""
    registry = registry if registry is not None else default_registry()
    try:
        system = create_system(case, registry)
    except BaseException as exc:  # noqa: BLE001 - SystemType.create: the run's error
        if is_interrupt(exc):
            raise
        return Report(case.name, "error", 0.0, 0, _system_error(case, exc))
    try:
        root = generate(case, registry=registry, clock=system)
    except BaseException as exc:  # noqa: BLE001 - a factory raised or returned a non-Behaviour
        if is_interrupt(exc):
            raise
        return Report(case.name, "error", 0.0, 0, f"building the tree failed: {_described(exc)}",
                      source=case.source)
    try:
        return run_tree(root, case, system=system, trace=trace, require_complete=require_complete, progress=progress,
                        max_work=max_work, record=record)
    finally:
        take_apart(root)  # the tree was made here and goes now (the report keeps none of it)


def take_apart(root: py_trees.behaviour.Behaviour) -> None:
    """Let a generated tree that will not tick again go at once: ``run()`` does it for the tree it made.

    Its environment's blackboard clients are unregistered (:meth:`~btgen_pytrees.leaves.Environment.release`)
    and its keys taken off the blackboard (:meth:`~btgen_pytrees.leaves.Environment.clear`): a sweep's or a
    search's thousands of runs would keep them all. Then the links that make a tree a web of reference
    cycles are dropped - each node's ``parent``, ``children`` and ``iterator`` (the ``tick()`` generator
    py_trees keeps) and the environment's listeners (:meth:`~btgen_pytrees.leaves.Environment.forget_listeners`)
    - so the tree is freed as soon as the last reference to it goes, not left, 270 objects a run of the
    SUMO cut-in, for the garbage collector to find (about a tenth of a millisecond a run in collections).
    Nothing a report holds is touched: a report keeps no node (:mod:`btgen_pytrees.run.trace`).
    """
    env = root.btgen_env  # type: ignore[attr-defined]
    env.release()
    env.clear()
    env.forget_listeners()
    for node in list(root.iterate()):
        try:
            node.parent = None
            node.children = []
            node.iterator = None
        except (AttributeError, TypeError):  # a user's node that will not have them set: left to the collector
            pass


def work_per_tick(case: TestCase) -> int:
    """Work units one tick of *case*'s tree is charged: entries + criteria + 10 (the nodes every tree ticks)."""
    return len(case.entries) + len(case.criteria) + 10


def _spent(case: TestCase, budget: int, ticks: int) -> str:
    size = work_per_tick(case)
    return (f"stopped: the work budget of {budget:.3g} units is spent after {ticks} ticks x {size} "
            f"(entries + criteria + 10), with no verdict yet; raise it with --max-work N")


def _system_time(case: TestCase, now: Any, then: float) -> float:
    """*now*, what ``system.now()`` returned, checked: a finite number of seconds, not before *then* (the last
    tick's). The tick loop checks the usual answer - a float, finite, not going back - inline, without an
    ABC's ``isinstance``, and calls this for the others."""
    if isinstance(now, Real) and not isinstance(now, bool):
        seconds = float(now)
        if math.isfinite(seconds) and seconds >= then:
            return seconds
        if math.isfinite(seconds):
            raise SystemFailure(f"the {case.system.type!r} system's time ran backwards: now() returned {seconds!r} "
                                f"after {then!r} (a system's time never decreases)")  # fmt: skip
    shown = repr(now)
    shown = shown if len(shown) <= 60 else type(now).__name__
    raise SystemFailure(f"the {case.system.type!r} system's now() returned {shown}, not a finite number of seconds")


def _ours(root: py_trees.behaviour.Behaviour) -> bool:
    """Whether every node of the tree is one of this package's (a plugin's or a host's node may read a signal it
    did not declare: then the system publishes every signal, :attr:`Environment.wanted <btgen_pytrees.contracts.environment.Environment.wanted>`)."""
    return all(type(node).__module__.startswith(_PACKAGE) for node in root.iterate())


def _scene(system: System, collector: Collector) -> tuple[Scene | None, Any]:
    """A :class:`Scene` in the run's trace, and the system's ``scene_vehicles``, if it offers a scene."""
    places, scene_map = getattr(system, "scene_vehicles", None), getattr(system, "scene_map", None)
    if not (callable(places) and callable(scene_map)) or collector.recorder is None:
        return None, None
    scene = Scene(scene_map())
    collector.recorder.trace.scene = scene
    return scene, places


def _system_error(case: TestCase, exc: BaseException) -> str:
    """A system's :class:`SystemFailure` speaks for itself; anything else is named as the system's."""
    if isinstance(exc, SystemFailure):
        return str(exc) or f"the {case.system.type!r} system failed"
    return f"the {case.system.type!r} system raised {_described(exc)}"


def _described(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
