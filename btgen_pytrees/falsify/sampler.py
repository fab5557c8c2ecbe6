"""``ask(n)`` / ``tell(values)``: the search's sampler, over our Gaussian-process model, the ``cmaes``
library and Optuna's samplers.

Every method but ``random`` starts with a *space-filling* stage: Sobol's
sequence over the unit box (:mod:`.space`; SciPy's ``qmc.Sobol`` points, made
once per process and dimension) randomised by a *digital shift* drawn from the
seed (every point's bits XORed with the same random bits: the points stay a
net, each search's are elsewhere), so the first runs cover the box evenly and
give the objective's scale (``gp``'s start runs the box's two opposite corners
first, when it has at least 4 runs); a box with input signals
(:attr:`~.space.Space.signals`) gets their values *shaped* - held pieces - in
every space-filling point but the ``sobol`` method's (:meth:`Sampler._shaped`).
Then:

* ``gp`` - a Gaussian-process model of the objective (:mod:`.surrogate`),
  refitted after every batch; each batch is the quadratic model's minimum
  (when there are runs enough for one and it ranks them), then the points most
  likely to fail under the model, spread by "kriging believer". List parameters are drawn
  uniformly.
* ``cmaes`` - CMA-ES (the ``cmaes`` library, which Optuna's ``CmaEsSampler``
  wraps; used directly because Optuna 5 deprecates that sampler's ``x0``,
  ``sigma0`` and restarts) started at the best start point with step size 0.2
  of the box, its population a multiple of the batch. It *restarts* from the
  next best start point not near an earlier start or a known failure when
  the library says it has converged or it has not improved for a while, and
  when the search asks for a new region (:meth:`Sampler.restart`). List
  parameters are drawn uniformly.
* ``tpe`` - Optuna's ``TPESampler`` (multivariate, constant liar for batches),
  given every run so far; for mixed and categorical spaces.
* ``sobol`` - the Sobol sequence on (space-filling only); ``random`` - uniform
  random (Optuna's ``RandomSampler``; no start stage: it is the baseline).
* ``auto`` - ``gp`` when every parameter is continuous, ``tpe`` when there is a list.

Points are asked in batches and told in the order they were asked, so a seed
gives the same search whatever the number of workers. Optuna's and NumPy's
generators and the Sobol points' shifts (:mod:`.qmc`) are seeded from the seed; nothing global is
changed (Optuna's log level is raised only around its calls, and put back; warnings are
silenced only around the calls into Optuna and the ``cmaes`` library).
"""

from __future__ import annotations

import bisect
import contextlib
import functools
import importlib.util
import math
import random
import warnings
from typing import Any, Callable, Iterator, Sequence

from .qmc import Draws, shifted_point
from .space import Space
from .surrogate import FULL_TERMS, KEEP, Model, one_thread, quadratic_minimum

__all__ = ["Sampler", "METHODS", "SearchUnavailable", "HINT", "available", "resolve_method"]

METHODS = ("auto", "gp", "cmaes", "tpe", "sobol", "random")
HINT = "falsify needs the 'search' extra (optuna, cmaes, scipy, threadpoolctl): pip install -e '.[search]'"

SIGMA0 = 0.2
"""CMA-ES's first step size, as a fraction of the unit box."""
STALL = 10
"""Runs told without a lower objective (plus :data:`STALL_PER` per continuous parameter) after which the ``gp`` model counts
as stalled (:attr:`Sampler.stalled`). It was 20 plus 2 per parameter (100 runs in 40 parameters): on ARCH-COMP's
CC5 the model then spent hundreds of runs in a bowl above zero where uniform random needs 59 to fail
(docs/performance.md, "ARCH-COMP chasing cars")."""
STALL_PER = 0.5
STALLED_SHARE = 0.5
"""The share of a stalled ``gp`` model's runs that are the Sobol sequence's (every other run at batch 1)."""
GAIN = 0.01
"""The least fall of the lowest objective that counts as progress (objectives are scaled: 1 is a criterion's
spread over the start), so a model creeping down a bowl whose bottom passes counts as stalled."""
SHAPE_CUTS = 3
"""The most changes of a shaped input signal (:meth:`Sampler._shaped`): its pieces are 1 to 4."""
SHAPE_MIN = 4
"""The fewest values a signal is shaped with: a signal of two or three values is a small box the model covers by
itself, and held at its ends it mostly fails a bound on it - a start of 4 runs then had too few passing runs to
show the criterion's gradient, and the model never ran."""
SHAPE_TRIES = 8
"""Draws of a shaped point before the space-filling point goes unshaped: a shape is never drawn twice (nor the
box's two corners, which the ``gp`` start runs). A signal held whole at one end is a likely draw (1 in 12 per
signal), and it is the start's corner again; repeated, such points made the start's margins alike and hid a
criterion's gradient (4 values per signal: 33 distinct points in 40 draws)."""
RESTART_SIGMA = 0.3
"""The step size of a restart (a new region: wider)."""


