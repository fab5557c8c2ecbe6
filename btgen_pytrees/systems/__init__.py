"""Systems under test: the interface's names (re-exported) and its implementations.

The interface is :mod:`btgen_pytrees.contracts.system` (the life cycle a run drives a
system through); :mod:`.simulated` and :mod:`.sumo` implement it.
"""

from ..contracts.system import System, SystemFailure, SystemInfo, SystemSpec, SystemType

__all__ = ["System", "SystemFailure", "SystemInfo", "SystemSpec", "SystemType"]
