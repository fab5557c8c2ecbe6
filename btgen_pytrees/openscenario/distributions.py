"""A ``ParameterValueDistribution`` file: the scenario it varies and its variations, reproducibly.

ASAM OpenSCENARIO 1.2, clause 9 "Parameter value distributions" (1.0: 10): the file names a
``ScenarioFile`` and gives either

* ``Deterministic`` distributions - ``DistributionSet`` (listed values), ``DistributionRange``
  (``lowerLimit`` to ``upperLimit`` by ``stepWidth``, the upper limit included when a step lands
  on it) for one parameter each, and ``ValueSetDistribution`` s (sets of assignments to several
  parameters together). The variations are the full product: the distribution written first
  varies slowest, as the project's ``variations`` block (``load/variations.py``) orders a product;
* or ``Stochastic`` distributions with ``numberOfTestRuns`` and ``randomSeed``: each test run
  draws one value for every parameter, in the file's order, from :class:`random.Random` seeded
  with ``randomSeed`` (its sequence is fixed across Python versions): ``UniformDistribution``,
  ``NormalDistribution`` and ``LogNormalDistribution`` (``expectedValue`` and ``variance`` of the
  distribution itself; with a ``Range``, values outside it are drawn again), ``PoissonDistribution``,
  ``Histogram`` (a bin by weight, then uniform in it), ``ProbabilityDistributionSet`` (a value by
  weight). Drawn numbers are rounded to 6 significant digits, as the project's random draws are,
  so a row's label names the exact value run. ``UserDefinedDistribution`` is refused: its content
  is a tool's own format.

The count is computed by arithmetic before anything is drawn.
"""

from __future__ import annotations

import bisect
import math
import random
from dataclasses import dataclass, field
from typing import Any, Iterator

from .parameters import Scope
from .xmltree import Node, XmlProblem

__all__ = ["Axis", "Distribution", "parse_distribution", "RANGE_EPSILON", "MAX_REDRAWS", "MAX_RUNS"]

RANGE_EPSILON = 1e-9
MAX_REDRAWS = 1000
"""Draws of a distribution with a ``Range`` before the value is clamped into the range."""
MAX_RUNS = 10_000_000
"""Largest ``numberOfTestRuns`` accepted (the sweep's own limit applies on top)."""

Value = Any


@dataclass
class Axis:
    """One deterministic distribution: the names it sets and its values (tuples, one value per name)."""

    names: tuple[str, ...]
    kind: str  # "set", "range", "valueset"
    node: Node
    spec: Any  # list of tuples (set, valueset) or (low, high, step)

    def size(self) -> int:
        if self.kind == "range":
            low, high, step = self.spec
            return int(math.floor((high - low) / step + RANGE_EPSILON)) + 1
        return len(self.spec)

    def value(self, k: int) -> tuple[Value, ...]:
        if self.kind == "range":
            low, _, step = self.spec
            return (round(low + k * step, 12) + 0.0,)
        return self.spec[k]  # type: ignore[no-any-return]


@dataclass
class Stochastic:
    name: str
    kind: str  # uniform, normal, lognormal, poisson, histogram, set
    node: Node
    spec: Any

    def draw(self, rng: random.Random) -> Value:
        kind, spec = self.kind, self.spec
        if kind == "set":
            values, cumulative = spec
            return values[bisect.bisect_right(cumulative, rng.random() * cumulative[-1])]
        if kind == "histogram":
            bins, cumulative = spec
            low, high = bins[bisect.bisect_right(cumulative, rng.random() * cumulative[-1])]
            return _six(rng.uniform(low, high))
        low, high = spec.get("range", (-math.inf, math.inf))
        for _ in range(MAX_REDRAWS):
            x = self._one(rng)
            if low <= x <= high:
                return _six(x) if kind != "poisson" else x
        return _six(min(max(x, low), high))

    def _one(self, rng: random.Random) -> float:
        spec = self.spec
        if self.kind == "uniform":
            return rng.uniform(*spec["range"])
        if self.kind == "normal":
            return rng.gauss(spec["mean"], math.sqrt(spec["variance"]))
        if self.kind == "lognormal":
            m, v = spec["mean"], spec["variance"]
            sigma2 = math.log(1 + v / (m * m))
            return rng.lognormvariate(math.log(m) - sigma2 / 2, math.sqrt(sigma2))
        # poisson, by inversion of its cumulative distribution (bounded: lambda <= 1e4 is checked)
        lam = spec["mean"]
        u, k, p = rng.random(), 0, math.exp(-lam)
        total = p
        while u > total and k < 10 * lam + 100:
            k += 1
            p *= lam / k
            total += p
        return k


