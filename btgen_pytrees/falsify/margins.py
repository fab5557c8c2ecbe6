"""The search's objective, combined from the report's margins: the one definition is
:mod:`btgen_pytrees.sweep.objective`, which a sweep's map and summary use too (so they show what a
search would); named here for the search's modules."""

from __future__ import annotations

from ..sweep.objective import combine, fit_scales, groups_of, objective, row_margins

__all__ = ["row_margins", "combine", "groups_of", "fit_scales", "objective"]
