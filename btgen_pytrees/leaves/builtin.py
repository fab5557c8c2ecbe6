"""Registration of the built-in simulated leaves, oracles, the ``simulated`` system and the ``sumo`` one.

Built-ins go through :meth:`Registry.register` like any plugin; this module is
the only place that knows their parameter schemas.
"""

from __future__ import annotations

import importlib.util
from typing import Any

from ..contracts.registry import Registry
from ..systems.simulated import SIMULATED
from . import oracles, simulated, sumo, temporal

__all__ = ["register_builtins", "PARAMS"]

_SECONDS = {"type": "number", "minimum": 0, "description": "seconds, >= 0"}
# dotted names (ego.speed) are allowed here so that writing a system's signal gets the read-only message
_SIGNAL = {"type": "string", "pattern": "^[A-Za-z][A-Za-z0-9_]*(?:[.][A-Za-z][A-Za-z0-9_]*)*(?![\\s\\S])",
           "description": "a signal name"}
_VALUE = {"type": ["number", "boolean"]}


def _params(required: list[str], **properties: Any) -> dict[str, Any]:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "type": "object",
        "required": required,
        "additionalProperties": False,
        "properties": properties,
    }


PARAMS: dict[str, dict[str, Any]] = {
    "set": _params(["signal", "value"], signal=_SIGNAL, value=_VALUE, duration=_SECONDS),
    "ramp": _params(["signal", "to", "duration"], signal=_SIGNAL, to={"type": "number"}, duration=_SECONDS),
    "profile": _params(
        ["signal", "points"], signal=_SIGNAL,
        points={"type": "array", "minItems": 1, "maxItems": 100000,
                "description": "control points [t, value]: t seconds from the entry's start (increasing), the value then",
                "items": {"type": "array", "prefixItems": [_SECONDS, _VALUE], "minItems": 2, "maxItems": 2}},
        shape={"enum": ["step", "linear", "pchip"], "default": "step",
               "description": "step: each value holds until the next point; linear: interpolated; pchip: "
                              "shape-preserving cubic (needs SciPy, the 'search' extra)"}),
    "hold": _params(["duration"], duration=_SECONDS),
    "wait": _params(["duration"], duration=_SECONDS),
    "until": _params(["expect"], expect={"type": "string", "minLength": 1, "maxLength": 1000}, timeout=_SECONDS),
}


def _profile_problems(params: Any) -> Any:
    """``profile``'s rules past the schema; ``pchip`` only where SciPy is installed (a case is valid only
    where it can run)."""
    yield from simulated.profile_problems(params)
    if params.get("shape") == "pchip" and importlib.util.find_spec("scipy") is None:
        yield ("shape",), "the 'pchip' shape needs SciPy, which is not installed: pip install -e '.[search]'"


def register_builtins(registry: Registry) -> Registry:
    """Add the built-in leaves to *registry* and return it."""
    behaviour, constraint = "behavior", "constraint"
    registry.register("set", simulated.Set, kind=behaviour, params_schema=PARAMS["set"], signals=("signal",),
                      description="write a signal; hold for 'duration' if given")  # fmt: skip
    registry.register("ramp", simulated.Ramp, kind=behaviour, params_schema=PARAMS["ramp"], signals=("signal",),
                      description="move a signal linearly to 'to' over 'duration'")  # fmt: skip
    registry.register("profile", simulated.Profile, kind=behaviour, params_schema=PARAMS["profile"], signals=("signal",),
                      check=_profile_problems, description="drive a signal through control points [t, value] (step, linear or pchip)")  # fmt: skip
    registry.register("hold", simulated.Hold, kind=behaviour, params_schema=PARAMS["hold"],
                      description="do nothing for 'duration'")  # fmt: skip
    registry.register("wait", simulated.Wait, kind=constraint, params_schema=PARAMS["wait"],
                      description="succeed after 'duration'")  # fmt: skip
    registry.register("until", simulated.Until, kind=constraint, params_schema=PARAMS["until"],
                      expressions=("expect",), description="succeed once 'expect' holds; fail after 'timeout'")  # fmt: skip
    no_params = {"type": "object", "maxProperties": 0, "description": "built-in criteria take no params"}
    registry.register(None, oracles.Record, kind="record", params_schema=no_params, description="expect holds on every tick")
    registry.register(None, oracles.Period, kind="period", params_schema=no_params, description="expect holds on every tick of a window")
    registry.register(None, oracles.Final, kind="final", params_schema=no_params, description="expect holds at one instant")
    registry.register(None, temporal.Temporal, kind="temporal", params_schema=no_params,
                      description="the formula's robustness at its anchor is > 0 (signal temporal logic)")  # fmt: skip
    registry.register_system(SIMULATED)
    sumo.register(registry)  # the SUMO back end registers like a plugin; it imports libsumo only to run
    return registry