def _six(x: float) -> float:
    return float(f"{x:.6g}")


@dataclass
class Distribution:
    """A parsed ``ParameterValueDistribution``: the scenario file and the variations."""

    scenario: str
    node: Node
    axes: list[Axis] = field(default_factory=list)
    stochastic: list[Stochastic] = field(default_factory=list)
    runs: int = 0
    seed: int = 0

    @property
    def names(self) -> tuple[str, ...]:
        if self.stochastic:
            return tuple(s.name for s in self.stochastic)
        return tuple(n for a in self.axes for n in a.names)

    @property
    def count(self) -> int:
        if self.stochastic:
            return self.runs
        return math.prod(a.size() for a in self.axes)

    def points(self) -> Iterator[tuple[tuple[str, Value], ...]]:
        """Every variation, ``((name, value), ...)``, in order; lazy."""
        if self.stochastic:
            rng = random.Random(self.seed)
            for run in range(self.runs):
                yield (("sample", run), *((s.name, s.draw(rng)) for s in self.stochastic))
            return
        sizes = [a.size() for a in self.axes]
        for flat in range(math.prod(sizes)):
            ks, rest = [], flat
            for size in reversed(sizes):
                rest, k = divmod(rest, size)
                ks.append(k)
            point: list[tuple[str, Value]] = []
            for a, k in zip(self.axes, reversed(ks)):
                point.extend(zip(a.names, a.value(k)))
            yield tuple(point)


def _limits(scope: Scope, node: Node) -> tuple[float, float]:
    low, high = scope.number(node, "lowerLimit"), scope.number(node, "upperLimit")
    if high < low:
        raise XmlProblem(node, f"upperLimit {high:g} is less than lowerLimit {low:g}")
    return low, high


def _weights(node: Node, items: list[tuple[Any, float]]) -> tuple[list[Any], list[float]]:
    if not items:
        raise XmlProblem(node, f"{node.tag} lists no element")
    if any(w < 0 for _, w in items) or sum(w for _, w in items) <= 0:
        raise XmlProblem(node, "weights must not be negative and must not all be zero")
    cumulative, total = [], 0.0
    for _, w in items:
        total += w
        cumulative.append(total)
    return [v for v, _ in items], cumulative


