"""Three small plants for the ARCH-COMP falsification requirements, as a btgen_pytrees plugin.

ARCH-COMP's AT, CC and AFC requirements are stated over Simulink models (an automatic transmission,
five chasing cars, an engine's air-fuel ratio control). These are small stand-ins with the same
signals and the same shape of behaviour - not the benchmark models - so that the requirements, written
as ``temporal`` criteria, run on a real tree: each plant is a behaviour that integrates its model once
per tick from input signals the case's other entries write (``set``, ``ramp``), and publishes its
outputs as signals.

* ``transmission`` - inputs ``throttle`` (0-100 %), ``brake`` (0-325); outputs ``speed`` (mph),
  ``rpm``, ``gear`` (1-4; an up- and down-shift schedule with hysteresis, each shift taking 0.1 s);
* ``chasing_cars`` - inputs ``throttle``, ``brake`` (0-1) of the leading car, car 5; outputs ``y1`` ... ``y5``
  (positions, m; ``y5 - y4`` is the gap in front of car 4): each other car tracks the one ahead with a
  proportional controller;
* ``fuel_control`` - input ``theta`` (throttle angle, degrees); output ``mu`` (the normalised air-fuel
  ratio error): a fast throttle change disturbs it, the controller brings it back.

``python -m btgen_pytrees run --plugin examples/temporal/arch.py examples/temporal/at.json``
"""

from __future__ import annotations

import math
from typing import Any

import py_trees
from py_trees.common import Status

from btgen_pytrees.leaves import Environment, Registry
from btgen_pytrees.model import Entry

DURATION = {
    "type": "object",
    "required": ["duration"],
    "additionalProperties": False,
    "properties": {"duration": {"type": "number", "exclusiveMinimum": 0}},
}


class Plant(py_trees.behaviour.Behaviour):
    """A model integrated once per tick for ``duration`` seconds; succeeds then."""

    inputs: tuple[str, ...] = ()

    def __init__(self, entry: Entry, env: Environment):
        super().__init__(name=entry.name)
        self.env = env
        self.duration: float = entry.params["duration"]
        self.started = 0.0
        self.last = 0.0

    def initialise(self) -> None:
        self.started = self.last = self.env.now()
        self.reset()
        self.publish()

    def update(self) -> Status:
        now = self.env.now()
        dt, self.last = now - self.last, now
        values = self.env.values(self.inputs)
        if dt > 0:
            self.step(dt, values)
        self.publish()
        return Status.SUCCESS if now - self.started >= self.duration - 1e-9 else Status.RUNNING

    def reset(self) -> None:
        raise NotImplementedError

    def step(self, dt: float, inputs: dict[str, Any]) -> None:
        raise NotImplementedError

    def publish(self) -> None:
        raise NotImplementedError


class Transmission(Plant):
    """A four-gear automatic transmission driving a car."""

    inputs = ("throttle", "brake")
    RATIO = (3.5, 2.2, 1.5, 1.0)
    UP = ((12.0, 0.25), (28.0, 0.45), (45.0, 0.55))  # up-shift from gear g at base + slope * throttle mph
    DOWN = ((8.0, 0.15), (20.0, 0.35), (35.0, 0.45))  # down-shift to gear g below base + slope * throttle

    def reset(self) -> None:
        self.speed, self.gear, self.shifting = 0.0, 1, 0.0

    def rpm(self) -> float:
        return max(800.0, self.speed * self.RATIO[self.gear - 1] * 32.0)

    def step(self, dt: float, inputs: dict[str, Any]) -> None:
        throttle = min(max(float(inputs.get("throttle", 0.0)), 0.0), 100.0)
        brake = min(max(float(inputs.get("brake", 0.0)), 0.0), 325.0)
        rpm = self.rpm()
        torque = 0.0 if self.shifting > 0 else throttle / 100.0 * max(0.0, 1.0 - ((rpm - 3000.0) / 3500.0) ** 2)
        accel = 9.0 * torque * self.RATIO[self.gear - 1] - brake * 0.04 - 0.0008 * self.speed**2 - 0.3 * (self.speed > 0)
        self.speed = max(0.0, self.speed + accel * dt)
        self.shifting = max(0.0, self.shifting - dt)
        g = self.gear
        if g < 4 and self.speed > self.UP[g - 1][0] + self.UP[g - 1][1] * throttle:
            self.gear, self.shifting = g + 1, 0.1
        elif g > 1 and self.speed < self.DOWN[g - 2][0] + self.DOWN[g - 2][1] * throttle:
            self.gear, self.shifting = g - 1, 0.1

    def publish(self) -> None:
        self.env.write("speed", self.speed)
        self.env.write("rpm", self.rpm())
        self.env.write("gear", self.gear)


class ChasingCars(Plant):
    """Five cars in a row; the leading one (car 5) is driven by the inputs, each other one follows the car ahead."""

    inputs = ("throttle", "brake")

    def reset(self) -> None:
        self.y = [0.0, 10.0, 20.0, 30.0, 40.0]
        self.v = [0.0] * 5

    def step(self, dt: float, inputs: dict[str, Any]) -> None:
        throttle = min(max(float(inputs.get("throttle", 0.0)), 0.0), 1.0)
        brake = min(max(float(inputs.get("brake", 0.0)), 0.0), 1.0)
        accel = [0.0] * 5
        accel[4] = 3.0 * throttle - 6.0 * brake
        for i in range(4):
            gap = self.y[i + 1] - self.y[i]
            accel[i] = min(2.0, max(-6.0, 0.4 * (gap - 10.0) + 1.2 * (self.v[i + 1] - self.v[i])))
        for i in range(5):
            self.v[i] = max(0.0, self.v[i] + accel[i] * dt)
            self.y[i] += self.v[i] * dt

    def publish(self) -> None:
        for i, y in enumerate(self.y, start=1):
            self.env.write(f"y{i}", y)


class FuelControl(Plant):
    """An engine's normalised air-fuel ratio error: disturbed by fast throttle moves, then controlled back."""

    inputs = ("theta",)

    def reset(self) -> None:
        self.mu, self.theta = 0.0, None

    def step(self, dt: float, inputs: dict[str, Any]) -> None:
        theta = float(inputs.get("theta", 8.8))
        change = 0.0 if self.theta is None else theta - self.theta
        self.theta = theta
        self.mu = self.mu * math.exp(-dt / 0.4) + 0.00025 * change

    def publish(self) -> None:
        self.env.write("mu", self.mu)


def register(registry: Registry) -> None:
    """The plugin hook (``--plugin examples/temporal/arch.py``)."""
    registry.register("transmission", Transmission, params_schema=DURATION,
                      description="an automatic transmission: throttle, brake -> speed, rpm, gear")  # fmt: skip
    registry.register("chasing_cars", ChasingCars, params_schema=DURATION,
                      description="five chasing cars: throttle, brake of the first -> y1 ... y5")  # fmt: skip
    registry.register("fuel_control", FuelControl, params_schema=DURATION,
                      description="air-fuel ratio control: theta -> mu")  # fmt: skip
