"""A SUMO scenario made from an OpenDRIVE road and a list of entities (``"road"`` + ``"entities"``).

An OpenSCENARIO scenario names its road network (a ``.xodr``) and places its entities on it in
OpenDRIVE terms. Such a case stays an ordinary SUMO case: this module makes the SUMO files it runs
on, and everything else (checks, runs, signals, reuse of simulations) is the SUMO system's as for a
hand-written ``.sumocfg`` (docs/opendrive.md):

* the road: SUMO's own ``netconvert`` converts the ``.xodr`` (:data:`NETCONVERT_OPTIONS`: world
  coordinates kept as they are, the OpenDRIVE road and lane of every SUMO lane kept as its
  ``origId``), once per content - the result is kept in a cache directory (:func:`cache_dir`) under
  the digest of the file's bytes, netconvert's version and the options; never in the user's tree;
* the entities: one vehicle type and one vehicle per entity, departing at time 0 exactly where its
  position puts its reference point (the OpenSCENARIO reference point, the rear axle's centre: SUMO
  places a vehicle by its front bumper, :func:`place`) at its speed, on a route along the road ahead;
  a route file and a ``.sumocfg`` beside the network, named after their own content.

The ``.xodr`` is read and checked (:func:`~.opendrive.read_opendrive`) from the bytes that are then
copied into the cache and converted, so netconvert reads exactly what was checked.
"""

from __future__ import annotations

import bisect
import functools
import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import tempfile
import threading
import xml.parsers.expat
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Mapping

from .opendrive import Network, OpenDriveError, Pose, read_opendrive

__all__ = ["NETCONVERT_OPTIONS", "Entity", "RoadCase", "SumoLane", "SumoNet", "cache_dir", "netconvert_binary",
           "convert", "road_case", "place", "POSITION_KINDS", "CATEGORIES", "ENTITY_KEYS", "write_sumo_files"]

NETCONVERT_OPTIONS = (
    "--offset.disable-normalization", "true",  # SUMO's x, y are the OpenDRIVE world coordinates
    "--output.original-names", "true",  # every lane keeps its OpenDRIVE road and lane: <param key="origId" value="0_-4"/>
    "--no-turnarounds", "true",  # no U-turns at the road's ends
    "--opendrive.curve-resolution", "0.5",  # curves as polylines with points every 0.5 m (250 m radius: 0.1 mm off)
    "--no-warnings", "true",
)  # fmt: skip
"""How netconvert is run on every ``.xodr`` (docs/opendrive.md)."""

POSITION_KINDS = ("LanePosition", "RelativeLanePosition", "RoadPosition", "RelativeRoadPosition", "WorldPosition",
                  "RelativeWorldPosition", "RelativeObjectPosition")  # fmt: skip
"""The OpenSCENARIO positions an entity's ``position`` (and ``sumo.teleport``) may give."""

CATEGORIES = {"car": "passenger", "van": "delivery", "truck": "truck", "trailer": "trailer", "semitrailer": "truck",
              "bus": "bus", "motorbike": "motorcycle", "bicycle": "bicycle", "train": "rail", "tram": "tram",
              "pedestrian": "ignoring", "wheelchair": "ignoring", "animal": "ignoring", "misc": "ignoring"}  # fmt: skip
"""OpenSCENARIO's vehicle category (and pedestrians, misc objects) -> SUMO's vehicle class."""

ENTITY_KEYS = ("length", "width", "height", "center", "category", "max_speed", "max_accel", "max_decel", "position",
               "speed", "controller", "distance")  # fmt: skip
"""The keys an entity of ``entities`` may have (docs/opendrive.md); any other is refused, not ignored."""

_lock = threading.Lock()


