"""OpenDRIVE roads read without SUMO: the reference lines, lanes and road coordinates of a ``.xodr``.

SUMO's ``netconvert`` turns a ``.xodr`` into the network SUMO drives on (:mod:`.roads`); this module
answers what netconvert's output cannot: where a position given in OpenDRIVE terms (road, lane,
``s``, ``t``) is in the world, and back - which road, lane and ``s`` a point of the world is on.
Those are the terms of an OpenSCENARIO file's positions and of its conditions (docs/opendrive.md).

The file comes from anyone, so it is read like every SUMO file of a case (:mod:`.scenario`): with
:mod:`xml.parsers.expat`, no DOCTYPE (so no entities), at most :data:`MAX_BYTES` bytes and
:data:`MAX_DEPTH` levels of elements. Problems are :class:`OpenDriveError` s naming the file (and line).

Geometry, as the standard (ASAM OpenDRIVE 1.6-1.8, clause 7 "Coordinate systems", 8 "Geometry",
9 "Roads", 11 "Lanes") defines it: the reference line of a road is its ``planView`` - lines, arcs,
spirals (clothoids), ``poly3`` and ``paramPoly3`` pieces, each from ``(x, y, hdg)`` at its ``s``; a
point ``(s, t)`` is the reference line's point at ``s`` moved ``t`` along its left normal. Lanes lie
beside the ``laneOffset`` line: positive ids to the left, negative to the right, each as wide as its
``width`` polynomial in the lane section. Elevation, superelevation and ``border`` records are not
read (the corpus has none; a ``border`` record is refused, naming the file).
"""

from __future__ import annotations

import bisect
import math
import os
import stat
import xml.parsers.expat
from dataclasses import dataclass, field
from typing import Iterator, Mapping, Sequence

__all__ = ["OpenDriveError", "Road", "Lane", "LaneSection", "Network", "Pose", "read_opendrive", "MAX_BYTES",
           "MAX_DEPTH", "driving_sign"]

MAX_BYTES = 64 * 1024 * 1024
"""Largest ``.xodr`` read (64 MiB, the limit of every SUMO file of a case)."""
MAX_DEPTH = 32
"""Deepest nesting of elements (OpenDRIVE's own nest 8 at most)."""

_STEP = 1.0
"""Metres between the samples of a reference line that :meth:`Road.project` starts from."""


class OpenDriveError(ValueError):
    """The file cannot be used; ``str()`` says why, naming the file (and line)."""


@dataclass(frozen=True)
class Pose:
    """A place in the world with its road coordinates.

    ``x, y``: m, OpenDRIVE world coordinates; ``h``: heading, rad, counter-clockwise from +x (the
    driving direction of its lane); ``road``, ``lane``: OpenDRIVE ids; ``s``, ``t``: road coordinates;
    ``offset``: lateral distance from the lane's centre (left +, in the road's ``t`` direction)."""

    x: float
    y: float
    h: float
    road: str
    lane: int
    s: float
    t: float
    offset: float = 0.0


def _poly(coefficients: tuple[float, float, float, float], ds: float) -> float:
    a, b, c, d = coefficients
    return a + ds * (b + ds * (c + ds * d))


def _poly_slope(coefficients: tuple[float, float, float, float], ds: float) -> float:
    _, b, c, d = coefficients
    return b + ds * (2 * c + ds * 3 * d)


