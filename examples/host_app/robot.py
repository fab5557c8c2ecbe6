"""Two custom leaves of a (pretend) robot, as a btgen_pytrees plugin.

A real host would talk to hardware or a simulator here. These leaves only move
numbers on the generated tree's blackboard namespace, using the environment's
clock, which is all the generator needs to know about them: they do not know
about triggers, completion flags or the timeline.
"""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.common import Status

from btgen_pytrees.leaves import Environment, Registry
from btgen_pytrees.model import Entry


class MoveArm(py_trees.behaviour.Behaviour):
    """``move_arm {to, speed}``: drive the ``arm`` signal towards *to* at *speed* units per second."""

    def __init__(self, entry: Entry, env: Environment):
        super().__init__(name=entry.name)
        self.env = env
        self.target: float = entry.params["to"]
        self.speed: float = entry.params["speed"]
        self.last = 0.0

    def initialise(self) -> None:
        self.last = self.env.now()

    def update(self) -> Status:
        now = self.env.now()
        position = self.env.values(["arm"]).get("arm", 0.0)
        step = self.speed * (now - self.last)
        self.last = now
        position = min(self.target, position + step) if position < self.target else max(self.target, position - step)
        self.env.write("arm", position)
        self.feedback_message = f"arm at {position:.2f}"
        return Status.SUCCESS if position == self.target else Status.RUNNING


class CloseGripper(py_trees.behaviour.Behaviour):
    """``close_gripper {}``: close the gripper (it takes a fixed 0.1 s)."""

    def __init__(self, entry: Entry, env: Environment):
        super().__init__(name=entry.name)
        self.env = env
        self.started = 0.0

    def initialise(self) -> None:
        self.started = self.env.now()

    def update(self) -> Status:
        if self.env.now() - self.started < 0.1:
            return Status.RUNNING
        self.env.write("gripper", 1)
        return Status.SUCCESS


MOVE_ARM_PARAMS: dict[str, Any] = {
    "type": "object",
    "required": ["to", "speed"],
    "additionalProperties": False,
    "properties": {"to": {"type": "number"}, "speed": {"type": "number", "exclusiveMinimum": 0}},
}


def register(registry: Registry) -> None:
    """The plugin hook: ``--plugin robot`` or an entry point in ``btgen_pytrees.leaves`` calls this."""
    registry.register("move_arm", MoveArm, params_schema=MOVE_ARM_PARAMS, description="move the arm")
    registry.register("close_gripper", CloseGripper, params_schema={"type": "object", "maxProperties": 0},
                      description="close the gripper")  # fmt: skip