def cache_dir() -> str:
    """Where converted networks and generated files are kept: ``$BTGEN_CACHE``, else
    ``$XDG_CACHE_HOME/btgen_pytrees``, else ``~/.cache/btgen_pytrees``."""
    explicit = os.environ.get("BTGEN_CACHE")
    if explicit:
        return os.path.abspath(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(os.path.abspath(base), "btgen_pytrees")


def netconvert_binary() -> str | None:
    """The ``netconvert`` of the eclipse-sumo wheel (the ``sumo`` extra), else one on the PATH, else None."""
    try:
        import sumo

        binary = os.path.join(sumo.SUMO_HOME, "bin", "netconvert")
        if os.path.isfile(binary):
            return binary
    except ImportError:
        pass
    return shutil.which("netconvert")


@functools.lru_cache(maxsize=1)
def _sumo_version() -> str:
    """The installed SUMO's version, part of the cache key (read once a process: importlib.metadata walks sys.path)."""
    for name in ("eclipse-sumo", "libsumo"):
        try:
            return f"{name} {metadata.version(name)}"
        except metadata.PackageNotFoundError:
            continue
    return "unknown"


def _write(path: str, data: bytes) -> None:
    """Write *path* atomically (a temporary file in its directory, then a rename): readers never see half a file."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), prefix=".tmp-")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        with _suppress():
            os.unlink(tmp)
        raise


class _suppress:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> bool:
        return exc[0] is not None and issubclass(exc[0], OSError)  # type: ignore[arg-type]


_GENERATED = re.compile(rb"<!-- generated on .*?-->\s*", re.S)


def convert(xodr: str) -> tuple[str, Network]:
    """The SUMO network of the ``.xodr`` at *xodr* (the path of the cached ``.net.xml``) and its roads.

    Raises:
        OpenDriveError: the file is unreadable, unsafe or not OpenDRIVE, netconvert is missing or fails, or the
            cache directory cannot be written.
    """
    try:
        return _convert(xodr)
    except OSError as exc:
        raise OpenDriveError(f"{os.path.basename(xodr)}: cannot write the cache directory {cache_dir()} "
                             f"({exc.strerror or exc}); set BTGEN_CACHE to a writable directory") from None


def _convert(xodr: str) -> tuple[str, Network]:
    """:func:`convert`, the cache directory's errors left as they are."""
    shown = os.path.basename(xodr)
    try:
        with open(xodr, "rb") as fh:
            data = fh.read(64 * 1024 * 1024 + 1)
    except OSError as exc:
        raise OpenDriveError(f"{shown}: cannot read: {exc.strerror or exc}") from None
    digest = hashlib.blake2b(data, digest_size=16)
    digest.update(repr((_sumo_version(), NETCONVERT_OPTIONS)).encode())
    key = digest.hexdigest()
    folder = os.path.join(cache_dir(), "sumo", key)
    copy = os.path.join(folder, "road.xodr")
    net = os.path.join(folder, "road.net.xml")
    with _lock:
        if not (os.path.isfile(net) and os.path.isfile(copy)):
            _write(copy, data)
            network = read_opendrive(copy, shown)
            binary = netconvert_binary()
            if binary is None:
                raise OpenDriveError(f"{shown}: converting an OpenDRIVE road needs SUMO's netconvert: pip install -e '.[sumo]'")
            tmp = os.path.join(folder, f".tmp-{os.getpid()}-{threading.get_ident()}.net.xml")
            try:
                done = subprocess.run([binary, "--opendrive-files", copy, "-o", tmp, *NETCONVERT_OPTIONS],
                                      capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL,
                                      check=False, cwd=folder)  # fmt: skip
                if done.returncode != 0 or not os.path.isfile(tmp):
                    why = " ".join(ln.strip() for ln in done.stderr.splitlines() if ln.strip())[:500]
                    raise OpenDriveError(f"{shown}: netconvert could not convert it: {why or 'exit ' + str(done.returncode)}")
                with open(tmp, "rb") as fh:
                    text = _GENERATED.sub(b"", fh.read(), count=1)  # netconvert's header names the time and paths
                _write(net, text)
            except subprocess.TimeoutExpired:
                raise OpenDriveError(f"{shown}: netconvert took more than 300 s") from None
            finally:
                with _suppress():
                    os.unlink(tmp)
            _networks[key] = network
            return net, network
        network = _networks.get(key)
        if network is None:
            network = read_opendrive(copy, shown)
            if len(_networks) >= 16:
                _networks.clear()
            _networks[key] = network
    return net, network


_networks: dict[str, Network] = {}
"""The roads read, by the digest of the ``.xodr``'s bytes (and netconvert's version and options): a sweep's
variations on one road read it once a process (the reading, not the file, is what is kept)."""


# ---------------------------------------------------------------------------------------------------
# the SUMO network as this module needs it


_cumulative: dict[str, tuple[Any, list[float]]] = {}


@dataclass(frozen=True)
class SumoLane:
    """A lane of the SUMO network: its id, edge, index, length (SUMO's lane coordinate), shape, OpenDRIVE origin."""

    id: str
    edge: str
    index: int
    length: float
    shape: tuple[tuple[float, float], ...]
    origin: str  # "road_lane", e.g. "0_-4"; "" when netconvert gave none

    def shape_length(self) -> float:
        return self.cumulative()[-1] if self.shape else 0.0

    def cumulative(self) -> list[float]:
        """The distance along the shape of each of its points (computed once)."""
        kept = _cumulative.get(self.id)
        if kept is None or kept[0] is not self.shape:
            total, out = 0.0, [0.0]
            for a, b in zip(self.shape, self.shape[1:]):
                total += math.dist(a, b)
                out.append(total)
            kept = (self.shape, out)
            _cumulative[self.id] = kept
        return kept[1]

    def project(self, x: float, y: float) -> tuple[float, float, float]:
        """``(distance along the shape, signed lateral distance (left +), distance to the shape)`` of a point."""
        best = (math.inf, 0.0, 0.0)
        along = 0.0
        for (ax, ay), (bx, by) in zip(self.shape, self.shape[1:]):
            dx, dy = bx - ax, by - ay
            seg = math.hypot(dx, dy)
            if seg == 0:
                continue
            u = max(0.0, min(seg, ((x - ax) * dx + (y - ay) * dy) / seg))
            px, py = ax + dx * u / seg, ay + dy * u / seg
            dist = math.hypot(x - px, y - py)
            if dist < best[0] - 1e-12:
                lateral = ((x - ax) * -dy + (y - ay) * dx) / seg
                best = (dist, along + u, lateral)
            along += seg
        return best[1], best[2], best[0]

    def point(self, along: float) -> tuple[float, float, float]:
        """``(x, y, heading)`` *along* m along the shape (extended straight beyond its ends)."""
        cumulative = self.cumulative()
        i = min(max(bisect.bisect_right(cumulative, along) - 1, 0), len(self.shape) - 2)
        while i < len(self.shape) - 2 and cumulative[i + 1] - cumulative[i] <= 0:
            i += 1
        (ax, ay), (bx, by) = self.shape[i], self.shape[i + 1]
        seg = cumulative[i + 1] - cumulative[i]
        u = (along - cumulative[i]) / seg if seg > 0 else 0.0
        return ax + (bx - ax) * u, ay + (by - ay) * u, math.atan2(by - ay, bx - ax)


class SumoNet:
    """Lanes (by id and by OpenDRIVE origin) and connections of a generated ``.net.xml``."""

    def __init__(self, path: str):
        self.path = path
        self.lanes: dict[str, SumoLane] = {}
        self.by_origin: dict[str, list[SumoLane]] = {}
        self.next: dict[str, list[tuple[str, int, int, str]]] = {}  # edge -> (to edge, from lane, to lane, dir)
        self.speeds: dict[str, float] = {}
        edge = [""]
        internal = [False]
        pending: list[dict[str, str]] = []

        def start(tag: str, a: dict[str, str]) -> None:
            if tag == "edge":
                edge[0], internal[0] = a.get("id", ""), a.get("function") == "internal"
            elif tag == "lane" and not internal[0]:
                pending.append(dict(a, edge=edge[0]))
            elif tag == "param" and pending and a.get("key") == "origId":
                pending[-1]["origin"] = a.get("value", "")
            elif tag == "connection" and not a.get("from", "").startswith(":"):
                self.next.setdefault(a.get("from", ""), []).append(
                    (a.get("to", ""), int(a.get("fromLane", "0")), int(a.get("toLane", "0")), a.get("dir", "s")))

        parser = xml.parsers.expat.ParserCreate()
        parser.StartElementHandler = start
        with open(path, "rb") as fh:
            parser.ParseFile(fh)
        for a in pending:
            shape = tuple((float(p.split(",")[0]), float(p.split(",")[1])) for p in a.get("shape", "").split())
            lane = SumoLane(a["id"], a["edge"], int(a.get("index", "0")), float(a.get("length", "0")), shape,
                            a.get("origin", ""))  # fmt: skip
            self.lanes[lane.id] = lane
            self.speeds[lane.id] = float(a.get("speed", "13.89"))
            if lane.origin:
                self.by_origin.setdefault(lane.origin, []).append(lane)

    def lane_of(self, road: str, lane: int, x: float, y: float) -> tuple[SumoLane, float, float] | None:
        """The SUMO lane made from OpenDRIVE lane *lane* of road *road* nearest to point ``(x, y)``, with the
        point's SUMO lane position (SUMO's ``pos``: the distance along the shape scaled to the lane's length)
        and lateral offset (left +); None when netconvert made no SUMO lane of it."""
        best: tuple[float, SumoLane, float, float] | None = None
        for candidate in self.by_origin.get(f"{road}_{lane}", ()):
            along, lateral, dist = candidate.project(x, y)
            if best is None or dist < best[0]:
                best = (dist, candidate, along, lateral)
        if best is None:
            return None
        _, found, along, lateral = best
        factor = found.length / found.shape_length() if found.shape_length() > 0 else 1.0
        return found, along * factor, lateral

    def route(self, edge: str, lane: int) -> list[str]:
        """*edge* and the edges after it, straight on where there is a choice (at most 1000)."""
        out, seen = [edge], {edge}
        while len(out) < 1000:
            options = self.next.get(out[-1], [])
            if not options:
                break
            own = [c for c in options if c[1] == lane] or options
            chosen = next((c for c in own if c[3] == "s"), own[0])
            if chosen[0] in seen:
                break
            out.append(chosen[0])
            seen.add(chosen[0])
            lane = chosen[2]
        return out


# ---------------------------------------------------------------------------------------------------
# entities


@dataclass(frozen=True)
class Entity:
    """One entity as the case declares it (docs/opendrive.md "Entities"): its bounding box, where it starts."""

    name: str
    length: float = 5.0
    width: float = 2.0
    height: float = 1.5
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    category: str = "car"
    max_speed: float = 70.0
    max_accel: float = 10.0
    max_decel: float = 10.0
    position: Mapping[str, Any] | None = None
    speed: Any = 0.0
    controller: Any = False
    distance: Mapping[str, Any] | None = None

    @property
    def front(self) -> float:
        """Metres from the reference point forward to the front bumper."""
        return self.center[0] + self.length / 2

    @property
    def rear(self) -> float:
        """Metres from the reference point back to the rear bumper (positive when it is behind)."""
        return self.length / 2 - self.center[0]


@dataclass
class Placed:
    """An entity placed: its pose (reference point) and where SUMO puts it (lane, front bumper pos, lateral)."""

    entity: Entity
    pose: Pose
    lane: SumoLane
    pos: float
    lateral: float
    speed: float


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise OpenDriveError(f"{where}: expected a number, not {value!r}")
    return float(value)


def _lane_id(value: Any, where: str) -> int:
    if isinstance(value, str):
        try:
            value = int(value)
        except ValueError:
            raise OpenDriveError(f"{where}: lane id {value!r} is not an integer") from None
    if isinstance(value, bool) or not isinstance(value, int) or value == 0 and False:
        raise OpenDriveError(f"{where}: lane id {value!r} is not an integer")
    return int(value)


def shift_lane(lane: int, delta: int) -> int:
    """OpenDRIVE lane id *delta* lanes from *lane* (positive: towards higher ids), skipping the centre lane 0."""
    if delta == 0:
        return lane
    target = lane + delta
    if lane < 0 < target or lane > 0 > target or target == 0:
        target += 1 if delta > 0 else -1
    return target


def resolve(network: Network, position: Mapping[str, Any], placed: Mapping[str, Pose], where: str) -> Pose:
    """The :class:`Pose` of an OpenSCENARIO position object (``{"LanePosition": {...}}``, docs/opendrive.md),
    relative ones against the poses of *placed* entities."""
    kinds = [k for k in position if k in POSITION_KINDS]
    if len(kinds) != 1:
        raise OpenDriveError(f"{where}: give exactly one of {', '.join(POSITION_KINDS)}")
    kind = kinds[0]
    a = position[kind]
    if not isinstance(a, Mapping):
        raise OpenDriveError(f"{where}/{kind}: expected an object of attributes")
    at = f"{where}/{kind}"

    def num(name: str, default: float | None = None) -> float:
        if name not in a:
            if default is None:
                raise OpenDriveError(f"{at}: '{name}' is missing")
            return default
        return _number(a[name], f"{at}/{name}")

    def ref() -> Pose:
        name = a.get("entityRef")
        if not isinstance(name, str) or name not in placed:
            known = ", ".join(placed) or "none yet"
            raise OpenDriveError(f"{at}/entityRef: {name!r} is not an entity placed before (placed: {known})")
        return placed[name]

    if kind == "LanePosition":
        return network.lane_pose(str(a.get("roadId", "")), _lane_id(a.get("laneId"), f"{at}/laneId"), num("s"), num("offset", 0.0))
    if kind == "RoadPosition":
        return network.road_pose(str(a.get("roadId", "")), num("s"), num("t"))
    if kind == "RelativeLanePosition":
        base = ref()
        lane = shift_lane(base.lane, int(num("dLane")))
        road = network.road(base.road)
        sign = 1 if road.forward(base.lane) else -1
        if "dsLane" in a:  # along the target lane's centre: the s it reaches (for constant curvature, exact)
            ds_lane = num("dsLane")
            t_lane = road.lane_t(lane, base.s) if lane in road.borders(base.s) else base.t
            x, y, h = road.reference(base.s)
            curvature = _curvature(road, base.s)
            scale = 1 - curvature * t_lane
            s = base.s + sign * ds_lane / (scale if abs(scale) > 1e-9 else 1.0)
        else:
            s = base.s + sign * num("ds", 0.0)
        return network.lane_pose(base.road, lane, s, num("offset", 0.0))
    if kind == "RelativeRoadPosition":
        base = ref()
        return network.road_pose(base.road, base.s + num("ds"), base.t + num("dt"))
    if kind in ("WorldPosition", "RelativeWorldPosition", "RelativeObjectPosition"):
        if kind == "WorldPosition":
            x, y = num("x"), num("y")
        elif kind == "RelativeWorldPosition":
            base = ref()
            x, y = base.x + num("dx"), base.y + num("dy")
        else:
            base = ref()
            dx, dy = num("dx"), num("dy", 0.0)
            x = base.x + dx * math.cos(base.h) - dy * math.sin(base.h)
            y = base.y + dx * math.sin(base.h) + dy * math.cos(base.h)
        pose = network.locate(x, y)
        if pose is None:
            raise OpenDriveError(f"{at}: ({x:g}, {y:g}) is on no lane of any road of {network.name}")
        return pose
    raise OpenDriveError(f"{at}: unsupported position")  # pragma: no cover - kinds are listed above


def _curvature(road: Any, s: float) -> float:
    step = 0.5
    a, b = max(0.0, s - step), min(road.length, s + step)
    if b <= a:
        return 0.0
    return (_unwrap(road.reference(b)[2] - road.reference(a)[2])) / (b - a)


def _unwrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def place(net: SumoNet, entity: Entity, pose: Pose, where: str, network: Network | None = None) -> tuple[SumoLane, float, float]:
    """Where SUMO puts *entity* whose reference point is at *pose*: ``(lane, pos of the front bumper, lateral)``.

    SUMO's position of a vehicle is its front bumper's middle on its lane, ``pos`` along SUMO's lane coordinate
    (SUMO's ``length`` of the lane, which may differ from its shape's length on curves: SUMO scales), and its
    lateral offset from the lane's centre. The reference point (moved ``center[1]`` m to the box's middle line)
    is projected on the SUMO lane's shape; the front bumper is ``front`` m further along the lane. So SUMO
    shows the reference point where the OpenDRIVE geometry puts it (docs/opendrive.md "From OpenDRIVE to SUMO")."""
    c, s = math.cos(pose.h), math.sin(pose.h)
    mx, my = pose.x - entity.center[1] * s, pose.y + entity.center[1] * c  # on the box's middle line
    lane_id = pose.lane
    if network is not None:  # an offset that reaches into another lane: SUMO's vehicle is on that lane
        road = network.roads.get(pose.road)
        inside = road.lane_at(pose.s, pose.t) if road is not None else None
        if inside is not None and net.by_origin.get(f"{pose.road}_{inside}"):
            lane_id = inside
    found = net.lane_of(pose.road, lane_id, mx, my)
    if found is None:
        raise OpenDriveError(f"{where}: lane {lane_id} of road {pose.road!r} is not a lane SUMO drives on "
                             "(netconvert imports driving lanes; this one is of another type)")  # fmt: skip
    lane, at, lateral = found
    pos = at + entity.front * lane.length / lane.shape_length()
    if pos > lane.length + 1e-6 or at < 0:
        raise OpenDriveError(f"{where}: the front of {entity.name!r} would be off its lane")
    return lane, min(pos, lane.length), lateral


@dataclass
class RoadCase:
    """The SUMO files made for a road case and what the run needs to speak OpenDRIVE (docs/opendrive.md)."""

    config: str
    network: Network
    net: SumoNet
    entities: dict[str, Entity]
    placed: dict[str, Placed]
    routes: dict[str, list[str]]


def entities_of(raw: Any, where: str = "/system/entities") -> dict[str, Entity]:
    """The :class:`Entity` s of a case's ``entities`` object (checked: names, numbers)."""
    if not isinstance(raw, Mapping) or not raw:
        raise OpenDriveError(f"{where}: expected an object of entities by name")
    out: dict[str, Entity] = {}
    for name, spec in raw.items():
        at = f"{where}/{name}"
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name) or name == "sim":
            raise OpenDriveError(f"{at}: an entity's name must be a signal name (a letter, then letters, digits, _), not 'sim'")
        if not isinstance(spec, Mapping):
            raise OpenDriveError(f"{at}: expected an object")
        for key in spec:
            if key not in ENTITY_KEYS:
                raise OpenDriveError(f"{at}/{key}: not a key of an entity (its keys: {', '.join(ENTITY_KEYS)})")
        values: dict[str, Any] = {}
        for key in ("length", "width", "height", "max_speed", "max_accel", "max_decel"):
            if key in spec:
                values[key] = _number(spec[key], f"{at}/{key}")
                if values[key] <= 0:
                    raise OpenDriveError(f"{at}/{key}: must be positive")
        if "center" in spec:
            center = spec["center"]
            if not isinstance(center, list) or len(center) != 3:
                raise OpenDriveError(f"{at}/center: expected [x, y, z]")
            values["center"] = tuple(_number(v, f"{at}/center") for v in center)
        category = spec.get("category", "car")
        if category not in CATEGORIES:
            raise OpenDriveError(f"{at}/category: {category!r} is none of {', '.join(CATEGORIES)}")
        distance = spec.get("distance")
        if distance is not None and not isinstance(distance, Mapping):
            raise OpenDriveError(f"{at}/distance: expected an object (a LongitudinalDistanceAction's attributes)")
        out[name] = Entity(name, category=category, position=spec.get("position"), speed=spec.get("speed", 0.0),
                           controller=spec.get("controller", False), distance=distance, **values)  # fmt: skip
    return out


