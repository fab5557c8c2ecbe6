"""Pass criteria beside a scenario: the sidecar ``SCENARIO.oracle.json``.

OpenSCENARIO has no pass criteria. A converted scenario checks by default that no collision
involves the ego and that every event that started has completed; the run's verdict is
``timeout`` when the StopTrigger has not ended it within ``timeout`` seconds
(docs/openscenario.md "Pass criteria"). A sidecar file next to the scenario,
``NAME.oracle.json`` for ``NAME.xosc``, changes that::

    {
      "oracle": {"relation": "&&", "criteria": [ ...criteria of docs/format.md... ]},
      "replace": false,
      "ego": "Ego",
      "timeout": 120,
      "controllers": {"Ego": "my_alks"}
    }

* ``oracle`` - criteria in this project's format, *added* to the defaults (or replacing them with
  ``"replace": true``); its ``relation`` joins them all;
* ``ego`` - the entity the collision criterion is about (default: ``Ego``, ``ego`` or ``hero``);
* ``timeout`` - seconds (default :data:`~.scenario.DEFAULT_TIMEOUT`);
* ``controllers`` - entity -> the controller its ``ActivateControllerAction`` activates (a name a
  plugin registered with the SUMO system; without one, SUMO's own driver model).

The criteria are checked with the rest of the case when it loads (ids, expressions, signals).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Mapping

from ..errors import InvalidTestCase, Problem
from .scenario import Options

__all__ = ["Sidecar", "read_sidecar", "sidecar_path", "KEYS", "MAX_SIDECAR_BYTES"]

KEYS = ("oracle", "replace", "ego", "timeout", "controllers", "$schema", "description")
MAX_SIDECAR_BYTES = 1024 * 1024


def sidecar_path(path: str) -> str:
    stem = path[: -len(".xosc")] if path.lower().endswith(".xosc") else path
    return stem + ".oracle.json"


@dataclass
class Sidecar:
    path: str = ""
    found: bool = False
    data: dict[str, Any] = field(default_factory=dict)

    def options(self, given: Options | None) -> Options:
        given = given or Options()
        return Options(ego=given.ego or self.data.get("ego"),
                       timeout=given.timeout if given.timeout is not None else self.data.get("timeout"),
                       controllers={**self.data.get("controllers", {}), **given.controllers})  # fmt: skip

    def apply(self, doc: dict[str, Any], source: str) -> dict[str, Any]:
        oracle = self.data.get("oracle")
        if oracle is None:
            return doc
        mine = list(oracle.get("criteria", []))
        criteria = mine if self.data.get("replace") else [*doc["oracle"]["criteria"], *mine]
        doc["oracle"] = {"relation": oracle.get("relation", "&&"), "criteria": criteria}
        return doc


def read_sidecar(path: str, explicit: str | None = None) -> Sidecar:
    """The sidecar of the scenario *path* (or the file *explicit* names); an empty one when there is none."""
    where = explicit or sidecar_path(path)
    if explicit is None and not os.path.isfile(where):
        return Sidecar()
    try:
        with open(where, "rb") as fh:
            raw = fh.read(MAX_SIDECAR_BYTES + 1)
    except OSError as exc:
        raise InvalidTestCase([Problem((), f"cannot read the oracle file: {exc.strerror or exc}", "json")], where) from None
    if len(raw) > MAX_SIDECAR_BYTES:
        raise InvalidTestCase([Problem((), f"the oracle file is larger than {MAX_SIDECAR_BYTES} bytes", "limit")], where)
    try:
        data = json.loads(raw)
    except (ValueError, RecursionError) as exc:
        raise InvalidTestCase([Problem((), f"not valid JSON: {exc}", "json")], where) from None
    problems = list(_problems(data))
    if problems:
        raise InvalidTestCase(problems, where)
    return Sidecar(where, True, data)


def _problems(data: Any) -> Any:
    if not isinstance(data, dict):
        yield Problem((), "an oracle file holds a JSON object", "json")
        return
    for key in data:
        if key not in KEYS:
            yield Problem((key,), f"unknown key {key!r} (keys: {', '.join(KEYS)})", "json")
    oracle = data.get("oracle")
    if oracle is not None and (not isinstance(oracle, dict) or not isinstance(oracle.get("criteria", []), list)):
        yield Problem(("oracle",), "expected an oracle object: {\"relation\": ..., \"criteria\": [...]}", "json")
    if "replace" in data and not isinstance(data["replace"], bool):
        yield Problem(("replace",), "expected true or false", "json")
    if "ego" in data and not isinstance(data["ego"], str):
        yield Problem(("ego",), "expected an entity name", "json")
    timeout = data.get("timeout")
    if timeout is not None and (isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0):
        yield Problem(("timeout",), "expected seconds > 0", "json")
    controllers = data.get("controllers")
    if controllers is not None and (not isinstance(controllers, Mapping) or not all(isinstance(v, str) for v in controllers.values())):
        yield Problem(("controllers",), "expected an object: entity -> controller name", "json")