@dataclass(frozen=True)
class Geometry:
    """One piece of a reference line: ``kind`` line/arc/spiral/poly3/paramPoly3 from ``s`` for ``length`` m."""

    s: float
    x: float
    y: float
    hdg: float
    length: float
    kind: str
    values: tuple[float, ...] = ()

    def at(self, ds: float) -> tuple[float, float, float]:
        """``(x, y, heading)`` of the reference line ``ds`` m into this piece."""
        kind, h0 = self.kind, self.hdg
        if kind == "line":
            return self.x + ds * math.cos(h0), self.y + ds * math.sin(h0), h0
        if kind == "arc":
            k = self.values[0]
            if abs(k) < 1e-15:
                return self.x + ds * math.cos(h0), self.y + ds * math.sin(h0), h0
            h = h0 + k * ds
            return self.x + (math.sin(h) - math.sin(h0)) / k, self.y - (math.cos(h) - math.cos(h0)) / k, h
        if kind == "spiral":
            k0, k1 = self.values
            rate = (k1 - k0) / self.length if self.length > 0 else 0.0
            u, v = _integrate(lambda d: k0 * d + rate * d * d / 2, ds)
            c, s_ = math.cos(h0), math.sin(h0)
            return self.x + u * c - v * s_, self.y + u * s_ + v * c, h0 + k0 * ds + rate * ds * ds / 2
        # poly3 / paramPoly3: local (u, v) of a parameter p; p is found so that the arc length is ds
        p = self._parameter(ds)
        u, v, du, dv = self._local(p)
        c, s_ = math.cos(h0), math.sin(h0)
        return self.x + u * c - v * s_, self.y + u * s_ + v * c, h0 + math.atan2(dv, du)

    def _local(self, p: float) -> tuple[float, float, float, float]:
        if self.kind == "poly3":
            coefficients = (self.values[0], self.values[1], self.values[2], self.values[3])
            return p, _poly(coefficients, p), 1.0, _poly_slope(coefficients, p)
        au, bu, cu, du_, av, bv, cv, dv_ = self.values[:8]
        return (_poly((au, bu, cu, du_), p), _poly((av, bv, cv, dv_), p),
                _poly_slope((au, bu, cu, du_), p), _poly_slope((av, bv, cv, dv_), p))  # fmt: skip

    def _speed(self, p: float) -> float:
        _, _, du, dv = self._local(p)
        return math.hypot(du, dv)

    def _parameter(self, ds: float) -> float:
        """The parameter whose arc length from the piece's start is *ds* (Newton steps on Simpson's arc length;
        ``paramPoly3`` with ``pRange="normalized"`` runs p over [0, 1])."""
        scale = self.length if self.kind == "paramPoly3" and len(self.values) > 8 and self.values[8] == 1.0 else 1.0
        p = ds / scale
        for _ in range(8):
            arc = _simpson(self._speed, 0.0, p)
            speed = self._speed(p)
            if speed <= 0:
                break
            step = (arc - ds) / speed
            p -= step
            if abs(step) < 1e-9:
                break
        return p


def _simpson(f, a: float, b: float, n: int = 0) -> float:  # type: ignore[no-untyped-def]
    """Composite Simpson's rule with an even number of panels of at most about 1 m (at least 8)."""
    if b == a:
        return 0.0
    n = n or max(8, 2 * math.ceil(abs(b - a) / 2))
    h = (b - a) / n
    total = f(a) + f(b)
    for i in range(1, n):
        total += (4 if i % 2 else 2) * f(a + i * h)
    return total * h / 3


def _integrate(heading, ds: float) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """``(∫cos θ, ∫sin θ)`` over [0, ds] of a heading function (a spiral's), by Simpson's rule."""
    return _simpson(lambda d: math.cos(heading(d)), 0.0, ds), _simpson(lambda d: math.sin(heading(d)), 0.0, ds)


@dataclass(frozen=True)
class Lane:
    """A lane of a lane section: OpenDRIVE id, type, and its ``width`` records ``(sOffset, a, b, c, d)``."""

    id: int
    type: str
    widths: tuple[tuple[float, float, float, float, float], ...]
    starts: tuple[float, ...] = field(init=False, repr=False, compare=False)
    """Where each width record starts (``sOffset``), for the search of :meth:`width`."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "starts", tuple(w[0] for w in self.widths))

    def width(self, ds: float) -> float:
        """Width at *ds* m into its lane section."""
        widths = self.widths
        if not widths:
            return 0.0
        i = max(0, bisect.bisect_right(self.starts, ds) - 1) if len(widths) > 1 else 0
        start, a, b, c, d = widths[i]
        ds -= start
        return max(0.0, a + ds * (b + ds * (c + ds * d)))


@dataclass(frozen=True)
class LaneSection:
    """Lanes from ``s`` on; ``lanes`` by id (no centre lane 0)."""

    s: float
    lanes: Mapping[int, Lane]
    constant: bool = field(init=False, repr=False, compare=False)
    """Whether every lane has one width record and it is constant (so are the lanes' borders along it)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "constant", all(len(lane.widths) == 1 and lane.widths[0][2:] == (0.0, 0.0, 0.0)
                                                 for lane in self.lanes.values()))  # fmt: skip