def _keep_distance(network: Network, entities: Mapping[str, Entity], name: str, pose: Pose, spec: Mapping[str, Any],
                   poses: Mapping[str, Pose], speeds: Mapping[str, float], where: str) -> Pose:  # fmt: skip
    """*pose* moved along its lane to the distance an Init LongitudinalDistanceAction asks from another entity:
    ``{"entityRef", "distance" | "timeGap", "freespace" = false, "displacement" = "trailingReferencedEntity"}``;
    a time gap is counted at the speed of the entity behind (docs/opendrive.md)."""
    ref = spec.get("entityRef")
    if not isinstance(ref, str) or ref not in poses:
        raise OpenDriveError(f"{where}/entityRef: {ref!r} is not an entity placed before (placed: {', '.join(poses) or 'none yet'})")
    other = poses[ref]
    road = network.road(other.road)
    sign = 1.0 if road.forward(other.lane) else -1.0
    side = spec.get("displacement", "trailingReferencedEntity")
    if side not in ("trailingReferencedEntity", "leadingReferencedEntity", "any"):
        raise OpenDriveError(f"{where}/displacement: {side!r} is not trailingReferencedEntity, leadingReferencedEntity or any")
    ahead = side == "leadingReferencedEntity" or (side == "any" and pose.road == other.road and sign * (pose.s - other.s) > 0)
    if "distance" in spec:
        gap = _number(spec["distance"], f"{where}/distance")
    elif "timeGap" in spec:
        gap = _number(spec["timeGap"], f"{where}/timeGap") * (speeds[ref] if ahead else speeds[name])
    else:
        raise OpenDriveError(f"{where}: give 'distance' or 'timeGap'")
    if spec.get("freespace", False):
        me, them = entities[name], entities[ref]
        gap += (them.front + me.rear) if ahead else (me.front + them.rear)
    if pose.road != other.road:
        raise OpenDriveError(f"{where}: {name!r} and {ref!r} are on different roads")
    return network.lane_pose(pose.road, pose.lane, other.s + sign * (gap if ahead else -gap), pose.offset)