def parse_distribution(root: Node, scope: Scope) -> Distribution:
    """Read ``/OpenSCENARIO/ParameterValueDistribution``."""
    pvd = root.need_child("ParameterValueDistribution")
    scenario = pvd.need_child("ScenarioFile")
    result = Distribution(scope.text(scenario, "filepath") or "", pvd)
    deterministic, stochastic = pvd.child("Deterministic"), pvd.child("Stochastic")
    if (deterministic is None) == (stochastic is None):
        raise XmlProblem(pvd, "a ParameterValueDistribution holds either Deterministic or Stochastic")
    if deterministic is not None:
        for d in deterministic.children:
            d.use()
            if d.tag == "DeterministicSingleParameterDistribution":
                name = scope.text(d, "parameterName") or ""
                kind = d.only()
                if kind.tag == "DistributionSet":
                    values = [(scope.text(e, "value"),) for e in kind.all("Element")]
                    if not values:
                        raise XmlProblem(kind, "DistributionSet lists no Element")
                    result.axes.append(Axis((name,), "set", kind, values))
                elif kind.tag == "DistributionRange":
                    step = scope.number(kind, "stepWidth")
                    low, high = _limits(scope, kind.need_child("Range"))
                    if step <= 0:
                        raise XmlProblem(kind, f"stepWidth {step:g} must be greater than 0")
                    result.axes.append(Axis((name,), "range", kind, (low, high, step)))
                elif kind.tag == "UserDefinedDistribution":
                    raise XmlProblem(kind, "UserDefinedDistribution is not supported: its content is a tool's own format")
                else:
                    raise XmlProblem(kind, f"unknown deterministic distribution {kind.tag}")
            elif d.tag == "DeterministicMultiParameterDistribution":
                kind = d.only()
                if kind.tag != "ValueSetDistribution":
                    raise XmlProblem(kind, f"unknown multi-parameter distribution {kind.tag}")
                sets = kind.all("ParameterValueSet")
                if not sets:
                    raise XmlProblem(kind, "ValueSetDistribution lists no ParameterValueSet")
                names = tuple(scope.text(a, "parameterRef") or "" for a in sets[0].all("ParameterAssignment"))
                rows = []
                for s in sets:
                    assignments = s.all("ParameterAssignment")
                    these = tuple(scope.text(a, "parameterRef") or "" for a in assignments)
                    if these != names:
                        raise XmlProblem(s, f"assigns {', '.join(these)}; the first set assigns {', '.join(names)}")
                    rows.append(tuple(scope.text(a, "value") for a in assignments))
                result.axes.append(Axis(names, "valueset", kind, rows))
            else:
                raise XmlProblem(d, f"unknown deterministic distribution {d.tag}")
        seen: set[str] = set()
        for axis in result.axes:
            for n in axis.names:
                if n in seen:
                    raise XmlProblem(axis.node, f"parameter {n!r} is varied twice")
                seen.add(n)
        return result
    assert stochastic is not None
    result.runs = scope.integer(stochastic, "numberOfTestRuns")
    if not 1 <= result.runs <= MAX_RUNS:
        raise XmlProblem(stochastic, f"numberOfTestRuns {result.runs} must be between 1 and {MAX_RUNS:,}")
    result.seed = scope.integer(stochastic, "randomSeed", 0)
    for d in stochastic.all("StochasticDistribution"):
        name = scope.text(d, "parameterName") or ""
        kind = d.only()
        spec: dict[str, Any] = {}
        rng = kind.child("Range")
        if rng is not None:
            spec["range"] = _limits(scope, rng)
        if kind.tag == "UniformDistribution":
            if rng is None:
                raise XmlProblem(kind, "UniformDistribution needs a Range")
            result.stochastic.append(Stochastic(name, "uniform", kind, spec))
        elif kind.tag in ("NormalDistribution", "LogNormalDistribution"):
            spec["mean"], spec["variance"] = scope.number(kind, "expectedValue"), scope.number(kind, "variance")
            if spec["variance"] < 0:
                raise XmlProblem(kind, "variance must not be negative")
            if kind.tag == "LogNormalDistribution" and spec["mean"] <= 0:
                raise XmlProblem(kind, "a log-normal distribution's expectedValue must be greater than 0")
            result.stochastic.append(Stochastic(name, "normal" if kind.tag == "NormalDistribution" else "lognormal", kind, spec))
        elif kind.tag == "PoissonDistribution":
            spec["mean"] = scope.number(kind, "expectedValue")
            if not 0 < spec["mean"] <= 1e4:
                raise XmlProblem(kind, "a Poisson distribution's expectedValue must be in (0, 10000]")
            result.stochastic.append(Stochastic(name, "poisson", kind, spec))
        elif kind.tag == "Histogram":
            bins = [(_limits(scope, b.need_child("Range")), scope.number(b, "weight")) for b in kind.all("Bin")]
            result.stochastic.append(Stochastic(name, "histogram", kind, _weights(kind, bins)))
        elif kind.tag == "ProbabilityDistributionSet":
            items = [(scope.text(e, "value"), scope.number(e, "weight")) for e in kind.all("Element")]
            result.stochastic.append(Stochastic(name, "set", kind, _weights(kind, items)))
        elif kind.tag == "UserDefinedDistribution":
            raise XmlProblem(kind, "UserDefinedDistribution is not supported: its content is a tool's own format")
        else:
            raise XmlProblem(kind, f"unknown stochastic distribution {kind.tag}")
    if not result.stochastic:
        raise XmlProblem(stochastic, "Stochastic lists no StochasticDistribution")
    return result