@dataclass
class Road:
    """One road: its reference line (:class:`Geometry` pieces), lane offsets and sections, and the rule of traffic."""

    id: str
    length: float
    junction: str
    geometries: list[Geometry]
    sections: list[LaneSection]
    offsets: list[tuple[float, float, float, float, float]] = field(default_factory=list)
    left_hand: bool = False
    predecessor: tuple[str, str] | None = None  # (elementType, elementId)
    successor: tuple[str, str] | None = None
    _samples: list[tuple[float, float, float]] = field(default_factory=list, repr=False)
    _starts: tuple[list[float], list[float], list[float]] | None = field(default=None, repr=False)
    _borders: tuple[float, dict[int, tuple[float, float]]] | None = field(default=None, repr=False)
    _fixed: dict[tuple[int, int], dict[int, tuple[float, float]]] = field(default_factory=dict, repr=False)

    def starts(self) -> tuple[list[float], list[float], list[float]]:
        """Where each geometry piece, lane offset record and lane section starts (``s``), computed once."""
        if self._starts is None:
            self._starts = ([g.s for g in self.geometries], [o[0] for o in self.offsets], [sec.s for sec in self.sections])
        return self._starts

    def reference(self, s: float) -> tuple[float, float, float]:
        """``(x, y, heading)`` of the reference line at *s* (clamped to the road)."""
        s = min(max(s, 0.0), self.length)
        i = max(0, bisect.bisect_right(self.starts()[0], s) - 1)
        g = self.geometries[i]
        return g.at(min(s - g.s, g.length))

    def lane_offset(self, s: float) -> float:
        if not self.offsets:
            return 0.0
        i = max(0, bisect.bisect_right(self.starts()[1], s) - 1)
        start, a, b, c, d = self.offsets[i]
        return _poly((a, b, c, d), s - start)

    def section(self, s: float) -> LaneSection:
        i = max(0, bisect.bisect_right(self.starts()[2], s) - 1)
        return self.sections[i]

    def borders(self, s: float) -> dict[int, tuple[float, float]]:
        """Lane id -> ``(t of its inner border, t of its outer border)`` at *s* (inner: towards lane 0).

        The last answer is kept: locating a point asks for the borders at one ``s`` twice (its lane, then
        the lane's centre), every step of a run. The dict returned is shared: do not change it."""
        last = self._borders
        if last is not None and last[0] == s:
            return last[1]
        starts = self.starts()
        k = max(0, bisect.bisect_right(starts[2], s) - 1)
        j = max(0, bisect.bisect_right(starts[1], s) - 1) if self.offsets else -1
        fixed = self._fixed.get((k, j))
        if fixed is not None:
            self._borders = (s, fixed)
            return fixed
        section = self.sections[k]
        ds = s - section.s
        base = self.lane_offset(s)
        out: dict[int, tuple[float, float]] = {}
        for sign in (1, -1):
            t = base
            i = sign
            while i in section.lanes:
                w = section.lanes[i].width(ds)
                out[i] = (t, t + sign * w)
                t += sign * w
                i += sign
        self._borders = (s, out)
        if section.constant and (j < 0 or self.offsets[j][2:] == (0.0, 0.0, 0.0)):
            self._fixed[(k, j)] = out  # the same borders all along the section (on finite s: a + ds * 0.0 is a)
        return out

    def lane_t(self, lane: int, s: float) -> float:
        """``t`` of the centre of lane *lane* at *s*; :class:`KeyError` when the section has no such lane."""
        inner, outer = self.borders(s)[lane]
        return (inner + outer) / 2

    def point(self, s: float, t: float) -> tuple[float, float, float]:
        """``(x, y, heading of the reference line)`` of road coordinates ``(s, t)``."""
        x, y, h = self.reference(s)
        return x - t * math.sin(h), y + t * math.cos(h), h

    def samples(self) -> list[tuple[float, float, float]]:
        """``(s, x, y)`` every :data:`_STEP` m along the reference line (and at its end)."""
        if not self._samples:
            n = max(1, math.ceil(self.length / _STEP))
            for i in range(n + 1):
                s = min(self.length, i * _STEP)
                x, y, _ = self.reference(s)
                self._samples.append((s, x, y))
        return self._samples

    def project(self, x: float, y: float, hint: float | None = None) -> tuple[float, float, float]:
        """``(s, t, distance beyond the road's ends)`` of the world point: the foot of the perpendicular on the
        reference line (the nearest one; *hint*, an ``s`` near the answer, saves the search along the road)."""
        if hint is None or not 0.0 <= hint <= self.length:
            best = min(self.samples(), key=lambda p: (p[1] - x) ** 2 + (p[2] - y) ** 2)
            s = best[0]
        else:
            s = hint
        for _ in range(20):  # Newton on the tangential component of the vector from the line to the point
            rx, ry, h = self.reference(s)
            c, sn = math.cos(h), math.sin(h)
            along = (x - rx) * c + (y - ry) * sn
            if abs(along) < 1e-7:
                break
            s_next = min(max(s + along, 0.0), self.length)
            if s_next == s:
                break
            s = s_next
        else:  # the last step moved s: its line point is not yet worked out
            rx, ry, h = self.reference(s)
            c, sn = math.cos(h), math.sin(h)
            along = (x - rx) * c + (y - ry) * sn
        t = -(x - rx) * sn + (y - ry) * c
        beyond = along if (s >= self.length and along > 0) or (s <= 0 and along < 0) else 0.0
        return s, t, beyond

    def lane_at(self, s: float, t: float) -> int | None:
        """The id of the lane that holds ``t`` at *s* (``None`` outside every lane)."""
        for lane, (inner, outer) in self.borders(s).items():
            if (inner <= t <= outer or outer <= t <= inner) and outer != inner:
                return lane
        return None

    def forward(self, lane: int) -> bool:
        """Whether traffic in *lane* goes with increasing ``s`` (right-hand traffic: negative ids)."""
        return (lane < 0) != self.left_hand