def _speed(entity: Entity, speeds: Mapping[str, float], where: str) -> float:
    speed = entity.speed
    if isinstance(speed, Mapping):
        ref = speed.get("entityRef")
        if ref not in speeds:
            raise OpenDriveError(f"{where}/speed/entityRef: {ref!r} is not an entity declared before")
        value = _number(speed.get("value"), f"{where}/speed/value")
        kind = speed.get("type", "delta")
        if kind not in ("delta", "factor"):
            raise OpenDriveError(f"{where}/speed/type: 'delta' or 'factor', not {kind!r}")
        result = speeds[ref] + value if kind == "delta" else speeds[ref] * value
    else:
        result = _number(speed, f"{where}/speed")
    if result < 0:
        raise OpenDriveError(f"{where}/speed: {result:g} m/s; SUMO drives forwards only")
    return result


_cases: dict[tuple[Any, ...], RoadCase] = {}


def road_case(xodr: str, entities_raw: Any, where: str = "/system/entities") -> RoadCase:
    """Convert the road, place the entities, and write (once per content) the route file and ``.sumocfg``.

    A process keeps the last cases made (a sweep's runs make the same one again and again), each for as long
    as the ``.xodr`` keeps its size and modification time and the files made still exist.

    Raises:
        OpenDriveError: what is wrong, naming the file or the JSON path below *where*.
    """
    try:
        info = os.stat(xodr)
        key: tuple[Any, ...] | None = (os.path.abspath(xodr), info.st_size, info.st_mtime_ns, where,
                                       json.dumps(entities_raw, separators=(",", ":")))  # fmt: skip
    except (OSError, TypeError, ValueError):
        key = None
    kept = _cases.get(key) if key is not None else None
    if kept is not None and os.path.isfile(kept.config):
        return kept
    made = _road_case(xodr, entities_raw, where)
    if key is not None:
        if len(_cases) >= 32:
            _cases.clear()
        _cases[key] = made
    return made