def _legacy_seed(seed: int) -> int:
    """*seed* for a generator that takes 0 to 2**32 - 1 only (NumPy's ``RandomState``, behind Optuna's samplers
    and the ``cmaes`` library): the seed modulo 2**32, so every non-negative seed - and a restart's seed
    above it - searches (a seed below the limit is itself)."""
    return seed % 2**32


class SearchUnavailable(RuntimeError):
    """The optional optimiser libraries are missing; ``str()`` says which extra to install."""


def available() -> bool:
    """Whether the ``search`` extra's libraries are installed (found, not imported: each method imports
    what it uses when it starts - Optuna for ``tpe`` and ``random``, ``cmaes`` for CMA-ES - so a search
    does not pay for the others' imports)."""
    return all(importlib.util.find_spec(name) is not None for name in ("cmaes", "optuna", "scipy", "numpy", "threadpoolctl"))


def resolve_method(method: str, space: Space) -> str:
    """``auto`` -> ``gp`` or ``tpe``; ``cmaes`` on fewer than two continuous parameters -> ``tpe``;
    ``gp`` without a continuous parameter -> ``tpe``."""
    if method == "auto":
        return "gp" if space.continuous and not space.categorical else "tpe"
    if method == "gp" and not space.continuous:
        return "tpe"
    if method == "cmaes" and len(space.continuous) < 2:
        return "tpe"  # the library's CMA-ES needs two dimensions at least
    return method


@contextlib.contextmanager
def _quiet(optuna: Any) -> Iterator[None]:
    """Warnings off (Optuna's experimental ones, the ``cmaes`` library's) for our calls only,
    and Optuna's INFO lines ("A new study created") when *optuna* is given: the calls that reach Optuna
    pass it (setting its log level costs more than a model's batch)."""
    level = optuna.logging.get_verbosity() if optuna is not None else None
    if optuna is not None:
        optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        if optuna is not None:
            optuna.logging.set_verbosity(level)