def driving_sign(road: Road, lane: int) -> int:
    """+1 when lane *lane* of *road* runs along ``s``, -1 against it."""
    return 1 if road.forward(lane) else -1


class Network:
    """The roads of one ``.xodr``, by id, in file order."""

    def __init__(self, path: str, roads: Sequence[Road]):
        self.path = path
        self.name = os.path.basename(path)
        self.roads: dict[str, Road] = {r.id: r for r in roads}

    def road(self, road_id: str) -> Road:
        try:
            return self.roads[str(road_id)]
        except KeyError:
            known = ", ".join(list(self.roads)[:10])
            raise OpenDriveError(f"{self.name} has no road {road_id!r} (roads: {known})") from None

    def lane_pose(self, road_id: str, lane: int, s: float, offset: float = 0.0) -> Pose:
        """The :class:`Pose` of ``LanePosition(road, lane, s, offset)``: heading = the lane's driving direction."""
        road = self.road(road_id)
        if not 0.0 <= s <= road.length + 1e-9:
            raise OpenDriveError(f"s = {s:g} is outside road {road.id!r} (0 to {road.length:g} m)")
        s = min(s, road.length)
        try:
            t = road.lane_t(int(lane), s)
        except KeyError:
            have = sorted(road.section(s).lanes)
            raise OpenDriveError(f"road {road.id!r} has no lane {lane} at s = {s:g} (lanes: {have})") from None
        t += offset
        x, y, h = road.point(s, t)
        return Pose(x, y, h if road.forward(int(lane)) else _wrap(h + math.pi), road.id, int(lane), s, t, offset)

    def road_pose(self, road_id: str, s: float, t: float) -> Pose:
        """The :class:`Pose` of ``RoadPosition(road, s, t)``; its lane is the one holding ``t``."""
        road = self.road(road_id)
        if not 0.0 <= s <= road.length + 1e-9:
            raise OpenDriveError(f"s = {s:g} is outside road {road.id!r} (0 to {road.length:g} m)")
        s = min(s, road.length)
        lane = road.lane_at(s, t)
        if lane is None:
            raise OpenDriveError(f"t = {t:g} at s = {s:g} is on no lane of road {road.id!r}")
        x, y, h = road.point(s, t)
        return Pose(x, y, h if road.forward(lane) else _wrap(h + math.pi), road.id, lane, s, t, t - road.lane_t(lane, s))

    def locate(self, x: float, y: float, hint: tuple[str, float] | None = None) -> Pose | None:
        """The road coordinates of a world point: the road (and lane) it lies on, the nearest when several
        do; ``None`` when it is on no lane of any road. *hint*: ``(road, s)`` of a point near it."""
        best: tuple[float, Pose] | None = None
        roads: Iterator[Road]
        if hint is not None and hint[0] in self.roads:
            road = self.roads[hint[0]]
            s, t, beyond = road.project(x, y, hint[1])
            lane = road.lane_at(s, t) if beyond == 0 else None
            if lane is not None:
                return self._pose(road, lane, s, t, x, y)
        roads = iter(self.roads.values())
        for road in roads:
            s, t, beyond = road.project(x, y)
            if beyond:
                continue
            lane = road.lane_at(s, t)
            if lane is None:
                continue
            score = abs(t)
            if best is None or score < best[0]:
                best = (score, self._pose(road, lane, s, t, x, y))
        return best[1] if best is not None else None

    @staticmethod
    def _pose(road: Road, lane: int, s: float, t: float, x: float, y: float) -> Pose:
        h = road.reference(s)[2]
        return Pose(x, y, h if road.forward(lane) else _wrap(h + math.pi), road.id, lane, s, t, t - road.lane_t(lane, s))