def _road_case(xodr: str, entities_raw: Any, where: str) -> RoadCase:
    net_path, network = convert(xodr)
    net = _net(net_path)
    entities = entities_of(entities_raw, where)
    poses: dict[str, Pose] = {}
    speeds: dict[str, float] = {}
    placed: dict[str, Placed] = {}
    for name, entity in entities.items():
        at = f"{where}/{name}"
        if not isinstance(entity.position, Mapping):
            raise OpenDriveError(f"{at}/position: expected a position object, e.g. {{\"LanePosition\": {{...}}}}")
        try:
            pose = resolve(network, entity.position, poses, f"{at}/position")
        except OpenDriveError as exc:
            message = str(exc)
            raise OpenDriveError(message if message.startswith(where) else f"{at}/position: {message}") from None
        speeds[name] = _speed(entity, speeds, at)
        if entity.distance is not None:
            pose = _keep_distance(network, entities, name, pose, entity.distance, poses, speeds, f"{at}/distance")
        lane, pos, lateral = place(net, entity, pose, f"{at}/position", network)
        poses[name] = pose
        placed[name] = Placed(entity, pose, lane, pos, lateral, speeds[name])
    folder = os.path.dirname(net_path)
    routes = _routes(net, placed).encode()
    key = hashlib.blake2b(routes, digest_size=12)
    key.update(_config(os.path.basename(net_path), "").encode())
    rou = os.path.join(folder, f"{key.hexdigest()}.rou.xml")
    cfg = os.path.join(folder, f"{key.hexdigest()}.sumocfg")
    if not os.path.isfile(rou):
        _write(rou, routes)
    if not os.path.isfile(cfg):
        _write(cfg, _config(os.path.basename(net_path), os.path.basename(rou)).encode())
    return RoadCase(cfg, network, net, entities, placed, {n: net.route(p.lane.edge, p.lane.index) for n, p in placed.items()})


