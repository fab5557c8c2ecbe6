"""A Gaussian-process model of the objective, and the batch of points most likely to fail under it.

The ``gp`` method of :mod:`.sampler` asks it for each batch after the start.
It is ordinary kriging on the unit box, small enough to refit every batch:

* a **Gaussian process** with a constant mean and a squared-exponential kernel,
  one length scale per continuous parameter (so the model is not separable: the
  kernel couples the parameters, and a parameter the objective hardly depends on
  gets a long scale). The scales maximise the profile likelihood over a few
  candidates, scored a round at a time: at the first fit a range of equal
  scales, then the best of them with each parameter's halved and with it
  doubled; later fits the previous scales and each parameter's times 0.6 (or
  1.6, on alternate fits: the model follows the runs without a full search
  every batch); then, when two or more parameters gained, all their changes
  at once. The scales are fitted at every batch while the model sees every run
  (up to :data:`KEEP`), then once the runs told have grown by :data:`REFIT`;
* a point's **acquisition** is its probability of failing under the model,
  P(objective < 0) = Phi(-mean / sd): high near runs that came close to failing
  and far from every run (exploration), with no weight to tune (ranked by
  mean / sd, the same order);
* a **batch** is chosen greedily from candidate points (uniform ones, and normal
  ones around the best runs at several distances: Sobol points under a fresh
  random shift, :class:`~.qmc.Draws`): the most likely to fail first;
  then the model is told that point's predicted value ("kriging believer": the
  uncertainty around it shrinks, its mean stays) and the next is chosen, so a
  batch spreads over the promising places instead of piling onto one.

It is fitted to at most :data:`KEEP` runs (the best half and the most recent
others) and scores :data:`CANDIDATES` points, so its cost per batch stays about
half a millisecond whatever the budget (the products stay small enough for the
BLAS library to run them on one thread: on a busy machine its threads only wait
for one another; LAPACK's Cholesky and triangular solves are called directly,
as NumPy's and SciPy's wrappers cost more than these small matrices' arithmetic).

:func:`quadratic_minimum` is the minimum of a quadratic model fitted to the best
runs (as in lq-CMA-ES); with ``check`` it is given only when the model ranks its
own runs (leave-one-out, Kendall's tau of at least :data:`TRUST`); its minimum is
the best of 1,024 such candidates, half around the best run and half uniform.
NumPy and SciPy (the ``search`` extra) are imported once, when the model first
proposes a batch (an import statement per batch cost more than the batch's
arithmetic; SciPy's LAPACK and ``scipy.special`` cost a ``falsify`` process about
0.15-0.2 s of processor time, which a search ending within its start's runs,
or a process still starting its workers, does not pay).
"""

from __future__ import annotations

import contextlib
import functools
import heapq
import math
from typing import Any, Sequence

from .qmc import Draws

__all__ = ["Model", "quadratic_minimum", "boundary_projection", "KEEP", "CANDIDATES", "REFIT", "TRUST", "FULL_TERMS", "one_thread"]

KEEP = 32
"""Most runs the model is fitted to."""
CANDIDATES = 256
"""Candidate points per batch (half uniform, half around the best runs)."""
TRUST = 0.85
"""The quadratic model's leave-one-out rank correlation with its runs below which its minimum is not
proposed (lq-CMA-ES's threshold for trusting its model)."""
FULL_TERMS = 66
"""Most terms of a full quadratic model (d <= 10 parameters); past it the model has no cross terms. A full
quadratic in 20 parameters has 231 terms, fitted to up to 693 runs: 20-30 ms per batch (a singular value
decomposition and a rank check of that size), more than a run of 20 ms; without cross terms, 41 terms and
at most 123 runs (docs/falsify.md, "Cost")."""
REFIT = 1.25
"""The scales are fitted at every batch while the model sees every run (up to :data:`KEEP`); after that
again once the runs told have grown by this factor since their last fit (the factor and the
prediction are computed for every batch)."""
_SPREAD = (0.02, 0.05, 0.1, 0.2)
"""Distances (standard deviations, in the unit box) of the candidates around the best runs."""
_FIRST = (0.1, 0.3, 1.0)
_NUGGET = 1e-6
_EPS = 2.220446049250313e-16
"""``numpy.finfo(float).eps``."""
_LONGEST = 4.0