def _wrap(angle: float) -> float:
    """*angle* in (-pi, pi]."""
    a = math.fmod(angle + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


# ---------------------------------------------------------------------------------------------------
# reading


def _elements(path: str, shown: str) -> list[tuple[str, dict[str, str], int, int]]:
    try:
        info = os.stat(path)
    except OSError as exc:
        raise OpenDriveError(f"{shown}: cannot read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise OpenDriveError(f"{shown}: not a regular file")
    if info.st_size > MAX_BYTES:
        raise OpenDriveError(f"{shown}: {info.st_size} bytes; the limit is {MAX_BYTES}")
    found: list[tuple[str, dict[str, str], int, int]] = []
    depth = [0]
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attributes: dict[str, str]) -> None:
        depth[0] += 1
        if depth[0] > MAX_DEPTH:
            raise OpenDriveError(f"{shown}:{parser.CurrentLineNumber}: elements nested more than {MAX_DEPTH} levels deep")
        found.append((tag, attributes, parser.CurrentLineNumber, depth[0]))

    def end(_tag: str) -> None:
        depth[0] -= 1

    def doctype(*_args: object) -> None:
        raise OpenDriveError(f"{shown}:{parser.CurrentLineNumber}: a DOCTYPE is not allowed in an OpenDRIVE file of a test case")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = doctype
    try:
        with open(path, "rb") as fh:
            parser.ParseFile(fh)
    except xml.parsers.expat.ExpatError as exc:
        raise OpenDriveError(f"{shown}:{exc.lineno}: not well-formed XML: {xml.parsers.expat.ErrorString(exc.code)}") from None
    except OSError as exc:
        raise OpenDriveError(f"{shown}: cannot read: {exc.strerror or exc}") from None
    return found


def _float(attributes: Mapping[str, str], name: str, where: str, default: float | None = None) -> float:
    text = attributes.get(name)
    if text is None:
        if default is not None:
            return default
        raise OpenDriveError(f"{where}: attribute {name!r} is missing")
    try:
        value = float(text)
    except ValueError:
        raise OpenDriveError(f"{where}: {name}={text!r} is not a number") from None
    if not math.isfinite(value):
        raise OpenDriveError(f"{where}: {name}={text!r} is not a finite number")
    return value


def read_opendrive(path: str, shown: str | None = None) -> Network:
    """Read and check the ``.xodr`` at *path* (*shown*: its name in messages, default the file's name).

    Raises:
        OpenDriveError: unreadable, unsafe, not OpenDRIVE, or a road without reference line or lanes.
    """
    shown = shown or os.path.basename(path)
    elements = _elements(path, shown)
    if not elements or elements[0][0] != "OpenDRIVE":
        root = elements[0][0] if elements else "nothing"
        raise OpenDriveError(f"{shown}: not an OpenDRIVE file (root element <{root}>)")
    roads: list[Road] = []
    road: Road | None = None
    geometry: dict[str, float] | None = None
    section: dict[int, Lane] | None = None
    lane: tuple[int, str, list[tuple[float, float, float, float, float]]] | None = None
    left_hand_default = False
    parent: list[str] = []
    for tag, attributes, line, depth in elements:
        where = f"{shown}:{line}"
        del parent[depth - 1:]
        parent.append(tag)
        up = parent[-2] if len(parent) > 1 else ""
        if tag in ("include", "xi:include") or any(k in ("file", "href", "xi:href") for k in attributes):
            raise OpenDriveError(f"{where}: <{tag}> names a file, which is not allowed (a test case must not make "
                                 "SUMO read other files)")  # fmt: skip
        if tag == "road" and depth == 2:
            _finish_lane(section, lane)
            lane = None
            road_id = attributes.get("id")
            if road_id is None:
                raise OpenDriveError(f"{where}: <road> without an id")
            if any(r.id == road_id for r in roads):
                raise OpenDriveError(f"{where}: road {road_id!r} is declared twice")
            rule = attributes.get("rule", "LHT" if left_hand_default else "RHT")
            road = Road(road_id, _float(attributes, "length", where), attributes.get("junction", "-1"), [], [],
                        left_hand=rule == "LHT")  # fmt: skip
            roads.append(road)
            section = None
        elif road is None:
            continue
        elif tag in ("predecessor", "successor") and up == "link" and depth == 4:
            kind = attributes.get("elementType", "road")
            setattr(road, tag, (kind, attributes.get("elementId", "")))
        elif tag == "geometry" and up == "planView":
            geometry = {k: _float(attributes, k, where) for k in ("s", "x", "y", "hdg", "length")}
        elif up == "geometry" and geometry is not None:
            values: tuple[float, ...]
            if tag == "line":
                values = ()
            elif tag == "arc":
                values = (_float(attributes, "curvature", where),)
            elif tag == "spiral":
                values = (_float(attributes, "curvStart", where), _float(attributes, "curvEnd", where))
            elif tag == "poly3":
                values = tuple(_float(attributes, k, where) for k in "abcd")
            elif tag == "paramPoly3":
                values = tuple(_float(attributes, k, where) for k in ("aU", "bU", "cU", "dU", "aV", "bV", "cV", "dV"))
                values += (1.0 if attributes.get("pRange") == "normalized" else 0.0,)
            else:
                raise OpenDriveError(f"{where}: unknown geometry <{tag}>")
            g = geometry
            road.geometries.append(Geometry(g["s"], g["x"], g["y"], g["hdg"], g["length"], tag, values))
            geometry = None
        elif tag == "laneOffset":
            road.offsets.append((_float(attributes, "s", where), *(_float(attributes, k, where, 0.0) for k in "abcd")))  # type: ignore[arg-type]
        elif tag == "laneSection":
            _finish_lane(section, lane)
            lane = None
            section = {}
            road.sections.append(LaneSection(_float(attributes, "s", where), section))
        elif tag == "lane" and up in ("left", "right") and section is not None:
            _finish_lane(section, lane)
            try:
                lane_id = int(attributes.get("id", ""))
            except ValueError:
                raise OpenDriveError(f"{where}: lane id {attributes.get('id')!r} is not an integer") from None
            lane = (lane_id, attributes.get("type", "none"), [])
        elif tag == "width" and up == "lane" and lane is not None:
            lane[2].append((_float(attributes, "sOffset", where), *(_float(attributes, k, where, 0.0) for k in "abcd")))  # type: ignore[arg-type]
        elif tag == "border" and up == "lane":
            raise OpenDriveError(f"{where}: lane <border> records are not supported (give lane widths)")
    _finish_lane(section, lane)
    if not roads:
        raise OpenDriveError(f"{shown}: no <road>")
    for road in roads:
        if not road.geometries:
            raise OpenDriveError(f"{shown}: road {road.id!r} has no reference line (<planView><geometry>)")
        if not road.sections:
            raise OpenDriveError(f"{shown}: road {road.id!r} has no <laneSection>")
        road.geometries.sort(key=lambda g: g.s)
        road.sections.sort(key=lambda sec: sec.s)
        road.offsets.sort()
    network = Network(path, roads)
    network.name = shown
    return network


def _finish_lane(section: dict[int, Lane] | None, lane: tuple[int, str, list[tuple[float, float, float, float, float]]] | None) -> None:
    if section is not None and lane is not None:
        section[lane[0]] = Lane(lane[0], lane[1], tuple(sorted(lane[2])))
