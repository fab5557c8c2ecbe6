"""The search space: a sweep's ``variations`` read as a box to search instead of points to run.

* a range ``{"from": a, "to": b, "step": s}`` is the continuous interval [a, b];
  its step is the *resolution* (how precisely a boundary is reported), not a grid;
* a list is a categorical choice;
* a random draw keeps its distribution as a prior: ``{"uniform": [a, b]}`` is
  [a, b]; ``{"normal": [mu, sigma]}`` is mu +- 4 sigma, mapped so that equal
  steps of the searched coordinate are equal steps of probability. Their
  resolution is 1/100 of the interval (uniform) or sigma/10 (normal).

The searchers work in the *unit box*: one coordinate in [0, 1] per continuous
parameter (a value through its prior's quantile function) and a choice index
per list. Values are rounded to 1/100 of the resolution, so a counterexample's
value is short, exact in JSON, and runs again as written.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from statistics import NormalDist
from typing import Any, Mapping, Sequence

from ..load.variations import Value, Variations

__all__ = ["Dimension", "Space", "Points", "EDGE"]

EDGE = NormalDist().cdf(-4.0)
"""A normal prior's searched interval is mu +- 4 sigma: the unit coordinate runs from EDGE to 1 - EDGE."""

_NORMAL = NormalDist()


@dataclass(frozen=True)
class Dimension:
    """One searched parameter.

    Attributes:
        name: the parameter
        kind: ``range``, ``uniform``, ``normal`` (continuous) or ``list`` (categorical)
        low, high: the interval (continuous); for ``normal`` mu - 4 sigma and mu + 4 sigma
        resolution: how finely a boundary is located along it (continuous)
        choices: the values (``list``)
        mu, sigma: a normal prior's parameters
    """

    name: str
    kind: str
    low: float = 0.0
    high: float = 0.0
    resolution: float = 0.0
    choices: tuple[Value, ...] = ()
    mu: float = 0.0
    sigma: float = 0.0

    @functools.cached_property
    def continuous(self) -> bool:
        return self.kind != "list"

    @functools.cached_property
    def digits(self) -> int:
        """Decimal places values are rounded to: 1/100 of the resolution (computed once: every run's values are rounded)."""
        return max(0, min(12, 2 - math.floor(math.log10(self.resolution)))) if self.resolution > 0 else 6

    def value(self, u: float) -> Value:
        """The parameter's value at unit coordinate *u* (a choice index for a list)."""
        if not self.continuous:
            return self.choices[min(len(self.choices) - 1, max(0, int(u)))]
        u = min(1.0, max(0.0, float(u)))
        if self.kind == "normal":
            x = self.mu + self.sigma * _NORMAL.inv_cdf(EDGE + u * (1 - 2 * EDGE)) if self.sigma > 0 else self.mu
        else:
            x = self.low + u * (self.high - self.low)
        x = round(x, self.digits) + 0.0
        return int(x) if x.is_integer() and abs(x) < 1e15 and self.resolution >= 1 else x

    def unit(self, value: Any) -> float | None:
        """The unit coordinate of *value* (clipped into the box); ``None`` for a value not among a list's choices."""
        if not self.continuous:
            for i, choice in enumerate(self.choices):
                if type(choice) is type(value) and choice == value or (not isinstance(value, bool) and not isinstance(choice, bool) and choice == value):
                    return float(i)
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return None
        if self.kind == "normal":
            if self.sigma <= 0:
                return 0.5
            p = _NORMAL.cdf((float(value) - self.mu) / self.sigma)
            return min(1.0, max(0.0, (p - EDGE) / (1 - 2 * EDGE)))
        span = self.high - self.low
        return min(1.0, max(0.0, (float(value) - self.low) / span)) if span > 0 else 0.5

    @functools.cached_property
    def _linear(self) -> tuple[float, float, int, bool] | None:
        """A range's or a uniform prior's ``(low, span, digits, whether a whole value is an int)``, read once
        per run by :meth:`snapped` (one look-up instead of five); ``None`` for the other kinds."""
        if self.kind != "range" and self.kind != "uniform":
            return None
        return self.low, self.high - self.low, self.digits, self.resolution >= 1

    def snapped(self, u: float) -> tuple[float, Value]:
        """``(unit(value(u)), value(u))`` (*u* itself where the value is not in the box), in one call: a
        range's and a uniform prior's inline (every run's values go through it)."""
        linear = self._linear
        if linear is not None:
            low, span, digits, whole = linear
            x = round(low + min(1.0, max(0.0, float(u))) * span, digits) + 0.0
            v = int(x) if whole and x.is_integer() and abs(x) < 1e15 else x
            return (min(1.0, max(0.0, (float(v) - low) / span)) if span > 0 else 0.5), v
        v = self.value(u)
        back = self.unit(v)
        if back is None:
            return float(u), v
        return float(back), (v if self.continuous else self.value(back))

    def unit_resolution(self, u: float) -> float:
        """The resolution as a step of the unit coordinate near *u*."""
        if not self.continuous:
            return 1.0
        if self.kind == "normal":
            x = self.value(u)
            here = self.unit(float(x) + self.resolution)
            return max(1e-9, abs((here if here is not None else u) - u))
        return self._step

    @functools.cached_property
    def _step(self) -> float:
        span = self.high - self.low
        return self.resolution / span if span > 0 else 1.0

    def grid_size(self) -> int:
        """Values of the grid at the declared resolution (a list: its choices)."""
        if not self.continuous:
            return len(self.choices)
        return int(math.floor((self.high - self.low) / self.resolution + 1e-9)) + 1 if self.resolution > 0 else 1


