"""Systems under test: the interface (:mod:`.base`) and its implementations.

See :mod:`btgen_pytrees.systems.base` for the life cycle a run drives a system through.
"""

from .base import System, SystemFailure, SystemInfo, SystemSpec, SystemType

__all__ = ["System", "SystemFailure", "SystemInfo", "SystemSpec", "SystemType"]