_nets: dict[str, tuple[float, SumoNet]] = {}


def _net(path: str) -> SumoNet:
    stamp = os.stat(path).st_mtime_ns
    kept = _nets.get(path)
    if kept is None or kept[0] != stamp:
        if len(_nets) > 16:
            _nets.clear()
        kept = (stamp, SumoNet(path))
        _nets[path] = kept
    return kept[1]


def _g(value: float) -> str:
    return repr(round(value, 6) + 0.0)


def _routes(net: SumoNet, placed: Mapping[str, Placed]) -> str:
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', "<!-- generated by btgen_pytrees from an OpenDRIVE road "
             "(docs/opendrive.md) -->", "<routes>"]  # fmt: skip
    for name, p in placed.items():
        e = p.entity
        decel = e.max_decel
        lines.append(f'    <vType id="{name}" length="{_g(e.length)}" width="{_g(e.width)}" height="{_g(e.height)}" '
                     f'vClass="{CATEGORIES[e.category]}" maxSpeed="{_g(max(e.max_speed, p.speed))}" accel="{_g(e.max_accel)}" '
                     f'decel="{_g(decel)}" emergencyDecel="{_g(max(decel, 9.0))}" sigma="0" speedFactor="1" '
                     f'minGap="2.5" guiShape="passenger"/>')  # fmt: skip
    for name, p in placed.items():
        edges = " ".join(net.route(p.lane.edge, p.lane.index))
        lines.append(f'    <route id="{name}" edges="{edges}"/>')
    for name, p in placed.items():
        lines.append(f'    <vehicle id="{name}" type="{name}" route="{name}" depart="0" departLane="{p.lane.index}" '
                     f'departPos="{_g(p.pos)}" departPosLat="{_g(p.lateral)}" departSpeed="{_g(p.speed)}" '
                     f'insertionChecks="none"/>')  # fmt: skip
    lines.append("</routes>")
    return "\n".join(lines) + "\n"