class Model:
    """The model's state between batches (its length scales) and its draws (the candidates' shifts, :mod:`.qmc`)."""

    def __init__(self, draws: Draws):
        self.draws = draws
        self.scales: Any = None
        self.fitted = 0
        """How many runs had been told when the scales were last fitted."""
        self.refits = 0
        """How many fits have started from the previous scales (their factor alternates: 0.6, 1.6, ...)."""

    def propose(self, X: Sequence[Sequence[float]], y: Sequence[float], n: int, first: Any = None,
                told: int | None = None) -> list[list[float]]:
        """*n* points of the unit box most likely to fail (objective < 0) under the model fitted to the
        runs *X* (unit points, continuous coordinates) with objectives *y*; the most likely first
        (*first*, if given, is taken first whatever its score: the others spread around it).
        Uniform points when fewer than two runs are known. *told*: how many runs were told in all, when
        *X* is the sampler's choice of them already (the scales' refits follow the runs told)."""
        np, lapack, ndtri = _libraries()
        draws = self.draws
        told = len(y) if told is None else told
        if len(y) > KEEP:  # the best half and the most recent others, chosen before any array is made (the
            # runs told grow with the budget; what the model sees does not)
            best = set(heapq.nsmallest(KEEP // 2, range(len(y)), key=lambda i: (y[i], i)))
            recent = [i for i in range(len(y) - 1, -1, -1) if i not in best][: KEEP - len(best)]
            keep = sorted(best | set(recent))
            X, y = [X[i] for i in keep], [y[i] for i in keep]
        Xa, ya = np.asarray(X, dtype=float), np.asarray(y, dtype=float)
        d = Xa.shape[1] if Xa.ndim == 2 else 0
        if len(ya) < 2 or d == 0:
            return draws.uniform(np.empty((n, d))).tolist()
        # the arrays' and ufuncs' own methods below: NumPy's Python-level wrappers (sum, argsort, argmax)
        # cost more than these small arrays' work
        mu = float(np.add.reduce(ya)) / len(ya)
        r = ya - mu
        sq = ((Xa[:, None, :] - Xa[None, :, :]) ** 2).reshape(-1, d)  # (n x n) x d
        L = None
        if self.scales is None or len(self.scales) != d or told <= KEEP or told >= REFIT * self.fitted:
            self.scales, L = self._scales(np, lapack, sq, r, d)
            self.fitted = told
        # candidates: uniform, and around the best runs at several distances
        m = max(CANDIDATES, 2 * n)
        m_local = m // 2
        if L is None:  # the scales kept, or no candidate's matrix factored with the smallest nugget
            L = self._factor(np, lapack, sq, self.scales)
        inverse = lapack.dtrtri(L, lower=1)[0]  # L^-1 (LAPACK's; a triangular solve with n right-hand sides is far slower)
        alpha = inverse.T @ (inverse @ r)
        ranked = ya.argsort(kind="stable")[:4]
        turn, spread = local_pattern(m_local, len(ranked))
        centres = Xa[ranked[turn]]
        # written in place into one array (the same values as the sums and products spelt out: a small
        # array's every temporary costs more than its arithmetic): m Sobol points under one shift, the
        # first m - m_local uniform, the others through the normal quantile function (each centre's and
        # spread's points a block of consecutive ones: a net of their own, see local_pattern)
        C = np.empty((m + (first is not None), d))
        draws.uniform(C[:m])
        local = C[m - m_local : m]
        ndtri(local, out=local)  # normal(0, 1) points
        local *= spread
        local += centres  # centre + draw * spread
        np.maximum(local, 0.0, out=local)
        np.minimum(local, 1.0, out=local)
        if first is not None:
            C[m] = first
        Xs, Cs = Xa / self.scales, C / self.scales
        halves = _halves(d)
        cc = (Cs * Cs) @ halves  # half each row's squared norm: a product, where a reduction along a short axis is slow
        k = Xs @ Cs.T  # n x m: exp(x.c - |x|^2/2 - |c|^2/2), at most 1
        k -= ((Xs * Xs) @ halves)[:, None]
        k -= cc
        np.minimum(k, 0.0, out=k)
        np.exp(k, out=k)
        V = inverse @ k
        mean = k.T @ alpha
        mean += mu
        var = np.add.reduce(V * V, axis=0)
        np.subtract(1.0, var, out=var)
        np.maximum(var, 1e-12, out=var)  # in units of the process's variance
        chosen: list[int] = []
        for _ in range(min(n, len(C))):
            # P(objective < 0) = Phi(-mean / sd): the most likely to fail has the least mean / sd (the
            # process's own variance scales every sd alike), which is ranked without Phi - and without its
            # rounding to exactly 0 and 1 far in its tails, where it would tie the candidates
            z = mean / np.sqrt(var)
            if chosen:
                z[chosen] = math.inf
            j = len(C) - 1 if first is not None and not chosen else int(z.argmin())
            chosen.append(j)
            if len(chosen) == n:  # the batch is complete: nothing more to believe
                break
            # kriging believer: the point is told as predicted; the variance around it shrinks
            cov = np.exp(np.minimum(Cs @ Cs[j] - cc - cc[j], 0.0)) - V.T @ V[:, j]
            if var[j] > 1e-9:  # a point the runs already pin down teaches nothing (and would divide by ~0)
                row = cov / math.sqrt(float(var[j]))
                var = np.maximum(var - row * row, 1e-12)
                V = np.concatenate([V, row[None, :]])
        return [C[j].tolist() for j in chosen]

    def _scales(self, np: Any, lapack: Any, sq: Any, r: Any, d: int) -> tuple[Any, Any]:
        """The length scales with the best profile likelihood among a few candidates, and the Cholesky
        factor of their correlation matrix (None when no candidate's factored). Candidates are scored a
        round at a time (:func:`_round`): at the first fit the equal scales of :data:`_FIRST`, then the best
        of them with each parameter's scale halved and doubled; at a later fit the previous scales and each
        parameter's times 0.6 or 1.6 (on alternate fits); then, when two or more parameters gained, all
        their changes at once."""
        best: tuple[float, Any, Any] = (-math.inf, None, None)
        if self.scales is None or len(self.scales) != d:
            best = _round(np, lapack, sq, r, [np.full(d, s) for s in _FIRST], best)[0]
            base, factors, rounds = best[1], (0.5, 2.0), []
        else:
            self.refits += 1
            base, factors, rounds = self.scales, ((0.6,) if self.refits % 2 else (1.6,)), [self.scales]
        if d == 1:
            return _round(np, lapack, sq, r, rounds, best)[0][1:] if rounds else best[1:]
        trials = []
        for i in range(d):
            for f in factors:
                trial = base.copy()
                trial[i] = min(_LONGEST, trial[i] * f)
                trials.append(trial)
        best, lls = _round(np, lapack, sq, r, rounds + trials, best)
        start = lls[0] if rounds else best[0] if best[2] is not None else -math.inf
        gains = {}
        for j, (t, ll) in enumerate(zip(trials, lls[len(rounds):])):
            i = j // len(factors)
            if ll > start + 1e-9 and ll > gains.get(i, (-math.inf,))[0]:
                gains[i] = (ll, t[i])
        if len(gains) > 1:  # the gains at once: one more candidate
            joint = base.copy()
            for i, (_, s) in gains.items():
                joint[i] = s
            best = _round(np, lapack, sq, r, [joint], best)[0]
        return best[1], best[2]

    @staticmethod
    def _factor(np: Any, lapack: Any, sq: Any, scales: Any) -> Any:
        n = math.isqrt(len(sq))
        R = np.exp(sq @ (-0.5 / (scales * scales))).reshape(n, n)
        for nugget in (_NUGGET, 1e-4, 1e-2, 1.0):
            L, info = lapack.dpotrf(R + nugget * np.eye(n), lower=1, clean=1)
            if info == 0:
                return L
        return np.eye(n)  # not reached: R + I is positive definite


def _round(np: Any, lapack: Any, sq: Any, r: Any, candidates: Sequence[Any], best: tuple[float, Any, Any]) -> tuple[tuple[float, Any, Any], list[float]]:
    """Score a round of candidate length scales: each one's profile log-likelihood (-inf where its
    correlation matrix does not factor), and *best* or the candidate that beats it by more than 1e-9 (the
    first candidate is taken even when its matrix does not factor when nothing was taken yet, as the
    fallback's scales; one that factors beats one that does not). The round's correlation matrices are
    made at once; each is factored by LAPACK directly (NumPy's and SciPy's Python wrappers cost more than
    these small matrices' arithmetic). *sq*: each pair of runs' squared differences, (n x n) x d."""
    k, n = len(candidates), len(r)
    W = np.array(candidates)  # k x d
    W *= W
    np.divide(-0.5, W, out=W)
    R = (W @ sq.T).reshape(k, n, n)
    np.exp(R, out=R)
    R += _nugget(n)
    lls = []
    dpotrf, dtrtrs, log, prod = lapack.dpotrf, lapack.dtrtrs, math.log, np.multiply.reduce
    for scales, Rj in zip(candidates, R):
        L, info = dpotrf(Rj, lower=1, clean=1)
        if info != 0:
            lls.append(-math.inf)
            if best[1] is None:
                best = (-math.inf, scales, None)
            continue
        a = dtrtrs(L, r, lower=1)[0]
        ll = -0.5 * n * log(max(float(a @ a) / n, 1e-300)) - log(float(prod(L.diagonal())))
        lls.append(ll)
        if best[1] is None or best[2] is None or ll > best[0] + 1e-9:
            best = (ll, scales, L)
    return best, lls


@functools.lru_cache(maxsize=1)
def _libraries() -> tuple[Any, Any, Any]:
    """NumPy, SciPy's LAPACK and its normal quantile function, imported once (an import statement per batch
    costs more than the batch's arithmetic)."""
    import numpy
    from scipy.linalg import lapack
    from scipy.special import ndtri

    return numpy, lapack, ndtri


_CONTROLLER: list[Any] = [-1, None]
"""How many modules were loaded when the controller was made, and the controller."""


def _controller() -> Any:
    """threadpoolctl's view of the BLAS libraries loaded (NumPy's and SciPy's, imported first so it sees
    both), made again when modules were imported since (a library loaded later - by a plugin, another
    import - is seen too; making it costs a millisecond, comparing a count nothing); None without
    threadpoolctl."""
    import sys

    _libraries()
    if _CONTROLLER[0] != len(sys.modules):
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:  # pragma: no cover - the search extra brings it
            return None
        _CONTROLLER[1] = ThreadpoolController()
        _CONTROLLER[0] = len(sys.modules)
    return _CONTROLLER[1]


def one_thread() -> Any:
    """A context in which the BLAS libraries run on one thread (threadpoolctl), put back as they were
    after it. The model's matrices are small: with the library's default threads (one per core) its
    threads only wait for one another and take the cores from the runs - on the chasing-cars benchmark
    38 ms of processor time per run where one thread needs 1.7 ms, for the same runs. The runs themselves
    (and the host's own code) are not limited: only the sampler's calls are made in it."""
    controller = _controller()
    return contextlib.nullcontext() if controller is None else controller.limit(limits=1, user_api="blas")


@functools.lru_cache(maxsize=8)
def _halves(d: int) -> Any:
    """A vector of *d* halves (never written): a product with it is half each row's sum."""
    import numpy as np

    halves = np.full(d, 0.5)
    halves.flags.writeable = False
    return halves


@functools.lru_cache(maxsize=64)
def _nugget(n: int) -> Any:
    """:data:`_NUGGET` times the *n* x *n* identity (never written: made once per size, not per round)."""
    import numpy as np

    nugget = _NUGGET * np.eye(n)
    nugget.flags.writeable = False
    return nugget


@functools.lru_cache(maxsize=8)
def local_pattern(m_local: int, best: int) -> tuple[Any, Any]:
    """Which of the *best* runs each local candidate is drawn around, and at which spread (fixed arrays, never
    written: made once, not per batch): in blocks of consecutive candidates - each run's block split into one
    per spread - never in turns. The candidates are consecutive Sobol points, and every 4th point of Sobol's
    sequence lies in one quarter of its first coordinate: taken in turns, each run would get its normal
    draws from one quarter of the normal distribution (and, with four runs and four spreads, one spread
    each); a block of consecutive points is spread evenly."""
    import numpy as np

    turns = np.arange(m_local)
    return turns * best // m_local, np.asarray(_SPREAD)[turns * best * len(_SPREAD) // m_local % len(_SPREAD)][:, None]


@functools.lru_cache(maxsize=8)
def _pairs(d: int, full: bool) -> tuple[Any, Any]:
    """The quadratic's products: every pair of the *d* coordinates (``numpy.triu_indices``), or each with
    itself; made once per dimension (fixed arrays, never written)."""
    import numpy as np

    return np.triu_indices(d) if full else (np.arange(d), np.arange(d))


def boundary_projection(near: Sequence[tuple[Sequence[float], float]], fail: Sequence[float],
                        nominal: Sequence[float]) -> tuple[list[float], list[float]] | None:  # fmt: skip
    """The nominal point projected onto the zero of a plane fitted (least squares) to the objectives of the
    runs *near* a failing point *fail* (unit points and objectives), clipped to the box, and the plane's
    unit normal pointing to higher objectives: where the boundary of the failing region nearest to
    *nominal* lies if the objective is linear there, and which way the region lies from it. None with
    fewer runs than the plane's terms, runs that do not span every direction, or a flat objective."""
    np, _, _ = _libraries()
    d = len(fail)
    if len(near) < d + 1:
        return None
    f = np.array(fail, dtype=float)
    F = np.concatenate([np.ones((len(near), 1)), np.array([x for x, _ in near], dtype=float) - f], axis=1)
    coef, _, rank, _ = np.linalg.lstsq(F, np.array([y for _, y in near], dtype=float), rcond=None)
    g = coef[1:]
    norm = float(g @ g)
    if rank < d + 1 or not norm > 0.0:
        return None
    n = np.array(nominal, dtype=float)
    point = np.clip(n - float(coef[0] + g @ (n - f)) / norm * g, 0.0, 1.0)
    return [float(u) for u in point], [float(u) for u in g / math.sqrt(norm)]


def quadratic_minimum(told: Sequence[tuple[Sequence[float], float]], d: int, draws: Draws, check: bool = False) -> Any:
    """The minimum of a quadratic model of the objective fitted to the best runs (*told*: continuous unit
    points and objectives), as lq-CMA-ES does: a full quadratic once there are (d + 1)(d + 2)/2 + 2
    runs (while that is at most :data:`FULL_TERMS` terms: d <= 10), one without cross terms from
    2 d + 3; None with fewer. With *check*, also None when the
    model does not rank its own runs: each run predicted by the model fitted to the others
    (leave-one-out) must order them with a Kendall rank correlation of at least :data:`TRUST`.
    Searched over points around the best run and uniform ones; in more than 10 parameters (no cross terms
    ever) each coordinate's minimum exactly (the model is a sum of one parabola per parameter)."""
    np, lapack, ndtri = _libraries()
    full = (d + 1) * (d + 2) // 2
    diagonal = 2 * d + 1
    if len(told) >= full + 2 and full <= FULL_TERMS:
        terms = full
    elif len(told) >= diagonal + 2:
        terms = diagonal
    else:
        return None
    best = heapq.nsmallest(max(terms + 2, min(len(told), 3 * terms)), told, key=lambda p: p[1])  # stable: as sorted
    X = np.array([x for x, _ in best])
    Y = np.array([y for _, y in best])

    rows, cols = _pairs(d, terms == full)  # the products' pairs, in order

    def features(P: Any) -> Any:
        return np.concatenate([np.ones((len(P), 1)), P, P[:, rows] * P[:, cols]], axis=1)

    F = features(X)
    solved = _normal_equations(np, lapack, F, Y) if full > FULL_TERMS else None
    if solved is not None:
        coef, leverage = solved
    else:
        U, sv, Vt, _ = lapack.dgesdd(F, compute_uv=1, full_matrices=0)  # least squares, and each run's leverage (LAPACK's, as numpy.linalg.svd)
        rank = sv > sv[0] * max(F.shape) * _EPS  # numpy's lstsq cut-off
        Uk = U[:, rank]
        coef = Vt[rank].T @ ((Uk.T @ Y) / sv[rank])
        leverage = (Uk * Uk).sum(axis=1)
    if check:
        if leverage.max() > 1.0 - 1e-9:  # a run only the model itself fits: it cannot be checked
            return None
        loo = Y - (Y - F @ coef) / (1.0 - leverage)  # each run as the model fitted without it predicts it
        if _kendall(np, loo, Y) < TRUST:
            return None
    if full > FULL_TERMS:  # never a full model: the minimum without cross terms is each coordinate's, exactly
        a, b = coef[1 : d + 1], coef[d + 1 :]
        ends = np.where(a + b < 0.0, 1.0, 0.0)  # a straight or downward parabola: its lower end
        inner = np.clip(-a / np.where(b > 0.0, 2.0 * b, 1.0), 0.0, 1.0)
        return np.where(b > 0.0, inner, ends)
    candidates = draws.uniform(np.empty((1024, d)))  # Sobol points under one shift: the first half go around
    around = candidates[:512]  # the best run (normal(0, 0.1), clipped to the box, in place), the rest are uniform
    ndtri(around, out=around)
    around *= 0.1
    around += X[0]
    np.maximum(around, 0.0, out=around)
    np.minimum(around, 1.0, out=around)
    values = features(candidates) @ coef
    return candidates[int(values.argmin())]  # inside the box already


def _normal_equations(np: Any, lapack: Any, F: Any, Y: Any) -> tuple[Any, Any] | None:
    """Least squares by the normal equations (the Cholesky factor of F'F: a twentieth of the singular value
    decomposition's time on 123 runs and 41 terms) and each run's leverage; None when F'F is not positive
    definite (runs on a lower-dimensional set: the decomposition's rank cut-off decides)."""
    G = F.T @ F
    L, info = lapack.dpotrf(G, lower=1, clean=1)
    if info != 0 or float(L.diagonal().min()) <= math.sqrt(float(G.diagonal().max())) * 1e-6:
        return None
    Z = lapack.dtrtrs(L, F.T, lower=1)[0]  # L^-1 F'
    coef = lapack.dtrtrs(L, Z @ Y, lower=1, trans=1)[0]
    return coef, np.add.reduce(Z * Z, axis=0)


def _kendall(np: Any, a: Any, b: Any) -> float:
    """Kendall's rank correlation of two sequences (tau-a: a tied pair counts as neither order)."""
    m = len(a)
    if m < 2:
        return 0.0
    return float((np.sign(np.subtract.outer(a, a)) * np.sign(np.subtract.outer(b, b))).sum()) / (m * (m - 1))
