"""Falsification: search a sweep's parameter box for a failing setting (docs/falsify.md).

* :mod:`.space` - the ``variations`` block as a box: intervals, choices, priors
* :mod:`.sampler` - ``ask(n)``/``tell(values)`` over the model, ``cmaes`` and Optuna's samplers (the ``search`` extra)
* :mod:`.surrogate` - the ``gp`` method's Gaussian-process model
* :mod:`.margins` - each criterion's margin and the objective combined from them
* :mod:`.jobs` - the worker's job: a sweep variation's run, with its margins
* :mod:`.search` - the loop: start, search, shrink, bound, clusters
* :mod:`.report` - the result as JSON and as a table, with the random and grid baselines
* :mod:`.command` - the ``falsify`` command
"""

from .search import Search, Settings
from .space import Space

__all__ = ["Search", "Settings", "Space"]
