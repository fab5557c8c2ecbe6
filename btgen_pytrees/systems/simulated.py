"""The built-in simulated system: signals that only the test's own leaves write.

It is the default when a case names no ``system``. It owns no signals (every
signal is written by ``set``/``ramp`` or a user leaf) and has no process to
start; its only job is the run's clock: a virtual clock that moves by the case's
``tick`` after each tree tick, so tick *k* happens at ``round(k * tick, 9)``
(``0.30000000000000004`` becomes ``0.3``) and nothing ever sleeps. A 60 s test
runs as fast as its tree ticks, and the same input gives the same run, byte for
byte.

>>> from btgen_pytrees.systems import SystemSpec
>>> system = SIMULATED.create(SystemSpec(), type("Case", (), {"tick": 0.1})())
>>> system.start(None); times = []
>>> for _ in range(4):
...     times.append(system.now()); system.tick()
>>> times
[0.0, 0.1, 0.2, 0.3]
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

from ..errors import Problem
from ..contracts.system import SystemInfo, SystemSpec

if TYPE_CHECKING:  # pragma: no cover
    from ..contracts.environment import Environment
    from ..model import TestCase

__all__ = ["SimulatedSystem", "SimulatedType", "SIMULATED"]


class SimulatedSystem:
    """One run's virtual clock; publishes nothing, advances ``tick`` seconds per step."""

    def __init__(self, tick: float):
        self.step = float(tick)
        self.k = 0
        self.time = 0.0

    def start(self, env: "Environment | None") -> None:
        self.k, self.time = 0, 0.0

    def now(self) -> float:
        return self.time

    def publish(self, env: "Environment") -> None:
        """Nothing to publish: the simulated system owns no signals."""

    def tick(self) -> None:
        self.k += 1
        self.time = round(self.k * self.step, 9)  # computed from k, so errors never accumulate

    def close(self) -> None:
        """Nothing to release."""


class SimulatedType:
    """The ``simulated`` system type: no config file, no options, no owned signals."""

    name = "simulated"
    options: tuple[str, ...] = ()

    def describe(self, spec: SystemSpec, case_data: Mapping[str, Any]) -> SystemInfo:
        problems = ()
        if spec.config is not None:
            problems = (Problem(("system", "config"), "the simulated system takes no config file", "system"),)
        return SystemInfo(signals=(), problems=problems)

    def create(self, spec: SystemSpec, case: "TestCase") -> SimulatedSystem:
        return SimulatedSystem(case.tick)


SIMULATED = SimulatedType()
"""The registered instance (``registry.system("simulated")``)."""