def _config(net: str, routes: str) -> str:
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<configuration>\n    <input>\n'
            f'        <net-file value="{net}"/>\n        <route-files value="{routes}"/>\n'
            f"    </input>\n    <processing>\n"
            f'        <collision.action value="warn"/>\n        <collision.mingap-factor value="0"/>\n'
            f"    </processing>\n</configuration>\n")  # fmt: skip


def write_sumo_files(case: RoadCase, out_dir: str) -> list[str]:
    """Copy the generated network, route file and ``.sumocfg`` of *case* to *out_dir* (``convert --out-dir``),
    so the directory also runs with plain ``sumo -c``; returns the paths written."""
    written = []
    for path in (case.config, *_inputs(case.config)):
        target = os.path.join(out_dir, os.path.basename(path))
        with open(path, "rb") as fh:
            _write(target, fh.read())
        written.append(target)
    return written


def _inputs(config: str) -> list[str]:
    """The files a generated ``.sumocfg`` names (its net, route and additional files; not its options' values)."""
    folder = os.path.dirname(config)
    with open(config, encoding="utf-8") as fh:
        text = fh.read()
    names = re.findall(r'<(?:net-file|route-files|additional-files) value="([^"]+)"', text)
    return [os.path.join(folder, name) for value in names for name in value.split(",") if name]


def entities_json(raw: Any) -> str:
    """The ``entities`` block as canonical JSON text (what :class:`~btgen_pytrees.model.SystemSpec` keeps)."""
    return json.dumps(raw, separators=(",", ":"), allow_nan=False)