class Sampler:
    """Proposes unit points in batches; learns from their objectives (lower is closer to failing).

    Args:
        space: the searched box
        method: one of :data:`METHODS` (``auto`` is resolved here)
        seed: the seed of every generator
        start: how many space-filling points first (rounded up to a whole number of batches by the caller)
        batch: points per ask (CMA-ES's population is a multiple of it)
    """

    def __init__(self, space: Space, method: str, *, seed: int, start: int, batch: int):
        if not available():
            raise SearchUnavailable(HINT)
        import numpy

        self._np = numpy
        self.space = space
        self.method = resolve_method(method, space)
        self.seed = seed
        self.start = 0 if self.method == "random" else start
        self.batch = batch
        self.xs: list[list[float]] = []
        self.ys: list[float | None] = []
        self._unit: list[list[float]] = []  # each run's continuous coordinates (what the models see)
        self._ranked: list[tuple[float, int]] = []  # (objective, run) of the runs told one, least first
        self._lowest = math.inf  # the lowest objective told since the last restart, and the runs told since
        self._since = 0
        self._filling = 0  # space-filling points left in this batch (a stalled model's share)
        self._skip = self._skip_left = 0  # batches the quadratic sits out after a failed check (past 10 parameters)
        self._credit = 0.0  # the space-filling share's runs owed (a fraction carried from batch to batch)
        self._asked: list[tuple[str, Any, list[float]]] = []
        self._names = [d.name for d in space.dimensions]
        self._study: Any = None
        if self.method == "random":
            optuna = self._optuna
            with _quiet(optuna):
                self._study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=_legacy_seed(seed)))
        self._stage = "start" if self.start else self.method
        self._extremes = self._corners() if self.method == "gp" and self.start >= 4 else []
        self._draws = Draws(seed)  # the Sobol points' shifts: the start's (one), the models' candidates' (each theirs)
        self._shift = self._draws.shift(len(space.dimensions))
        self._sobol = 0  # Sobol points drawn
        self._shapes = random.Random(f"{seed}/signal shapes")  # the shapes' draws (a string seed: the same in every process)
        self._shapes_drawn: set[tuple[float, ...]] = {tuple(x) for x in self._extremes}  # no shaped point twice
        self._told_keys: set[tuple[float, ...]] = set()  # the told runs' continuous points, rounded (_told_before)
        self._cma: Any = None
        self._queue: list[list[float]] = []
        self._model = Model(self._draws)
        self._generation: list[tuple[Any, float | None]] = []
        self._starts: list[list[float]] = []
        self._stale = 0
        self._best = math.inf
        self.restarts = 0
        self.avoid: Callable[[int], bool] = lambda _k: False
        """Runs (by their number here: the order told) the searcher should not start from (e.g. inside a known
        failure cluster)."""

    # -- the interface ------------------------------------------------------------------------------

    @functools.cached_property
    def _optuna(self) -> Any:
        """Optuna, imported when a stage asks it (``tpe``, ``random``): its import costs about a third of a second
        of a process's start-up, which the ``gp`` and ``cmaes`` methods need not pay."""
        import optuna

        return optuna

    @functools.cached_property
    def _rng(self) -> Any:
        """NumPy's generator, seeded with the seed: made for the methods that draw with it (a list parameter's
        choice, CMA-ES's random start), not for every search (:mod:`.qmc`)."""
        return self._np.random.default_rng(self.seed)

    @functools.cached_property
    def _dists(self) -> dict[str, Any]:
        """Each parameter's Optuna distribution (made when a stage asks Optuna: ``tpe`` and ``random``)."""
        dists = self._optuna.distributions
        return {d.name: (dists.FloatDistribution(0.0, 1.0) if d.continuous else
                         dists.CategoricalDistribution(list(range(len(d.choices))))) for d in self.space.dimensions}  # fmt: skip

    @property
    def model(self) -> Model:
        """The ``gp`` method's Gaussian-process model (its length scales and when they were fitted)."""
        return self._model

    @property
    def stage(self) -> str:
        """``start`` (space-filling), then the method's own stage (``sobol`` when it fell back)."""
        return self._stage

    def ask(self, n: int) -> list[list[float]]:
        """*n* new unit points (a choice index for each list parameter); the models' linear algebra on one
        BLAS thread (:func:`~.surrogate.one_thread`)."""
        if self._stage not in ("gp", "cmaes") and not (self._stage == "start" and len(self.xs) + len(self._asked) >= self.start):
            return self._ask(n)  # no linear algebra to limit: the start, the Sobol sequence, Optuna's samplers
        with one_thread():
            return self._ask(n)

    def _ask(self, n: int) -> list[list[float]]:
        if self._stage == "start" and len(self.xs) + len(self._asked) >= self.start:
            self._switch(self.method)
        points = []
        optuna = self._study is not None and self._stage in ("tpe", "random")
        with _quiet(self._optuna if optuna else None) if optuna or self._stage == "cmaes" else contextlib.nullcontext():
            for _ in range(n):
                if self._stage == "cmaes" and self.batch > 1 and not self._asked:  # one model point per batch
                    x = self._model_point()
                    if x is None:  # too few runs for a model: the Sobol sequence
                        self._asked.append(("sobol", None, self._filling_point()))
                    else:
                        self._asked.append(("model", x, self._with_choices(x)))
                elif self._stage == "gp" and self._filling > 0:  # stalled: a share of the batch space-filling
                    self._filling -= 1
                    self._asked.append(("sobol", None, self._filling_point()))
                elif self._stage == "gp":
                    if not self._asked:  # the batch's share of space-filling points
                        self._credit += STALLED_SHARE * (n - len(points)) if self.stalled else 0.0
                        self._filling = math.floor(self._credit + 1e-9)
                        self._credit -= self._filling
                        if self._filling > 0:
                            self._filling -= 1
                            self._asked.append(("sobol", None, self._filling_point()))
                            points.append(self._asked[-1][2])
                            continue
                    if not self._asked or not self._queue:  # a batch's points at once (the quadratic's first)
                        first = None if self._asked else self._model_point(check=True)
                        if first is not None and self._told_before(first):
                            first = None  # its minimum at a point run before (a corner, mostly): the process chooses
                        if first is not None and n - len(points) == 1:  # the batch is the quadratic's point alone
                            self._queue = [[float(u) for u in first]]
                        else:
                            kept = self._kept()
                            X, y = [self._unit[i] for i in kept], [self.ys[i] for i in kept]
                            self._queue = self._model.propose(X, y, n - len(points), first=first, told=len(self._ranked))  # type: ignore[arg-type]
                    x = self._queue.pop(0)
                    if self._told_before(x):  # the process's pick clipped onto a run point: a space-filling one instead
                        self._asked.append(("sobol", None, self._filling_point()))
                    else:
                        self._asked.append(("model", x, self._with_choices(x)))
                elif self._stage == "cmaes":
                    x = self._cma.ask()
                    self._asked.append(("cma", x, self._with_choices(x)))
                elif self._stage == "start" and self._extremes:  # the box's extreme points first
                    self._asked.append(("sobol", None, self._extremes.pop(0)))
                elif self._stage in ("start", "sobol"):  # the start, or the Sobol sequence on
                    self._asked.append(("sobol", None, self._filling_point()))
                else:
                    trial = self._study.ask(self._dists)
                    self._asked.append(("trial", trial, [float(trial.params[k]) for k in self._names]))
                points.append(self._asked[-1][2])
        return [list(p) for p in points]

    def tell(self, values: Sequence[float | None]) -> None:
        """The objectives of the points asked (``None``: the run erred), in the order asked (CMA-ES's update
        on one BLAS thread, as :meth:`ask`)."""
        if self._stage != "cmaes":
            self._tell(values)  # only CMA-ES's update does linear algebra here
            return
        with one_thread():
            self._tell(values)

    def _tell(self, values: Sequence[float | None]) -> None:
        if len(values) != len(self._asked):
            raise ValueError(f"told {len(values)} values for {len(self._asked)} points asked")
        trials = any(kind == "trial" for kind, _, _ in self._asked)
        state = self._optuna.trial.TrialState if trials else None
        with _quiet(self._optuna) if trials else contextlib.nullcontext():  # only Optuna's tell warns
            for (kind, handle, point), value in zip(self._asked, values):
                if value is not None:
                    bisect.insort(self._ranked, (value, len(self.ys)))
                    if value < self._lowest - GAIN:
                        self._lowest, self._since = value, 0
                    else:
                        self._since += 1
                self.xs.append(point)
                self.ys.append(value)
                self._unit.append(self._continuous(point))
                if kind == "trial":
                    if value is None:
                        self._study.tell(handle, state=state.FAIL)
                    else:
                        self._study.tell(handle, value)
                elif kind == "cma":
                    self._generation.append((handle, value))
        self._asked = []
        if self._stage == "cmaes" and len(self._generation) >= self._cma.population_size:
            self._cma_tell()

    @property
    def stalled(self) -> bool:
        """Whether the ``gp`` model has stopped finding lower objectives: :data:`STALL` runs (plus half a run per
        parameter) told without a lower one. Then half of each batch - every other run at batch 1 - is the
        Sobol sequence's, until a run beats the lowest: a model that settles above zero (a bowl whose bottom
        passes, far from a small failing region) would never look elsewhere, where uniform random
        sampling finds the region at its rate; with the share it finds it at half that rate at worst."""
        return self._since >= STALL + STALL_PER * len(self.space.continuous)

    def rescore(self, values: Sequence[float | None]) -> None:
        """Replace the objectives told so far (e.g. once the criteria's scales are known); the next
        stage learns from these."""
        self.ys = list(values)
        self._rank()
        self._lowest = self._ranked[0][0] if self._ranked else math.inf  # the same runs, told in new units

    def restart(self, values: Sequence[float | None] | None = None) -> None:
        """Look elsewhere: CMA-ES restarts from a new point, TPE relearns from *values* (one per run so far)."""
        if values is not None:
            self.ys = list(values)
            self._rank()
        self._lowest, self._since = math.inf, 0  # a new region: the stall is counted anew
        if self._stage == "cmaes":
            self._new_cma(RESTART_SIGMA)
        elif self._stage == "tpe":
            self._switch("tpe")

    def space_filling(self) -> None:
        """Go on with the Sobol sequence only (the objective gives no direction to follow)."""
        if self._stage == "start":
            self.start = math.inf  # type: ignore[assignment]
        elif self._stage != "random":  # uniform random fills the space already
            self._stage = "sobol"

    # -- stages -------------------------------------------------------------------------------------

    def _switch(self, stage: str) -> None:
        self._stage = stage
        if stage == "tpe":
            optuna = self._optuna
            with _quiet(optuna):
                sampler = optuna.samplers.TPESampler(seed=_legacy_seed(self.seed + 1 + self.restarts), n_startup_trials=0, multivariate=True,
                                                     constant_liar=True, warn_independent_sampling=False)  # fmt: skip
                study = optuna.create_study(sampler=sampler)
                study.add_trials([optuna.trial.create_trial(params=self._params(x), distributions=self._dists, value=y)
                                  for x, y in zip(self.xs, self.ys) if y is not None])  # fmt: skip
            self._study = study
            self.restarts += 1
        elif stage == "cmaes":
            self._new_cma(SIGMA0)

    def _corners(self) -> list[list[float]]:
        """The box's two opposite corners: every parameter at its low end, then every one at its high
        end (a list parameter: its first choice, then its last)."""
        dims = self.space.dimensions
        return [[0.0] * len(dims), [1.0 if d.continuous else float(len(d.choices) - 1) for d in dims]]

    def _filling_point(self) -> list[float]:
        """A space-filling point: the Sobol sequence's next, its input signals' values (where the space has
        them: :attr:`~.space.Space.signals`) shaped along each signal (:meth:`_shaped`) - except for the
        ``sobol`` method, which is the sequence alone (the uniform cover, for a failure only a signal jumping
        at every control point reaches). No shaped point is drawn twice (:data:`SHAPE_TRIES`)."""
        point = self._sobol_point()
        if self.method == "sobol" or all(len(signal) < SHAPE_MIN for signal in self.space.signals):
            return point
        for _ in range(SHAPE_TRIES):  # a shape drawn before (the box's corners among them) is drawn again
            shaped = self._shaped(point)
            key = tuple(shaped)
            if key not in self._shapes_drawn:
                self._shapes_drawn.add(key)
                return shaped
        return point  # a signal of few values has few shapes: the Sobol point, unshaped

    def _shaped(self, point: list[float]) -> list[float]:
        """*point* with each input signal's values replaced by a shape a driver or a set-point makes: 0 to
        :data:`SHAPE_CUTS` changes at random control points, each piece held at the low end, the high end or
        a uniform value (a third each). A uniform point is a signal that jumps at every control point; the
        inputs that break a system are more often held ones - a pedal released, held down, then let go -
        which a uniform draw makes with vanishing odds (on ARCH-COMP's chasing cars 0.8 % of uniform
        inputs fail CC1 and 30 % of shaped ones; docs/falsify.md, "Input signals")."""
        draw = self._shapes
        out = list(point)
        for signal in self.space.signals:
            n = len(signal)
            if n < SHAPE_MIN:
                continue
            cuts = sorted(draw.sample(range(1, n), draw.randint(0, min(SHAPE_CUTS, n - 1))))
            for a, b in zip([0, *cuts], [*cuts, n]):
                u = draw.random()
                value = 0.0 if u < 1 / 3 else 1.0 if u < 2 / 3 else draw.random()
                for k in signal[a:b]:
                    out[k] = value
        return out

    def _sobol_point(self) -> list[float]:
        """The next point of the Sobol sequence, digitally shifted (a list parameter: its choice at that fraction)."""
        k = self._sobol
        self._sobol += 1
        u = shifted_point(len(self.space.dimensions), k, self._shift)
        return [float(v) if d.continuous else float(min(len(d.choices) - 1, int(v * len(d.choices))))
                for d, v in zip(self.space.dimensions, u)]  # fmt: skip

    def _params(self, x: Sequence[float]) -> dict[str, Any]:
        return {k: (float(u) if d.continuous else int(u)) for k, d, u in zip(self._names, self.space.dimensions, x)}

    def _continuous(self, x: Sequence[float]) -> list[float]:
        return [u for d, u in zip(self.space.dimensions, x) if d.continuous]

    def _with_choices(self, x: Any) -> list[float]:
        out, it = [], iter(float(v) for v in x)
        for d in self.space.dimensions:
            out.append(next(it) if d.continuous else float(self._rng.integers(len(d.choices))))
        return out

    def _new_cma(self, sigma: float) -> None:
        from cmaes import CMA

        np = self._np
        dims = len(self.space.continuous)
        ranked = self._ranked
        x0 = None
        for _, i in ranked:
            x = self.xs[i]
            if self.avoid(i) or any(self.space.distance(x, s) < 0.1 for s in self._starts):
                continue
            x0 = x
            break
        if x0 is None:
            x0 = [float(u) for u in self._rng.random(len(self.space.dimensions))]
        self._starts.append(list(x0))
        base = 4 + math.floor(3 * math.log(dims))
        per = self.batch - 1 if self.batch > 1 else 1  # CMA-ES's points of a batch (the first is the model's)
        size = per * max(1, math.ceil(base / per))
        mean = np.clip(np.array(self._continuous(x0), dtype=float), 0.0, 1.0)
        self._cma = CMA(mean=mean, sigma=sigma, bounds=np.array([[0.0, 1.0]] * dims), seed=_legacy_seed(self.seed + 7919 * len(self._starts)),
                        population_size=size)  # fmt: skip
        self._generation = []
        self._stale = 0
        self._best = math.inf
        if len(self._starts) > 1:
            self.restarts += 1

    def _model_point(self, check: bool = False) -> Any:
        """The minimum of a quadratic model of the objective fitted to the best runs so far (as in
        lq-CMA-ES), or None when too few runs fit one (or, with *check*, when it does not rank its own
        runs: the ``gp`` method's model chooses instead); the first point of each batch."""
        d = len(self.space.continuous)
        full = (d + 1) * (d + 2) // 2
        large = full > FULL_TERMS
        if check and large and self._skip_left > 0:  # a model that failed its check lately: not every batch
            self._skip_left -= 1
            return None
        most = 3 * (full if not large else 2 * d + 1)  # the most runs the quadratic is fitted to
        told = []
        for y, i in self._ranked:  # the best runs first: the walk stops at the most the model takes
            if not self.avoid(i):
                told.append((self._unit[i], y))
                if len(told) == most:
                    break
        point = quadratic_minimum(told, d, self._draws, check=check)
        if check and large and len(told) >= 2 * d + 3:  # fitted, past 10 parameters: a failed check is tried
            self._skip = 0 if point is not None else min(8, max(1, 2 * self._skip))  # again after 1, 2, 4, then 8 batches
            self._skip_left = self._skip
        return point

    def _told_before(self, x: Any) -> bool:
        """Whether the continuous point *x* is one told already (to 1e-9): the quadratic's minimum (or the
        process's pick) clipped to the box sits on a corner run long ago, and asked again it ran again - 21 of
        a one-parameter search's 30 runs were its failing corner, each counted a new failing run."""
        key = tuple(round(float(u), 9) for u in x)
        if len(self._told_keys) < len(self._unit):
            self._told_keys.update(tuple(round(u, 9) for u in unit) for unit in self._unit[len(self._told_keys):])
        return key in self._told_keys

    def _rank(self) -> None:
        self._ranked = sorted((y, i) for i, y in enumerate(self.ys) if y is not None)

    def _kept(self) -> list[int]:
        """The told runs the ``gp`` model is fitted to, in order: all of them up to :data:`~.surrogate.KEEP`,
        then the best half and the most recent others (:meth:`~.surrogate.Model.propose`'s choice, made from
        the ranked runs: a batch's bookkeeping does not grow with the runs)."""
        if len(self._ranked) <= KEEP:
            return sorted(i for _, i in self._ranked)
        best = {i for _, i in self._ranked[: KEEP // 2]}
        recent: list[int] = []
        i = len(self.ys) - 1
        while len(recent) < KEEP - len(best):
            if self.ys[i] is not None and i not in best:
                recent.append(i)
            i -= 1
        return sorted(best.union(recent))

    def _cma_tell(self) -> None:
        told = [y for _, y in self._generation if y is not None]
        worst = max(told) if told else 1.0
        pairs = [(x, worst + 1.0 if y is None else y) for x, y in self._generation]
        self._generation = []
        self._cma.tell(pairs)
        best = min(y for _, y in pairs)
        if best < self._best - 1e-9 * max(1.0, abs(self._best)):
            self._best, self._stale = best, 0
        else:
            self._stale += 1
        patience = 10 + math.ceil(30 * len(self.space.continuous) / self._cma.population_size)
        if self._cma.should_stop() or self._stale >= patience:
            self._new_cma(RESTART_SIGMA)
