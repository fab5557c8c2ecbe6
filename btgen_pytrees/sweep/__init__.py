"""Sweeps: one parameterised test case, many concrete runs, a verdict map.

A sweep is loaded and checked by :mod:`btgen_pytrees.load` (the template, the blocks and every
variation, :func:`~btgen_pytrees.load.sweep.load_sweep`); this package runs it:

* :mod:`.jobs` - a worker's job for one variation (and a chunk of them)
* :mod:`.runs` - the variations run on the local pool or a Dask cluster, made into the sweep's report
* :mod:`.overrides` - one variation chosen on the command line (``--set``, ``--params``)
* :mod:`.report`, :mod:`.plot` - the result and the verdict map
"""

from ..load.sweep import load_sweep
from ..load.template import MAX_VARIATIONS, Sweep, Variation, has_variations, is_parameterised
from ..load.variations import Variations, label

__all__ = ["MAX_VARIATIONS", "Sweep", "Variation", "Variations", "has_variations", "is_parameterised", "label",
           "load_sweep"]
