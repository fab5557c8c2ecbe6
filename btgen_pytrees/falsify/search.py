"""The search: ask a batch, run it, tell the objectives; after a failure, shrink it, bound it, look elsewhere.

A run *fails* when its verdict is not ``pass`` (``fail``, ``timeout`` or
``error``, as a sweep counts them). The loop (docs/falsify.md):

1. **start** - space-filling points (:mod:`.sampler`); then each criterion's
   scale is fixed (``search.scale``, else the standard deviation of its
   margins over the start runs; 1 when they do not vary) and the criteria
   whose margin varies over the start are *graded*: only they guide the
   search (a collision count or a boolean is 0 or +-1 wherever the run
   passes, and would only mislead it). With no graded criterion the search
   stays space-filling.
2. **search** - the method's sampler, batch by batch, until a run fails.
3. **shrink** - along the segment from the nominal point (the sweep's
   ``parameters``) to the failure, bisected until the pass/fail pair is within
   the resolution of every parameter; then along each parameter towards its
   nominal value, then along the failing region's boundary (the objective's
   local plane): the failing end is the counterexample closest to the nominal
   point.
4. **bound** - from the shrunk counterexample along each continuous parameter
   towards a passing value (the nominal one, else a box edge), bisected to its
   resolution: boundary points.
5. **clusters** - the search goes on elsewhere (runs within :data:`RADIUS` of a
   known failure are told a positive objective, and the sampler restarts); a
   failure farther than :data:`RADIUS` from every known one is a new cluster,
   shrunk and bounded in turn - until the budget ends, or after the first
   cluster with ``stop: cluster`` (its old name ``first`` still reads), or at the
   first failing run with ``stop: failure`` (that run's batch completes; nothing is shrunk or bounded).

Each bisection round runs a batch: ``batch`` points spread inside the interval
(each parameter's interval, in the bound), so a round narrows it by ``batch + 1``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Generator, Mapping, Sequence

from ..load.variations import Value, format_value
from .margins import fit_scales, objective
from .sampler import Sampler, resolve_method
from .space import Points, Space
from .surrogate import boundary_projection

__all__ = ["Settings", "Run", "Cluster", "Boundary", "Search", "RADIUS", "FAILING"]

RADIUS = 0.1
"""Failures closer than this (a fraction of the unit box's diagonal) belong to one cluster."""

NEARER_ROUNDS = 1
"""Rounds of the shrink's coordinate-by-coordinate moves towards the nominal point (one reaches a box-shaped
region's nearest point; each costs a bisection per parameter, about as many runs as the segment's)."""

BOUNDARY_ROUNDS = 4
"""Rounds of the shrink's moves along the failing region's boundary (:meth:`Search._along_boundary`), each a
bisection: they end early when a round brings the counterexample no nearer."""

PROBE = 4
"""A boundary round's probe along each parameter: this many resolutions from the nearest failure."""

STEPS = (1.0, 0.5, 0.25, 0.125)
"""A boundary round's steps from the nearest failure towards the plane's nearest point, tried in turn until
one brings the counterexample nearer."""

FAILING = frozenset(("fail", "timeout", "error"))
_NONE: Mapping[str, float | None] = {}
_SAMPLED = ("start", "search")


@dataclass(frozen=True)
class Settings:
    """What the ``search`` block and the options set (options win). ``batch`` defaults to the number of
    runs that can run at once: 1 for a search run in-process (the command gives its worker count,
    :func:`~btgen_pytrees.falsify.cases.settings_of`)."""

    budget: int = 200
    method: str = "auto"
    seed: int = 0
    batch: int = 1
    stop: str = "all"
    start: int | None = None
    scale: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.stop == "first":  # the old name of "cluster", still read (docs/falsify.md)
            object.__setattr__(self, "stop", "cluster")

    def start_runs(self, space: Space, method: str | None = None) -> int:
        """Space-filling runs first: ``start``, else (within a quarter of the budget) 2 sqrt(d) for d
        parameters and at least 4 for the ``gp`` method (the model explores by itself, and a Gaussian process
        needs no more runs than parameters: 13 in 40 parameters, where 40 start runs left ARCH-COMP's CC1
        to the start's luck; the box's two opposite corners among them), 4 per parameter for the others; a
        whole number of batches."""
        d = len(space.dimensions)
        default = max(4, math.ceil(2 * math.sqrt(d))) if resolve_method(method or self.method, space) == "gp" else 4 * d
        n = self.start if self.start is not None else max(self.batch, min(default, self.budget // 4))
        return self.batch * max(1, math.ceil(n / self.batch))


@dataclass(init=False, slots=True)
class Run:
    """One run of the search (``row`` is what its worker returned: verdict, margins, ...)."""

    index: int
    phase: str
    unit: list[float]
    parameters: dict[str, Value]
    row: dict[str, Any]
    objective: float | None
    failed: bool
    """Whether the verdict is ``fail``, ``timeout`` or ``error`` (a run's row is not changed once told)."""

    def __init__(self, index: int, phase: str, unit: list[float], parameters: dict[str, Value], row: dict[str, Any],
                 objective: float | None = None):  # fmt: skip
        """The dataclass's fields, and :attr:`failed` from the row, in one call (one per run)."""
        self.index, self.phase, self.unit, self.parameters, self.row = index, phase, unit, parameters, row
        self.objective = objective
        self.failed = row.get("verdict", "error") in FAILING

    @property
    def verdict(self) -> str:
        return str(self.row.get("verdict", "error"))


@dataclass
class Boundary:
    """A pass/fail pair along one parameter (``parameter`` None: along the shrink's segment)."""

    parameter: str | None
    passing: int
    failing: int


@dataclass
class Cluster:
    """Failures near one another: their runs, the shrunk counterexample and the boundary found. A run is a
    member of one cluster at most; ``span`` is each coordinate's extent over the members and the boundary
    points (a list parameter: the members' choices), kept as they are added."""

    members: list[int]
    shrunk: int
    boundary: list[Boundary] = field(default_factory=list)
    refined: bool = False
    span: list[Any] = field(default_factory=list)

    def extend(self, unit: Sequence[float], space: Space, member: bool = True) -> None:
        """Widen :attr:`span` to *unit* (a boundary point, not a *member*, adds no choice)."""
        if not self.span:
            self.span = [[u, u] if d.continuous else set() for d, u in zip(space.dimensions, unit)]
        for d, part, u in zip(space.dimensions, self.span, unit):
            if d.continuous:
                part[0], part[1] = min(part[0], u), max(part[1], u)
            elif member:
                part.add(int(u))

    def contains(self, unit: Sequence[float], space: Space) -> bool:
        """Whether *unit* lies in :attr:`span` (the cluster's box as the report draws it, before its
        widening to one resolution)."""
        return bool(self.span) and space.contains(self.span, unit)


Evaluate = Callable[[list[dict[str, Value]]], list[dict[str, Any]]]
"""Runs the given parameter values (in order) and returns each run's row (a sweep row with ``margins``:
criterion id -> the report's margin, and ``wall``)."""


class Search:
    """One falsification search over *space*; :meth:`run` drives it to the end of the budget.

    Args:
        space: the box
        nominal: the sweep's ``parameters`` (defaults)
        settings: budget, method, seed, batch, stop rule, scales
        evaluate: runs a batch (the sweep's executors); raises to stop (Ctrl-C); each row has ``margins``
        groups: the oracle's groups, ``{group: (relation, [criterion ids])}`` (:func:`.margins.groups_of`)
        progress: called after each batch with the search (a progress line)
    """

    def __init__(self, space: Space, nominal: Mapping[str, Value], settings: Settings, evaluate: Evaluate,
                 groups: Mapping[str, tuple[str, Sequence[str]]], progress: Callable[["Search"], None] | None = None):  # fmt: skip
        self.space = space
        self.settings = settings
        self.evaluate = evaluate
        self.progress = progress
        self.nominal_values = {d.name: nominal[d.name] for d in space.dimensions if d.name in nominal}
        self.nominal = space.unit(self.nominal_values)
        self.start = min(settings.start_runs(space), settings.budget)
        self.sampler = Sampler(space, settings.method, seed=settings.seed, start=self.start, batch=settings.batch)
        self.method = self.sampler.method
        self.runs: list[Run] = []
        self.clusters: list[Cluster] = []
        self.scales: dict[str, float] = {}
        self.graded: list[str] | None = None
        self._graded: frozenset[str] | None = None  # the same, for the objective's look-ups
        self.groups = {g: (relation, list(ids)) for g, (relation, ids) in groups.items()}
        self.notes: list[str] = [
            f"the nominal {d.name}={format_value(v)} lies outside the box ({format_value(d.low)} to {format_value(d.high)}): "
            "the shrink goes towards its nearest edge and distances are measured from there"
            for d in space.dimensions for v in (self.nominal_values.get(d.name),)
            if d.continuous and isinstance(v, (int, float)) and not isinstance(v, bool) and not d.low - 1e-12 <= v <= d.high + 1e-12]  # fmt: skip
        self.interrupted = False
        self.signum: int | None = None
        """The signal that interrupted the search in its own code (the CLI's SIGINT or SIGTERM), if it says."""
        self.first_failure: int | None = None
        self._all = Points(space)  # every run's unit point, in order
        self._failing = Points(space)  # every cluster member's, in the order they joined
        self._failing_runs: list[int] = []
        self._cluster_of: dict[int, Cluster] = {}
        self._near: list[float] = []  # each run's distance to the nearest cluster member
        self._from_nominal: list[float] = []  # each run's distance to the nominal point
        self._sampled_runs: list[int] = []  # the runs the sampler asked for, in its order
        self._seen: dict[tuple[float, ...], int] = {}  # a unit point -> the first run at it

    # -- the loop -----------------------------------------------------------------------------------

    def run(self) -> "Search":
        """Search until the budget ends (or the stop rule says so); Ctrl-C keeps what was found."""
        try:
            self._loop()
        except KeyboardInterrupt as stop:  # the CLI's SIGTERM arrives as one too: which signal is kept
            self.interrupted = True
            self.signum = getattr(stop, "signum", None)
        return self

    @property
    def left(self) -> int:
        return self.settings.budget - len(self.runs)

    def _loop(self) -> None:
        while self.left > 0:
            pending = next((c for c in self.clusters if not c.refined), None)
            if pending is not None:
                self._refine(pending)
                if self.settings.stop == "cluster":
                    return
                self._restart()
                continue
            n = min(self.settings.batch, self.left)
            points = self.sampler.ask(n)
            runs = self._run_points(points, "start" if self.sampler.stage == "start" else "search")
            self._sampled_runs += [r.index for r in runs]
            self.sampler.tell([self._told(r) for r in runs])
            if self.graded is None and len(self.sampler.xs) >= self.start:
                self._fix_scales()
            for r in runs:
                if r.failed:
                    self._place(r)
            if self.settings.stop == "failure" and any(r.failed for r in runs):
                self.notes.append("stopped at the first failing run (stop: failure): not shrunk, not bounded")
                return

    def _run_points(self, points: Sequence[Sequence[float]], phase: str) -> list[Run]:
        units, values = [], []
        for p in points:
            u, v = self.space.snapped(p)
            units.append(u)
            values.append(v)
        rows = self.evaluate(values)
        out = []
        for u, v, row in zip(units, values, rows):
            r = Run(len(self.runs), phase, u, v, row)
            r.objective = self._objective(r)
            self.runs.append(r)
            self._all.add(u)
            self._near.append(self._failing.nearest(u))
            self._from_nominal.append(self.space.distance(u, self.nominal))
            self._seen.setdefault(tuple(u), r.index)
            if r.failed and self.first_failure is None:
                self.first_failure = len(self.runs)
            out.append(r)
        if self.progress is not None:
            self.progress(self)
        return out

    # -- the objective ------------------------------------------------------------------------------

    def _objective(self, run: Run) -> float | None:
        """The scaled, combined margin; at most 0 for a failing run; None for an error without margins
        (:func:`~btgen_pytrees.sweep.objective.objective`: a sweep's map shows the same quantity)."""
        return objective(run.row.get("margins") or _NONE, run.failed, self.groups, self.scales, self._graded)

    def _fix_scales(self) -> None:
        """Each criterion's scale and whether it is graded, from the start's runs (a failure met during the
        start has been shrunk and bounded by now: those runs crowd around it and say nothing of the box):
        the first :attr:`start` runs the sampler asked for - ``random``, without a start stage, its first
        uniform draws (:func:`~btgen_pytrees.sweep.objective.fit_scales`)."""
        ids = [i for _, ids in self.groups.values() for i in ids]
        start = self._sampled()[: self.start]
        scales, graded = fit_scales([(r.row.get("margins") or _NONE, r.failed) for r in start], ids, self.settings.scale)
        self.scales.update(scales)
        self.graded = graded
        self._graded = frozenset(graded)
        for r in self.runs:
            r.objective = self._objective(r)
        flat = [i for i in ids if i not in graded]
        if flat:
            passed = sum(1 for r in start if not r.failed)
            seen_as = (f"no gradient over the start ({', '.join(flat)})" if passed > 1 else
                       f"a start of {len(start)} run{'s' * (len(start) != 1)} with {passed} passing cannot show a "
                       f"gradient ({', '.join(flat)}; a longer start: search.start, or a budget of 8 or more)")  # fmt: skip
            self.notes.append(seen_as + ": " + ("these guide nothing but still fail runs" if graded else "the search stays space-filling"))  # fmt: skip
        if not graded:
            self.sampler.space_filling()
        self.sampler.rescore([self._told(r) for r in self._sampled()])

    def _told(self, run: Run) -> float | None:
        """What the sampler is told: the objective, pushed up near known failures (so it looks elsewhere)."""
        if run.objective is None:
            return None
        near = self._near[run.index]
        if near < RADIUS:
            return max(run.objective, 0.0) + (1.0 - near / RADIUS)
        return run.objective

    def _restart(self) -> None:
        self.sampler.avoid = lambda k: self._near[self._sampled_runs[k]] < RADIUS
        self.sampler.restart([self._told(r) for r in self._sampled()])

    def _sampled(self) -> list[Run]:
        """The runs the sampler was asked for and told, in order: the start's and the search's (not the
        shrink's and the bound's, which the search asks for itself)."""
        return [self.runs[i] for i in self._sampled_runs]

    # -- clusters, shrink, bound ----------------------------------------------------------------------

    def _place(self, run: Run, into: Cluster | None = None) -> Cluster:
        """Put a failing run into a cluster: *into* (the cluster being shrunk or bounded: the run lies on
        one of its lines), else the first with a member within :data:`RADIUS` or whose box (:attr:`Cluster.span`)
        holds the run, else a new one; every other cluster with a member within :data:`RADIUS` merges into it
        (the rule is the same for every failure). A run joins one cluster, once."""
        if run.index in self._cluster_of:
            return self._cluster_of[run.index]
        close = self._failing.distances(run.unit) if len(self._failing) else ()
        near = {id(c): c for j in (j for j, x in enumerate(close) if x < RADIUS) for c in (self._cluster_of[self._failing_runs[j]],)}
        joined = [c for c in self.clusters if id(c) in near]
        if into is None:
            into = joined[0] if joined else next((c for c in self.clusters if c.contains(run.unit, self.space)), None)
        if into is None:
            into = Cluster([], run.index)
            self.clusters.append(into)
        self._join(into, run)
        for other in joined:
            if other is not into:
                self._merge(into, other)
        return into

    def _join(self, cluster: Cluster, run: Run) -> None:
        """*run* becomes a member of *cluster*: the distances to the failures and the counterexample follow."""
        cluster.members.append(run.index)
        cluster.extend(run.unit, self.space)
        self._cluster_of[run.index] = cluster
        self._failing.add(run.unit)
        self._failing_runs.append(run.index)
        self._near = self._all.lower(self._near, run.unit)
        if (self._from_nominal[run.index], run.index) < (self._from_nominal[cluster.shrunk], cluster.shrunk) or len(cluster.members) == 1:
            cluster.shrunk = run.index

    def _merge(self, into: Cluster, other: Cluster) -> None:
        for i in other.members:
            self._cluster_of[i] = into
        into.members = sorted(into.members + other.members)
        into.boundary += other.boundary
        into.refined = into.refined or other.refined
        for d, a, b in zip(self.space.dimensions, into.span, other.span):
            if d.continuous:
                a[0], a[1] = min(a[0], b[0]), max(a[1], b[1])
            else:
                a |= b
        if (self._from_nominal[other.shrunk], other.shrunk) < (self._from_nominal[into.shrunk], into.shrunk):
            into.shrunk = other.shrunk
        self.clusters.remove(other)

    def _bounded(self, cluster: Cluster, boundary: Boundary) -> None:
        """A pass/fail pair found for *cluster*: its midpoint widens the cluster's box."""
        cluster.boundary.append(boundary)
        p, f = self.runs[boundary.passing].unit, self.runs[boundary.failing].unit
        cluster.extend([(x + y) / 2 for x, y in zip(p, f)], self.space, member=False)

    def _refine(self, cluster: Cluster) -> None:
        """Shrink, then bound, *cluster*'s counterexample; each round one batch, within the budget."""
        for phase, steps in (("shrink", self._shrink(cluster)), ("bound", self._bound(cluster))):
            try:
                points = next(steps)
                while True:
                    if len(points) > self.left:
                        self.notes.append(f"the budget ended during the {phase} of cluster {self.clusters.index(cluster) + 1}")
                        cluster.refined = True
                        return
                    runs = self._run_points(points, phase)
                    for r in runs:
                        if r.failed:
                            self._place(r, cluster)
                    points = steps.send(runs)
            except StopIteration:
                pass
        cluster.refined = True

    def _resolved(self, a: Sequence[float], b: Sequence[float], where: Sequence[int] | None = None) -> bool:
        """Whether *a* and *b* are within the resolution of every continuous parameter (*where*: the
        parameters their coordinates are, in order; None: every parameter's)."""
        dims = self.space.dimensions if where is None else [self.space.dimensions[i] for i in where]
        return all(abs(x - y) <= d.unit_resolution(x) + 1e-12 for d, x, y in zip(dims, a, b) if d.continuous)

    def _shrink(self, cluster: Cluster) -> Generator[list[list[float]], list[Run], None]:
        """The cluster's failure nearest to the nominal point, within the declared resolution: along the
        segment from the nominal point to the failure first; then coordinate by coordinate - each continuous
        parameter moved from the nearest failure so far towards its nominal value, the others held
        (:data:`NEARER_ROUNDS` rounds, or until a round moves nothing); then along the region's boundary
        (:data:`BOUNDARY_ROUNDS` rounds: :meth:`_along_boundary`, :meth:`_towards`). The segment alone finds
        only the nearest failure on its line (on a hidden 4-parameter box region, 0.93-1.09 from the nominal
        point where the region's nearest point is 0.89); a box-shaped region's nearest point is reached
        coordinate by coordinate in one round, a ball's only along its boundary."""
        fail = self.runs[cluster.shrunk]
        origin = [n if n is not None else f for n, f in zip(self.nominal, fail.unit)]
        for d, i in zip(self.space.dimensions, range(len(origin))):
            if not d.continuous:
                origin[i] = fail.unit[i]  # lists keep the failure's choice: the segment is continuous
        yield from self._segment(cluster, origin, fail, None)
        for _ in range(NEARER_ROUNDS):
            moved = False
            for i, d in enumerate(self.space.dimensions):
                best = self.runs[cluster.shrunk]
                if not d.continuous or self.nominal[i] is None or abs(best.unit[i] - self.nominal[i]) <= d.unit_resolution(best.unit[i]) + 1e-12:
                    continue
                towards = list(best.unit)
                towards[i] = self.nominal[i]
                yield from self._segment(cluster, towards, best, d.name)
                moved = moved or cluster.shrunk != best.index
            if not moved:
                break
        for _ in range(BOUNDARY_ROUNDS):
            best = self.runs[cluster.shrunk]
            cont = [i for i, d in enumerate(self.space.dimensions) if d.continuous and self.nominal[i] is not None]
            at_nominal = self._resolved([best.unit[i] for i in cont], [self.nominal[i] for i in cont], cont)  # type: ignore[misc]
            if best.objective is None or not cont or at_nominal:
                break  # nothing to go by, or nothing nearer: the failure is at the nominal point
            probes = [self._probe(best.unit, i) for i in cont]
            runs = yield probes
            for r in runs:
                if r.failed:
                    self._place(r, cluster)
            found = self._along_boundary(best, cont, runs)
            if found is None:
                break
            for step in STEPS:  # the plane's point, then nearer to the failure: a boundary that curves away
                target, inward = self._towards(best.unit, cont, *found, step)
                if self._resolved(target, best.unit):
                    break
                (deep,) = yield [inward]
                if deep.failed:
                    self._place(deep, cluster)
                    yield from self._segment(cluster, target, deep, None, bounded=False)
                    if self._from_nominal[cluster.shrunk] < self._from_nominal[best.index] - 1e-9:
                        break
            if self._from_nominal[cluster.shrunk] >= self._from_nominal[best.index] - 1e-9:
                break

    def _probe(self, unit: Sequence[float], i: int) -> list[float]:
        """*unit* moved along parameter *i* by :data:`PROBE` resolutions (at least 0.005 of its range) towards
        its nominal value (up from the box's low edge where they are equal)."""
        d = self.space.dimensions[i]
        h = max(PROBE * d.unit_resolution(unit[i]), 0.005)
        step = h if (self.nominal[i] or 0.0) > unit[i] or unit[i] - h < 0.0 else -h
        out = list(unit)
        out[i] = min(1.0, max(0.0, unit[i] + step))
        return out

    def _along_boundary(self, fail: Run, cont: Sequence[int], probes: Sequence[Run]) -> tuple[list[float], list[float]] | None:
        """Where the failing region's boundary is nearest to the nominal point as the objective's local linear
        model draws it, and the plane's unit normal (:func:`~.surrogate.boundary_projection`: its plane
        through *fail* and one probe along each parameter; coordinates of the parameters *cont*). None where
        a probe has no objective or the objective is flat."""
        near = [([r.unit[i] for i in cont], r.objective) for r in (fail, *probes)]
        if any(y is None for _, y in near):
            return None
        return boundary_projection(near, [fail.unit[i] for i in cont], [self.nominal[i] for i in cont])  # type: ignore[arg-type, misc]

    def _towards(self, fail: Sequence[float], cont: Sequence[int], point: Sequence[float], normal: Sequence[float],
                 step: float) -> tuple[list[float], list[float]]:  # fmt: skip
        """The way *step* of *fail* to the plane's *point*, and a point as far again from there into the
        region along the plane's *normal*: the boundary between the two is nearer to the nominal point than
        *fail* (the plane's point passes where the region curves away from the plane - a ball seen from
        outside - so the step shrinks until the point inside fails)."""
        target, inward = list(fail), list(fail)
        depth = step * math.dist(point, [fail[i] for i in cont])
        for i, u, g in zip(cont, point, normal):
            target[i] = fail[i] + step * (u - fail[i])
            inward[i] = min(1.0, max(0.0, target[i] - depth * g))
        return target, inward

    def _segment(self, cluster: Cluster, origin: Sequence[float], fail: Run, along: str | None,
                 bounded: bool = True) -> Generator[list[list[float]], list[Run], None]:  # fmt: skip
        """k-section of the segment from *origin* to the failing run *fail* until the pass/fail pair is within
        the resolution of every parameter (the first round includes *origin* itself): its failing end is
        the segment's failure nearest to *origin*; the pair is a boundary point (*along*: the parameter the
        segment follows, None: towards the nominal point; not *bounded*: a boundary round's segment, whose
        direction is neither, is no boundary point of the report)."""

        def at(t: float) -> list[float]:
            return [o + t * (f - o) if d.continuous else f for d, o, f in zip(self.space.dimensions, origin, fail.unit)]

        lo, hi, hi_run = 0.0, 1.0, fail
        first = True
        pass_run: Run | None = None
        seen = self._seen.get(tuple(self.space.snap(at(0.0))))
        before = self.runs[seen] if seen is not None else None
        if before is not None:  # the segment's origin ran before (a failing nominal point: every shrink ends there)
            first = False
            if before.failed:  # the shrink ends at once; the run stays in its own cluster
                hi, hi_run = 0.0, before
            else:
                pass_run = before
        k = self.settings.batch
        while hi > 0.0 and not self._resolved(at(lo), at(hi)):
            ts = ([0.0] if first else []) + [lo + (hi - lo) * j / (k + 1) for j in range(1, k + 1 - (1 if first else 0))]
            runs = yield [at(t) for t in ts]
            first = False
            new_lo, new_hi = lo, hi
            for t, r in zip(ts, runs):
                if r.failed:
                    new_hi, hi_run = t, r
                    break
                new_lo, pass_run = t, r
            lo, hi = new_lo, new_hi
            if hi == 0.0:
                break
        if bounded and pass_run is not None and self._cluster_of.get(hi_run.index) is cluster:
            self._bounded(cluster, Boundary(along, pass_run.index, hi_run.index))

    def _bound(self, cluster: Cluster) -> Generator[list[list[float]], list[Run], None]:
        """From the cluster's deepest failure (smallest objective), both ways along each continuous
        parameter: a passing box edge first, then k-section of [failing, passing] to the resolution."""
        base = min((self.runs[i] for i in cluster.members),
                   key=lambda r: (r.objective if r.objective is not None else 0.0, r.index))  # fmt: skip
        sides = [(i, edge) for i, d in enumerate(self.space.dimensions) if d.continuous
                 for edge in (0.0, 1.0) if abs(edge - base.unit[i]) > d.unit_resolution(base.unit[i])]  # fmt: skip

        def point(i: int, u: float) -> list[float]:
            p = list(base.unit)
            p[i] = u
            return p

        runs = yield [point(i, edge) for i, edge in sides]
        # side -> [failing u, passing u, failing run, passing run]; a side whose edge fails has no boundary
        found = {side: [base.unit[side[0]], side[1], base, r] for side, r in zip(sides, runs) if not r.failed}
        k = self.settings.batch
        while True:
            dims = self.space.dimensions  # only the side's parameter differs: _resolved's test on it alone
            active = [s for s, (f, p, _, _) in found.items() if not abs(f - p) <= dims[s[0]].unit_resolution(f) + 1e-12]
            if not active:
                break
            m = max(1, k // len(active))
            asking = [(s, found[s][0] + (found[s][1] - found[s][0]) * j / (m + 1)) for s in active for j in range(1, m + 1)]
            runs = yield [point(s[0], u) for s, u in asking]
            for (s, u), r in zip(asking, runs):  # per side from the failing end towards the passing one
                entry = found[s]
                if entry[1] == u or (r.failed and abs(u - entry[0]) > abs(entry[1] - entry[0])):
                    continue
                if r.failed:
                    entry[0], entry[2] = u, r
                elif abs(u - entry[0]) < abs(entry[1] - entry[0]):
                    entry[1], entry[3] = u, r
        for (i, _), (f, p, fr, pr) in found.items():
            self._bounded(cluster, Boundary(self.space.dimensions[i].name, pr.index, fr.index))