@dataclass(frozen=True)
class Space:
    """The searched parameters, in the ``variations`` block's order."""

    dimensions: tuple[Dimension, ...]
    signals: tuple[tuple[int, ...], ...] = ()
    """The input signals among the dimensions: each the indices of one ``profile``'s control-point values, in
    time order (ranges and uniform priors only - a normal prior's box ends are its +-4 sigma tails, no held
    pedal; a dimension in one signal at most). The space-filling stage draws its points *shaped* along those
    of 4 values or more (:mod:`.sampler`): a uniform point is a signal that jumps at every control point,
    which no pedal or set-point does."""

    @classmethod
    def of(cls, variations: Variations, signals: Sequence[Sequence[str]] = ()) -> "Space":
        """The box of *variations*; *signals*: parameter names, each sequence one input signal's values in time
        order (:func:`~.cases.signals_of`); names not searched or already in a signal are left out, and a
        signal needs two of its values searched."""
        dims = []
        for axis in variations.axes:
            spec = axis.spec
            if axis.kind == "list":
                dims.append(Dimension(axis.name, "list", choices=tuple(spec)))
            elif axis.kind == "range":
                dims.append(Dimension(axis.name, "range", float(spec["from"]), float(spec["to"]), float(spec["step"])))
            elif axis.kind == "uniform":
                a, b = (float(x) for x in spec["uniform"])
                dims.append(Dimension(axis.name, "uniform", a, b, (b - a) / 100))
            else:
                mu, sigma = (float(x) for x in spec["normal"])
                dims.append(Dimension(axis.name, "normal", mu - 4 * sigma, mu + 4 * sigma, sigma / 10, mu=mu, sigma=sigma))
        index = {d.name: i for i, d in enumerate(dims) if d.kind in ("range", "uniform")}  # a normal prior's ends are its tails
        groups: list[tuple[int, ...]] = []
        taken: set[int] = set()
        for names in signals:
            group = tuple(dict.fromkeys(index[n] for n in names if n in index and index[n] not in taken))
            if len(group) >= 2:
                groups.append(group)
                taken.update(group)
        return cls(tuple(dims), tuple(groups))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(d.name for d in self.dimensions)

    @property
    def continuous(self) -> tuple[Dimension, ...]:
        return tuple(d for d in self.dimensions if d.continuous)

    @property
    def categorical(self) -> tuple[Dimension, ...]:
        return tuple(d for d in self.dimensions if not d.continuous)

    def values(self, unit: Sequence[float]) -> dict[str, Value]:
        """The parameters' values at a unit point."""
        return {d.name: d.value(u) for d, u in zip(self.dimensions, unit)}

    def unit(self, values: Mapping[str, Any]) -> list[float | None]:
        """The unit point of *values* (``None`` where a value is not in the box's choices)."""
        return [d.unit(values.get(d.name)) for d in self.dimensions]

    def snapped(self, unit: Sequence[float]) -> tuple[list[float], dict[str, Value]]:
        """``(snap(unit), values(snap(unit)))`` in one pass: a continuous value is its own value again
        (rounded, it runs as written: the values at the snapped point are the values at *unit*)."""
        out, values = [], {}
        for d, u in zip(self.dimensions, unit):
            back, values[d.name] = d.snapped(u)
            out.append(back)
        return out, values

    def snap(self, unit: Sequence[float]) -> list[float]:
        """*unit* moved to the point whose values it runs (values are rounded; the search sees what ran)."""
        out = []
        for d, u in zip(self.dimensions, unit):
            back = d.unit(d.value(u))
            out.append(float(back) if back is not None else float(u))
        return out

    def distance(self, a: Sequence[float | None], b: Sequence[float | None]) -> float:
        """Distance in the unit box, as a fraction of its diagonal (a differing choice counts 1)."""
        total = 0.0
        for d, x, y in zip(self.dimensions, a, b):
            if x is None or y is None:
                total += 1.0
            elif d.continuous:
                total += (x - y) ** 2
            else:
                total += 0.0 if x == y else 1.0
        return math.sqrt(total / max(1, len(self.dimensions)))

    def grid_size(self) -> int:
        return math.prod(d.grid_size() for d in self.dimensions)

    def contains(self, box: Sequence[Any], unit: Sequence[float]) -> bool:
        """Whether the unit point *unit* lies in *box*: an interval ``(low, high)`` of unit coordinates per
        continuous parameter, a set of choice indices per list."""
        for d, part, u in zip(self.dimensions, box, unit):
            if d.continuous:
                if not part[0] - 1e-12 <= u <= part[1] + 1e-12:
                    return False
            elif int(u) not in part:
                return False
        return True


