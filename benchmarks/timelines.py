"""Synthetic test cases with timelines of a chosen shape and size.

Each builder returns a test-case *dict* (what :func:`btgen_pytrees.load` accepts)
with exactly *n* execute entries and no oracle, so that what the benchmark
measures is the timeline and Algorithm 1, which are where the cost grows with
the input. The shapes stress different parts of the walk:

* ``chain`` - one long row walk: every entry continues its predecessor's
  Sequence, so the tree is shallow but one Sequence holds all *n* leaves.
* ``comb`` - a chain of steps, each with a check hanging off it: a fork after
  every step, i.e. the deepest nesting the walk can make; the generator must
  hoist branches to stay within its depth bound.
* ``fan_out`` - one root with *n - 1* successors: one Parallel with a huge
  child list.
* ``fan_in`` - *n - 1* roots joined by one final entry: one Trigger waiting for
  *n - 1* ids, every root wrapped in a Completion.
* ``random`` - each entry after the first two picks two distinct predecessors
  uniformly among the earlier ones (a seeded RNG, so every run builds the same
  DAG): almost every entry is a join, the worst case for the column walk.

Leaves are the built-in ``hold`` (behaviours) and ``wait`` (constraints) with a
duration of one tick, so a run of the ``random`` case ends after a few dozen
ticks while still starting and finishing every entry.
"""

from __future__ import annotations

import random
from typing import Any, Callable, Iterable

__all__ = ["SHAPES", "DURATION", "TICK", "chain", "comb", "fan_out", "fan_in", "random_dag", "build"]

TICK = 0.1
"""Virtual seconds per tick of the generated cases."""

DURATION = 0.1
"""Duration of every leaf: one tick, the smallest that still keeps leaves RUNNING for a tick."""

Case = dict[str, Any]


def _entry(
    entry_id: str, after: Iterable[str] = (), *, constraint: bool = False, join: str | None = None
) -> dict[str, Any]:
    """One execute entry: ``wait`` if *constraint*, else ``hold``, lasting :data:`DURATION`."""
    entry: dict[str, Any] = {
        "id": entry_id,
        "kind": "constraint" if constraint else "behavior",
        "action": "wait" if constraint else "hold",
        "params": {"duration": DURATION},
    }
    preds = list(after)
    if preds:
        entry["after"] = preds
    if join is not None:
        entry["join"] = join
    return entry


def _case(name: str, entries: list[dict[str, Any]]) -> Case:
    """Wrap *entries* in a case whose timeout cannot cut a run short.

    The timeout allows one tick per entry plus slack: no shape here takes
    longer than that, and it stays far below the loader's tick limit.
    """
    return {"name": name, "tick": TICK, "timeout": round((len(entries) + 10) * DURATION * 2, 6), "execute": entries}


def _check_size(n: int, least: int = 1) -> None:
    if n < least:
        raise ValueError(f"n must be at least {least}, not {n}")


def chain(n: int) -> Case:
    """``E0 → E1 → … → E(n-1)``, alternating behaviours and constraints."""
    _check_size(n)
    return _case(f"chain-{n}", [_entry(f"E{i}", [f"E{i - 1}"] if i else [], constraint=i % 2 == 1) for i in range(n)])


def comb(n: int) -> Case:
    """Steps ``S1 → S2 → …`` with a check ``Si → Ci`` after every step (``ceil(n/2)`` steps)."""
    _check_size(n)
    entries: list[dict[str, Any]] = []
    step = 0
    while len(entries) < n:
        step += 1
        entries.append(_entry(f"S{step}", [f"S{step - 1}"] if step > 1 else []))
        if len(entries) < n:
            entries.append(_entry(f"C{step}", [f"S{step}"], constraint=True))
    return _case(f"comb-{n}", entries)


def fan_out(n: int) -> Case:
    """One root ``R`` with ``n - 1`` successors."""
    _check_size(n)
    leaves = [_entry(f"E{i}", ["R"], constraint=i % 2 == 1) for i in range(1, n)]
    return _case(f"fan_out-{n}", [_entry("R"), *leaves])


def fan_in(n: int) -> Case:
    """``n - 1`` roots that all precede one final entry ``J`` (join ``all``)."""
    _check_size(n, 2)
    roots = [_entry(f"E{i}", constraint=i % 2 == 1) for i in range(1, n)]
    return _case(f"fan_in-{n}", [*roots, _entry("J", [r["id"] for r in roots], join="all")])


def random_dag(n: int, seed: int = 6, degree: int = 2) -> Case:
    """Entry *i* follows ``min(i, degree)`` distinct earlier entries drawn uniformly (join ``all``).

    ``random.Random(seed)`` makes the DAG a function of ``(n, seed, degree)``
    only, so every run and every machine benchmark the same graph.
    """
    _check_size(n)
    rng = random.Random(seed)
    entries = []
    for i in range(n):
        preds = sorted(rng.sample(range(i), min(i, degree)))
        entries.append(_entry(f"E{i}", [f"E{p}" for p in preds], constraint=i % 2 == 1, join="all"))
    return _case(f"random-{n}", entries)


SHAPES: dict[str, Callable[[int], Case]] = {
    "chain": chain,
    "comb": comb,
    "fan_out": fan_out,
    "fan_in": fan_in,
    "random": random_dag,
}
"""Every shape, by the name the benchmark prints."""


def build(shape: str, n: int) -> Case:
    """The case of *shape* with *n* entries (``KeyError`` for an unknown shape)."""
    return SHAPES[shape](n)
