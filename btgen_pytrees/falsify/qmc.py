"""Randomised quasi-Monte Carlo points: Sobol's sequence, digitally shifted, for one search's draws.

A search draws points three ways: its space-filling start (the Sobol sequence itself), and the
candidate points the ``gp`` model (:mod:`.surrogate`) and the quadratic model score each batch -
uniform ones over the box, and normal ones around the best runs. All three come from here:

* the points are SciPy's Sobol sequence (``qmc.Sobol(d, scramble=False)``: its direction numbers,
  :data:`SOBOL_BITS` bits), made once per process and size (:func:`sobol_points`);
* each draw XORs them with a *digital shift* - random bits per coordinate - from :class:`Draws`, a
  ``random.Random`` seeded with the search's seed. The start keeps one shift for the whole sequence;
  each set of candidates gets a fresh one (the first *n* points of the sequence, shifted anew: a
  randomised net, as even as the sequence and as random as a uniform draw for each point alone);
* normal points are the shifted points through the normal quantile function (``scipy.special.ndtri``).

Why not NumPy's generator: making one (``numpy.random.default_rng(seed)``: a ``SeedSequence``, a
``PCG64``, a ``Generator``) cost about 0.3 ms at the start of every search - a tenth of a search's own
cost at batch 1 on runs of 1 ms, where the code runs cold after the runs (docs/performance-history.md) -
while a ``random.Random`` is made in about 40 us, and its bits are all a shift needs. Sobol
candidates also cover the box more evenly than uniform ones (BoTorch draws its acquisition's raw
samples the same way). NumPy's generator is still made, from the same seed, where a method needs
one (a list parameter's choices, CMA-ES's random start: :mod:`.sampler`).
"""

from __future__ import annotations

import functools
import random
from typing import Any, Sequence

__all__ = ["SOBOL_BITS", "sobol_points", "sobol_rows", "shifted_point", "Draws"]

SOBOL_BITS = 30
"""Bits of a Sobol point's coordinates (SciPy's default)."""
_SCALE = 2.0**-SOBOL_BITS
_HALF = 0.5 * _SCALE
"""Half the last bit: a shifted point at its cell's centre, strictly inside (0, 1) (the normal quantile
function is infinite at 0 and 1)."""


@functools.lru_cache(maxsize=16)
def sobol_points(d: int, m: int) -> Any:
    """The first 2**m points of Sobol's sequence in *d* dimensions, unscrambled, as integers of
    :data:`SOBOL_BITS` bits: SciPy's ``qmc.Sobol(d, scramble=False).random_base2(m)``, bit for bit (its
    direction numbers, the Joe-Kuo table SciPy ships; made once per process and size, never written).

    They are worked out here from SciPy's table rather than by ``scipy.stats.qmc``: importing
    ``scipy.stats`` costs about 1 s of processor time, most of a ``falsify`` process's start-up, for
    a few hundred points made in a millisecond (each point is the XOR of the direction numbers of its
    index's Gray code's bits). Where the table is not found, SciPy makes them."""
    import numpy

    table = _direction_table()
    if table is None or d > len(table[0]):  # pragma: no cover - SciPy without its table file
        from scipy.stats import qmc

        points = (qmc.Sobol(d=d, scramble=False, bits=SOBOL_BITS).random_base2(m) * 2.0**SOBOL_BITS).astype(numpy.int64)
    else:
        v = numpy.array(_directions(table, d), dtype=numpy.int64)  # d x bits
        index = numpy.arange(1 << m, dtype=numpy.int64)
        gray = index ^ (index >> 1)
        points = numpy.zeros((1 << m, d), dtype=numpy.int64)
        for bit in range(m):
            points ^= ((gray >> bit) & 1)[:, None] * v[:, bit]
    points.flags.writeable = False
    return points


@functools.lru_cache(maxsize=1)
def _direction_table() -> tuple[Any, Any] | None:
    """SciPy's Sobol table (primitive polynomials and initial direction numbers), read from its file."""
    import importlib.util
    import os

    import numpy

    spec = importlib.util.find_spec("scipy")
    for where in (spec.submodule_search_locations or []) if spec is not None else []:
        path = os.path.join(where, "stats", "_sobol_direction_numbers.npz")
        if os.path.exists(path):
            with numpy.load(path) as table:
                return table["poly"].tolist(), table["vinit"]
    return None  # pragma: no cover


def _directions(table: tuple[Any, Any], d: int) -> list[list[int]]:
    """The direction numbers of the first *d* coordinates, :data:`SOBOL_BITS` bits (SciPy's recurrence:
    each coordinate's initial numbers from the table, the rest from its primitive polynomial)."""
    poly, vinit = table
    bits = SOBOL_BITS
    rows = [[1] * bits]
    for k in range(1, d):
        p = poly[k]
        m = p.bit_length() - 1
        v = [int(x) for x in vinit[k, :m]] + [0] * (bits - m)
        for j in range(m, bits):
            new = v[j - m]
            for i in range(m):
                if (p >> (m - 1 - i)) & 1:
                    new ^= v[j - i - 1] << (i + 1)
            v[j] = new
        rows.append(v)
    return [[x << (bits - 1 - j) for j, x in enumerate(row)] for row in rows]


@functools.lru_cache(maxsize=16)
def sobol_rows(d: int, m: int) -> tuple[tuple[int, ...], ...]:
    """:func:`sobol_points` as Python integers (made once per process and size): the start's points, one at
    a time after a run, are XORed in Python - a NumPy call that follows a run costs tens of microseconds
    with the processor's caches cold, many times its warm cost."""
    return tuple(map(tuple, sobol_points(d, m).tolist()))


def shifted_point(d: int, k: int, shift: Sequence[int]) -> list[float]:
    """Point *k* of Sobol's sequence in *d* dimensions XORed with *shift*, in [0, 1): its bits exactly (the
    start's points, one a run; worked out in Python, see :func:`sobol_rows`)."""
    row = sobol_rows(d, max(6, k.bit_length()))[k]
    return [(bits ^ s) * _SCALE for bits, s in zip(row, shift)]


class Draws:
    """One search's random bits: digital shifts of the Sobol points, and the candidate points made with them.

    Args:
        seed: the search's seed (any integer ``random.Random`` takes)
    """

    def __init__(self, seed: int):
        import numpy

        self._np = numpy
        self._bits = random.Random(seed).getrandbits

    def shift(self, d: int) -> list[int]:
        """*d* random numbers of :data:`SOBOL_BITS` bits: a digital shift (one per coordinate)."""
        bits = self._bits
        return [bits(SOBOL_BITS) for _ in range(d)]

    def uniform(self, out: Any) -> Any:
        """Fill *out* (an n x d float array) with the first n Sobol points under a fresh shift, each coordinate
        at its cell's centre in (0, 1); returns *out*."""
        n, d = out.shape
        if n == 0 or d == 0:
            return out
        np = self._np
        np.multiply(sobol_points(d, max(0, (n - 1).bit_length()))[:n] ^ np.array(self.shift(d)), _SCALE, out=out)
        out += _HALF
        return out