class Points:
    """Points of the unit box kept in one NumPy array (grown by doubling), for the distance from a point to
    each of them at once (:meth:`Space.distance`'s: a differing choice counts 1, as a continuous
    coordinate's difference never exceeds 1). The search keeps its failures and its runs so: the
    bookkeeping of a run is one pass in C over the points, not one Python call per point."""

    def __init__(self, space: Space):
        import numpy  # the search extra's: a search is made only where it is installed

        self._np = numpy
        self._width = len(space.dimensions)
        self._array = numpy.empty((16, self._width))
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def add(self, unit: Sequence[float]) -> None:
        if self._n == len(self._array):
            self._array = self._np.concatenate([self._array, self._np.empty_like(self._array)])
        self._array[self._n] = unit
        self._n += 1

    def distances(self, unit: Sequence[float | None]) -> Any:
        """The distance from *unit* to every point, in the order added (a coordinate that is None counts 1)."""
        np = self._np
        x = np.array([np.nan if u is None else u for u in unit], dtype=float)
        sq = self._array[: self._n] - x
        sq *= sq
        np.minimum(sq, 1.0, out=sq)  # a differing choice (or None: NaN, minimum's NaN kept) counts 1
        sq[np.isnan(sq)] = 1.0
        total = np.add.reduce(sq, axis=1)
        total /= max(1, self._width)
        return np.sqrt(total, out=total)

    def nearest(self, unit: Sequence[float | None]) -> float:
        """The distance to the nearest point (infinite when there is none)."""
        return float(self.distances(unit).min()) if self._n else math.inf

    def lower(self, values: Sequence[float], unit: Sequence[float | None]) -> list[float]:
        """*values* (one per point) each lowered to its point's distance to *unit* where that is less."""
        np = self._np
        return np.minimum(np.asarray(values, dtype=float), self.distances(unit)).tolist()
