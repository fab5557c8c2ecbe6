"""Sweeps: one parameterised test case, many concrete runs, a verdict map.

* :mod:`.variations` - the ``variations`` block: lists, ranges, random draws; count and order
* :mod:`.parameters` - ``$name`` references and their substitution
* :mod:`.check` - checks of the ``parameters``/``variations`` blocks
* :mod:`.case` - :class:`Sweep`: load, check every variation, iterate
"""

from .case import MAX_VARIATIONS, Sweep, Variation, has_variations, is_parameterised, load_sweep
from .variations import Variations, label

__all__ = ["MAX_VARIATIONS", "Sweep", "Variation", "Variations", "has_variations", "is_parameterised", "label",
           "load_sweep"]
