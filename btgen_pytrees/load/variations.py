"""Variations: which parameter values a sweep runs, in a fixed order.

The ``variations`` block of a test case names, per parameter, the values to try:

* a list, ``"gap": [5, 10, 20]``;
* a range, ``"speed": {"from": 10, "to": 30, "step": 5}`` (``to`` included when a step lands on it);
* a random draw, ``{"uniform": [a, b]}`` or ``{"normal": [mu, sigma]}``, with ``"samples": N``
  and ``"seed": S`` for the whole block.

Lists and ranges combine as a full product (the parameter written first varies
slowest, like :func:`itertools.product`). The random parameters are drawn
*once*: ``samples`` points, each giving a value to every random parameter, and
every point of the product is run with each of them. So the count is
``len(list1) * len(range1) * ... * samples``, computed arithmetically before
anything is built - a 10⁹-variation product is refused, never allocated.

Determinism: the same block gives the same variations in the same order on
every machine. Random values come from :class:`random.Random` seeded with
``seed`` (default 0; its ``random()`` sequence is fixed across Python versions)
and are rounded to 6 significant digits, so a label names the exact value run.

>>> v = Variations.parse({"gap": [5, 10], "speed": {"from": 10, "to": 20, "step": 5}})
>>> v.count, v.names
(6, ('gap', 'speed'))
>>> [label(p) for p in v.points()][:4]
['gap=5,speed=10', 'gap=5,speed=15', 'gap=5,speed=20', 'gap=10,speed=10']
>>> r = Variations.parse({"gap": [5, 10], "mu": {"uniform": [0, 1]}, "samples": 2, "seed": 7})
>>> [label(p) for p in r.points()] == [label(p) for p in r.points()]
True
>>> r.count, [label(p) for p in r.points()][0]
(4, 'gap=5,sample=0,mu=0.323833')
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass
from typing import Any, Iterator, Mapping, Sequence, Union

__all__ = ["Axis", "Variations", "Point", "label", "format_value", "BLOCK_KEYS", "RANGE_EPSILON"]

Value = Union[bool, int, float]
Point = tuple[tuple[str, Value], ...]
"""One variation: ``((name, value), ...)`` for every varied parameter, in the block's order
(a random sweep's sample number is the pseudo-parameter ``sample``)."""

BLOCK_KEYS = ("samples", "seed")
"""Keys of the ``variations`` block that are not parameters."""

RANGE_EPSILON = 1e-9
"""A range includes ``to`` when ``(to - from) / step`` is within this of a whole number."""


def format_value(value: Value) -> str:
    """The shortest exact text of a value: ``true``, ``5`` (also for 5.0), ``0.1``, ``1e-07``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)


def label(point: Point) -> str:
    """``gap=5,speed=10``: the variation's name in reports, maps and file names."""
    return ",".join(f"{name}={format_value(value)}" for name, value in point)


@dataclass(frozen=True)
class Axis:
    """One varied parameter.

    Attributes:
        name: the parameter
        kind: ``list``, ``range``, ``uniform`` or ``normal``
        spec: the block's value for it, as written
    """

    name: str
    kind: str
    spec: Any

    @property
    def random(self) -> bool:
        return self.kind in ("uniform", "normal")

    def size(self) -> int:
        """Number of values of a list or range (a random axis has none of its own)."""
        if self.kind == "list":
            return len(self.spec)
        if self.kind == "range":
            start, stop, step = self.spec["from"], self.spec["to"], self.spec["step"]
            return int(math.floor((stop - start) / step + RANGE_EPSILON)) + 1
        return 1

    def value(self, k: int) -> Value:
        """The *k*-th value of a list or range, computed (never a stored list)."""
        if self.kind == "list":
            return self.spec[k]  # type: ignore[no-any-return]
        start, step = self.spec["from"], self.spec["step"]
        if all(isinstance(x, int) for x in (start, step)):
            return start + k * step  # type: ignore[no-any-return]
        return round(start + k * step, 12) + 0.0  # 0.1 + 2 * 0.1 -> 0.3, and -0.0 -> 0.0

    def draw(self, rng: random.Random) -> float:
        a, b = self.spec[self.kind]
        x = rng.uniform(a, b) if self.kind == "uniform" else rng.gauss(a, b)
        return float(f"{x:.6g}")


def _whole(value: Any) -> Any:
    """``10`` for ``1e1``/``10.0``: JSON (and the schema's ``integer``) does not tell them apart."""
    return int(value) if isinstance(value, float) and value.is_integer() else value


@dataclass(frozen=True)
class Variations:
    """A parsed (and shape-checked) ``variations`` block.

    Attributes:
        axes: the varied parameters, in the block's order
        samples: number of random draws (0 when no parameter is random)
        seed: the random generator's seed
    """

    axes: tuple[Axis, ...]
    samples: int = 0
    seed: int = 0

    @classmethod
    def parse(cls, block: Mapping[str, Any] | None) -> "Variations":
        """Build from a block the schema accepted (see :mod:`.check` for the meaning checks)."""
        axes = []
        for name, spec in (block or {}).items():
            if name in BLOCK_KEYS:
                continue
            if isinstance(spec, list):
                kind = "list"
            elif "uniform" in spec:
                kind = "uniform"
            elif "normal" in spec:
                kind = "normal"
            else:
                kind = "range"
            axes.append(Axis(name, kind, spec))
        block = block or {}
        samples = block.get("samples", 0) if any(a.random for a in axes) else 0
        return cls(tuple(axes), _whole(samples), _whole(block.get("seed", 0)))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    @property
    def grid(self) -> tuple[Axis, ...]:
        return tuple(a for a in self.axes if not a.random)

    @property
    def randoms(self) -> tuple[Axis, ...]:
        return tuple(a for a in self.axes if a.random)

    @property
    def count(self) -> int:
        """How many variations, by arithmetic (exact for any size; nothing is built)."""
        n = math.prod(a.size() for a in self.grid)
        return n * self.samples if self.randoms else n

    def draws(self) -> list[tuple[float, ...]]:
        """The random points, drawn once: ``samples`` tuples, one value per random parameter."""
        rng = random.Random(self.seed)
        return [tuple(a.draw(rng) for a in self.randoms) for _ in range(self.samples)]

    def points(self) -> Iterator[Point]:
        """Every variation, in order; lazy, so the caller decides how many to take."""
        grid, randoms = self.grid, self.randoms
        draws = self.draws() if randoms else [()]
        sizes = [a.size() for a in grid]
        for flat in range(math.prod(sizes)):
            ks, rest = [], flat
            for size in reversed(sizes):
                rest, k = divmod(rest, size)
                ks.append(k)
            fixed = tuple((a.name, a.value(k)) for a, k in zip(grid, reversed(ks)))
            for s, drawn in enumerate(draws):
                extra: Sequence[tuple[str, Value]] = ()
                if randoms:
                    extra = (("sample", s), *zip((a.name for a in randoms), drawn))
                yield fixed + tuple(extra)
