"""The bird's-eye scene of a run: where every vehicle was on every tick (the replay page draws it).

A :class:`~btgen_pytrees.systems.System` offers a scene by having two more
methods (the SUMO system does; docs/systems.md says how to add them)::

    scene_map() -> {"lanes": [[width, [x0, y0, x1, y1, ...]], ...],   # polylines, metres
                    "areas": [[x0, y0, x1, y1, ...], ...],            # filled outlines (junctions)
                    "ego": "ego"}                                      # the id drawn as the ego ("" none)
    scene_vehicles() -> iterable of (id, x, y, heading, length, width, collided[, teleported])

``x, y`` is the middle of the vehicle's front, ``heading`` degrees clockwise
from north (y up), ``length``/``width`` metres, ``collided`` whether it has
been in a collision, and the optional ``teleported`` whether the system moved
it to this place on this tick without driving it there (SUMO's teleports): the
replay page then draws no motion from its last place. The runner asks for the map once, after the system
started, and for the vehicles after every tick (when the trace samples the
signals), and keeps them in ``report.trace.scene``, a :class:`Scene`.

**Memory.** A frame costs one list slot per vehicle and its numbers. At most
:data:`MAX_PLACES` vehicle positions are kept; past it, recording stops and
:attr:`Scene.truncated` is the first tick without a frame.

>>> scene = Scene({"lanes": [[3.2, [0, 0, 100, 0]]], "areas": [], "ego": "ego"})
>>> scene.record(0, [("ego", 10.0, 0.0, 90.0, 5.0, 1.8, False)])
>>> scene.record(1, [("ego", 12.5, 0.0, 90.0, 5.0, 1.8, False), ("cutter", 30.0, 3.2, 95.0, 5.0, 1.8, True)])
>>> scene.record(2, [("ego", 900.0, 0.0, 90.0, 5.0, 1.8, True, True)])  # teleported: flags 1 + 2
>>> scene.to_data()["vehicles"], scene.to_data()["frames"][1], scene.to_data()["frames"][2]
(['ego', 'cutter'], [0, 12.5, 0.0, 90.0, 0, 1, 30.0, 3.2, 95.0, 1], [0, 900.0, 0.0, 90.0, 3])
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping

__all__ = ["Scene", "MAX_PLACES"]

MAX_PLACES = 2_000_000
"""Vehicle positions a scene keeps before it stops recording."""


@dataclass
class Scene:
    """The map and, per tick, every vehicle's place.

    Attributes:
        map: what ``scene_map()`` returned (lanes, areas, ego)
        vehicles: every vehicle id seen, in the order first seen
        sizes: per vehicle, ``(length, width)``
        frames: per tick, flat ``[vehicle index, x, y, heading, flags, ...]``; flags: 1 collided, 2 teleported on this tick
        truncated: the first tick not recorded (``None``: complete)
    """

    map: Mapping[str, Any]
    vehicles: list[str] = field(default_factory=list)
    sizes: list[tuple[float, float]] = field(default_factory=list)
    frames: list[list[float]] = field(default_factory=list)
    truncated: int | None = None
    _index: dict[str, int] = field(default_factory=dict, repr=False)
    _left: int = field(default=MAX_PLACES, repr=False)

    def record(self, tick: int, places: Iterable[tuple[Any, ...]]) -> None:
        """The vehicles' places after tick *tick* (ticks come in order; a skipped tick is an empty frame):
        ``(id, x, y, heading, length, width, collided)``, and optionally ``teleported`` after those."""
        if self.truncated is not None:
            return
        while len(self.frames) < tick:
            self.frames.append([])
        frame: list[float] = []
        for place in places:
            vid, x, y, heading, length, width, collided = place[:7]
            flags = (1 if collided else 0) | (2 if len(place) > 7 and place[7] else 0)
            if not self._left:
                self.truncated = tick
                return
            self._left -= 1
            i = self._index.get(vid)
            if i is None:
                i = self._index[vid] = len(self.vehicles)
                self.vehicles.append(str(vid))
                self.sizes.append((_finite(length, 5.0), _finite(width, 1.8)))
            frame += (i, _finite(x, 0.0), _finite(y, 0.0), _finite(heading, 0.0), flags)
        self.frames.append(frame)

    def to_data(self) -> dict[str, Any]:
        """JSON-ready: the map, the vehicles and their sizes, one flat list per tick."""
        return {"map": dict(self.map), "vehicles": self.vehicles, "sizes": [list(s) for s in self.sizes],
                "frames": self.frames, "truncated": self.truncated}  # fmt: skip


def _finite(value: Any, default: float) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return default
    return number if math.isfinite(number) else default
