"""What a SUMO scenario declares, read at load time without starting SUMO.

A test case names a ``.sumocfg`` file; before any run, the loader needs to know
which vehicles, routes, vehicle types, lanes and traffic lights it declares (so
that ``ego.gap`` or ``{"vehicle": "egoo"}`` is a validation error with a JSON
path, not a surprise at run time), and it must be sure the scenario cannot make
the simulator read or write files of its own choosing. This module does both by
reading the XML itself, with :mod:`xml.parsers.expat` (line numbers for every
problem, no DTDs, no entities, no external references):

* the configuration may hold only the input files (``net-file``,
  ``route-files``, ``additional-files``) and the options of :data:`OPTIONS`;
  anything else - an output, a log, ``begin``/``end``, the step length - is a
  problem, because a blocklist of SUMO's many output options would miss one;
* every file it names must be a relative path to a regular file inside the
  configuration's own directory (no absolute path, no ``..``, no symlink out);
* no element of any of those files may name another file (``file``, ``href``,
  ``output``, ... attributes, ``<include>``) or equip a device that writes one
  (``<param key="device.*">``, ``has.*.device``).

**Read once per content.** A search or sweep validates and runs the same
scenario thousands of times in a process (and the SUMO system type reads it when
it checks a case, when it makes the system, and when a cluster ships the files);
:func:`read_scenario` therefore keeps the last :data:`CACHE_SIZE` scenarios read
without problems, each with the real path, size and BLAKE2 digest of every file
it parsed (the digest of the very bytes the parser saw) and its ``stat`` stamp,
and returns a kept one only when every file still has that real path, size and
content (and the limits below are the same) - an edited, replaced or re-linked
file is read and checked again, exactly as the first time. The content is known
unchanged without reading it when the file's stamp (device, inode, size,
modification and change time) is the one taken when its bytes were read and its
change time was then older than :data:`STAMP_MARGIN_NS`; otherwise its bytes are
hashed again (:func:`_unchanged` says why that is safe).

The result is a :class:`Scenario`; problems are plain strings here and become
:class:`~btgen_pytrees.errors.Problem` s with the case's JSON path in
:mod:`btgen_pytrees.systems.sumo` (its `SumoType`).
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import stat
import threading
import time
import xml.parsers.expat
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Callable, Iterator, Mapping

from ...text import closest

__all__ = ["Scenario", "ScenarioError", "read_scenario", "OPTIONS", "parse_options", "MAX_XML_BYTES",
           "MAX_SCENARIO_BYTES", "MAX_XML_DEPTH", "CACHE_SIZE", "RESTORE_DEPART", "STAMP_MARGIN_NS"]  # fmt: skip

MAX_XML_BYTES = 64 * 1024 * 1024
"""Largest configuration, network, route or additional file read (64 MiB)."""

MAX_SCENARIO_BYTES = 128 * 1024 * 1024
"""Largest total of the configuration and every file it names (128 MiB): SUMO reads them all before a run."""

MAX_XML_DEPTH = 32
"""Deepest nesting of elements in any of those files. SUMO's own files nest 5 levels at most
(``routes/vehicle/route/stop/param``); SUMO takes minutes to load a small file nested 200,000 deep."""

INPUTS = ("net-file", "route-files", "additional-files")
"""Options of a ``.sumocfg`` that name input files (each checked, then read)."""


def _number(low: float, high: float = math.inf, integer: bool = False) -> Callable[[str], str | None]:
    def check(text: str) -> str | None:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            return f"expected {'an integer' if integer else 'a number'}, not {text!r}"
        if not (low <= value <= high) or not math.isfinite(value):
            return f"{text} is out of range [{low:g}, {high:g}]"
        return None

    return check


def _choice(*allowed: str) -> Callable[[str], str | None]:
    def check(text: str) -> str | None:
        return None if text in allowed else f"expected one of {', '.join(allowed)}, not {text!r}"

    return check


_BOOL = _choice("true", "false")

OPTIONS: Mapping[str, tuple[Callable[[str], str | None], str]] = {
    "seed": (_number(0, 2**31 - 1, integer=True), "random seed (integer)"),
    "collision.action": (_choice("none", "warn", "teleport", "remove"), "what SUMO does on a collision"),
    "collision.check-junctions": (_BOOL, "also detect collisions on junctions"),
    "collision.mingap-factor": (_number(0, 10), "share of minGap that counts as a collision"),
    "collision.stoptime": (_number(0, 3600), "seconds colliding vehicles stop before the action"),
    "lateral-resolution": (_number(0.01, 10), "sublane width in m (switches on the sublane model)"),
    "default.action-step-length": (_number(0, 10), "seconds between drivers' decisions"),
    "default.speeddev": (_number(0, 1), "default speed deviation of vehicle types"),
    "default.carfollowmodel": (_choice("Krauss", "KraussPS", "KraussOrig1", "SmartSK", "Daniel1", "IDM", "IDMM",
                                       "EIDM", "PWagner2009", "BKerner", "Wiedemann", "W99", "Rail", "ACC", "CACC",
                                       "CC"), "car-following model of types that name none"),  # fmt: skip
    "time-to-teleport": (_number(-1, 1e6), "seconds a blocked vehicle waits before it is teleported (-1: never)"),
    "time-to-teleport.highways": (_number(-1, 1e6), "the same on fast roads"),
    "max-depart-delay": (_number(-1, 1e6), "seconds a vehicle may wait to depart before it is dropped"),
    "lanechange.duration": (_number(0, 100), "seconds a lane change takes (0: instant)"),
    "step-method.ballistic": (_BOOL, "ballistic instead of Euler position update"),
    "ignore-junction-blocker": (_number(-1, 1e6), "ignore vehicles blocking a junction after this many seconds"),
    "emergencydecel.warning-threshold": (_number(0, 100), "warn only above this ratio of emergency braking"),
}
"""Options a case (or its ``.sumocfg``) may set: name -> (value check, description).

Only options that change how traffic behaves; none names a file. The list is
documented in docs/format.md and docs/sumo.md.
"""


class ScenarioError(ValueError):
    """The configuration cannot be used; ``str()`` says why, naming the file and line."""


@dataclass(frozen=True)
class Scenario:
    """The parts of a SUMO scenario a test case may refer to.

    Attributes:
        config: absolute path of the ``.sumocfg``
        vehicles: vehicle id -> depart time text, for ``<vehicle>``/``<trip>`` elements
        routes: route (and route distribution) ids
        types: vehicle type (and type distribution) ids, including SUMO's defaults
        lanes: edge id -> number of lanes (internal edges left out)
        route_edges: route id -> its first edge (for lane checks of ``sumo.spawn``)
        signals: traffic light id -> number of controlled links (length of a state)
        options: options the configuration sets itself
        problems: what is wrong, one line each (``file:line: message``)
        shapes: the network as drawn by the replay page's scene: ``("lane", width, (x0, y0, x1, y1, ...))``
            for every lane (internal ones too) and ``("junction", 0.0, (...))`` for every junction
            outline, in network coordinates; at most :data:`MAX_SHAPE_POINTS` points in all
        files: absolute paths of every file SUMO reads: the configuration, then its inputs
        digest: BLAKE2 digest (hex) of the contents of every file in :attr:`files`, in order: what SUMO
            loads, for the key of a kept simulation (:func:`~.system.reuse_simulations`)
        restore_problem: why a simulation of this scenario kept open between runs cannot be set back to
            its start exactly (``simulation.loadState``; docs/sumo.md "One process, many runs"), or
            ``None`` when it can
    """

    config: str
    vehicles: Mapping[str, str] = field(default_factory=dict)
    routes: frozenset[str] = frozenset()
    types: frozenset[str] = frozenset()
    lanes: Mapping[str, int] = field(default_factory=dict)
    route_edges: Mapping[str, str] = field(default_factory=dict)
    signals: Mapping[str, int] = field(default_factory=dict)
    options: Mapping[str, str] = field(default_factory=dict)
    problems: tuple[str, ...] = ()
    files: tuple[str, ...] = ()
    digest: str = ""
    restore_problem: str | None = "not read"
    shapes: tuple[tuple[str, float, tuple[float, ...]], ...] = field(default=(), repr=False, compare=False)


MAX_SHAPE_POINTS = 200_000
"""Most points of lane and junction outlines kept for the scene (a city network is left partly undrawn)."""


DEFAULT_TYPES = ("DEFAULT_VEHTYPE", "DEFAULT_PEDTYPE", "DEFAULT_BIKETYPE", "DEFAULT_CONTAINERTYPE",
                 "DEFAULT_TAXITYPE", "DEFAULT_RAILTYPE")  # fmt: skip

# attributes that make SUMO read or write another file
_FILE_ATTRIBUTES = frozenset({"file", "files", "href", "output", "outputFile", "filename", "path", "src", "xsi:schemaLocation"})
_FILE_ELEMENTS = frozenset({"include", "xi:include"})
_PARAM_PREFIXES = ("device.", "has.")
_SPLIT = re.compile(r"[,\s]+")


def parse_options(options: tuple[str, ...] | list[str]) -> tuple[dict[str, str], list[tuple[int, str]]]:
    """Split ``["--seed", "7", "--collision.action=warn"]`` into ``{name: value}`` and problems.

    Each problem is ``(index in options, message)``.

    >>> parse_options(["--seed", "7", "--collision.action=warn"])
    ({'seed': '7', 'collision.action': 'warn'}, [])
    >>> parse_options(["--fcd-output", "x.xml"])[1]
    [(0, "option '--fcd-output' is not allowed for SUMO cases (see the allow-list in docs/sumo.md)")]
    """
    values: dict[str, str] = {}
    problems: list[tuple[int, str]] = []
    i = 0
    while i < len(options):
        item = options[i]
        if not isinstance(item, str) or not item.startswith("--"):
            problems.append((i, f"expected an option such as '--seed', not {item!r}"))
            i += 1
            continue
        name, eq, value = item[2:].partition("=")
        if name not in OPTIONS:
            hint = closest(name, OPTIONS)
            tip = f" (did you mean '--{hint}'?)" if hint is not None else " (see the allow-list in docs/sumo.md)"
            problems.append((i, f"option {'--' + name!r} is not allowed for SUMO cases{tip}"))
            i += 1 if eq else 2
            continue
        if not eq:
            if i + 1 >= len(options) or not isinstance(options[i + 1], str):
                problems.append((i, f"option '--{name}' needs a value"))
                break
            i += 1
            value = options[i]
        why = OPTIONS[name][0](value)
        if why:
            problems.append((i, f"--{name}: {why}"))
        elif name in values:
            problems.append((i, f"option '--{name}' is given twice"))
        else:
            values[name] = value
        i += 1
    return values, problems


# ---------------------------------------------------------------------------
# reading XML with line numbers


_Stamp = tuple[int, int, int, int, int]
"""What ``os.stat`` says of a file: device, inode, size, modification and change time (ns)."""
_Seen = dict[str, tuple[str, int, bytes, list[int | _Stamp]]]
"""path -> (real path, size, BLAKE2 digest, [stamp, when]) of each file parsed to its end: *stamp* taken before
the bytes were read, *when* (``time.time_ns()``) too (see :func:`_unchanged`)."""

STAMP_MARGIN_NS = 2_000_000_000
"""How much older than the moment its bytes were read a file's change time must be for its ``stat`` to stand
for its content (2 s: coarser than any file system's time stamps, FAT's 2 s modification times included)."""


def _stamp(info: os.stat_result) -> _Stamp:
    return (info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns, info.st_ctime_ns)


def _elements(path: str, shown: str, seen: _Seen | None = None) -> Iterator[tuple[str, Mapping[str, str], int, int]]:
    """Yield ``(tag, attributes, line, depth)`` of every element of the XML file *path* (root: depth 1).

    *seen*: where to note the file's fingerprint (:func:`_fingerprint`) of the bytes parsed, once read to its end.

    Raises:
        ScenarioError: unreadable, too large, not well-formed, or it declares a DTD.
    """
    try:
        when = time.time_ns()
        info = os.stat(path)
    except OSError as exc:
        raise ScenarioError(f"{shown}: cannot read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise ScenarioError(f"{shown}: not a regular file")
    if info.st_size > MAX_XML_BYTES:
        raise ScenarioError(f"{shown}: {info.st_size} bytes; the limit is {MAX_XML_BYTES}")
    found: list[tuple[str, Mapping[str, str], int, int]] = []
    depth = [0]
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attributes: dict[str, str]) -> None:
        depth[0] += 1
        if depth[0] > MAX_XML_DEPTH:
            raise ScenarioError(f"{shown}:{parser.CurrentLineNumber}: elements nested more than {MAX_XML_DEPTH} "
                                "levels deep (SUMO's own files nest 5 at most)")  # fmt: skip
        found.append((tag, attributes, parser.CurrentLineNumber, depth[0]))

    def end(_tag: str) -> None:
        depth[0] -= 1

    def doctype(*_args: object) -> None:
        raise ScenarioError(f"{shown}:{parser.CurrentLineNumber}: a DOCTYPE is not allowed in a SUMO file of a test case")

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = doctype
    digest = hashlib.blake2b(digest_size=16)
    size = 0
    try:
        with open(path, "rb") as fh:
            while True:
                chunk = fh.read(1 << 20)
                digest.update(chunk)
                size += len(chunk)
                parser.Parse(chunk, not chunk)
                yield from found
                found.clear()
                if not chunk:
                    break
        if seen is not None:
            seen[path] = (os.path.realpath(path), size, digest.digest(), [_stamp(info), when])
    except xml.parsers.expat.ExpatError as exc:
        raise ScenarioError(f"{shown}:{exc.lineno}: not well-formed XML: {xml.parsers.expat.ErrorString(exc.code)}") from None
    except OSError as exc:
        raise ScenarioError(f"{shown}: cannot read: {exc.strerror or exc}") from None


def _inside(base: str, name: str, where: str) -> str:
    """The absolute path of file *name* named by a ``.sumocfg`` in directory *base*; raise if it escapes."""
    if os.path.isabs(name) or re.match(r"^[A-Za-z][A-Za-z0-9+.-]*:", name) or name.startswith(("\\", "~")):
        raise ScenarioError(f"{where}: {name!r} must be a relative path inside the configuration's directory")
    if ".." in re.split(r"[\\/]", name):
        raise ScenarioError(f"{where}: {name!r} must not leave the configuration's directory ('..')")
    if name.endswith(".gz"):
        raise ScenarioError(f"{where}: {name!r}: compressed files are not supported")
    full = os.path.join(base, name)
    real_base, real = os.path.realpath(base), os.path.realpath(full)
    if os.path.commonpath([real_base, real]) != real_base:
        raise ScenarioError(f"{where}: {name!r} leads outside the configuration's directory (a symbolic link)")
    return full


CACHE_SIZE = 8
"""Scenarios :func:`read_scenario` keeps per process (the most recently used; each holds its network's shapes)."""
_cache: "OrderedDict[str, tuple[tuple[int, ...], str, tuple[tuple[str, tuple[str, int, bytes, list[int | _Stamp]]], ...], Scenario]]" = OrderedDict()
"""config path -> (the limits it was checked against, real path of its directory, each file's fingerprint
(real path, size, digest, [stamp, when]), the scenario)."""
_cache_lock = threading.Lock()


def _fingerprint(path: str) -> tuple[str, int, bytes] | None:
    """``(real path, size, BLAKE2 digest)`` of the file at *path* now; ``None`` if it cannot be read."""
    try:
        real = os.path.realpath(path)
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            digest = hashlib.blake2b(digest_size=16)
            read = 0
            while True:
                chunk = fh.read(1 << 20)
                if not chunk:
                    break
                read += len(chunk)
                digest.update(chunk)
    except OSError:
        return None
    return (real, read, digest.digest()) if read == size else None


def _unchanged(base: str, real_base: str, files: tuple[tuple[str, tuple[str, int, bytes, list[int | _Stamp]]], ...]) -> bool:
    """Whether the configuration's directory and every file a kept scenario parsed are as they were then.

    Each file: the same real path and size, and then either the same ``stat`` stamp (device, inode, size,
    modification and change time) as when its bytes were read while that change time was then at least
    :data:`STAMP_MARGIN_NS` old, or the same BLAKE2 digest of its bytes now. Writing a file sets its change
    time to the present, which no program can set back (``os.utime`` sets the modification time only): a
    file written since the bytes were read has another stamp - unless it was written within the time
    stamps' granularity of that read, which is why a stamp younger than the margin is never trusted and the
    bytes are hashed instead (and, when they are the same, the stamp is taken anew).
    """
    if os.path.realpath(base) != real_base:
        return False
    for path, (real, size, digest, noted) in files:
        try:
            when = time.time_ns()
            info = os.lstat(path)
            link = stat.S_ISLNK(info.st_mode)
            if link:
                info = os.stat(path)
        except OSError:
            return False
        if info.st_size != size:  # cheap first: a changed size needs no reading
            return False
        stamp, taken = noted
        if stamp == _stamp(info) and info.st_ctime_ns < taken - STAMP_MARGIN_NS:  # type: ignore[operator]
            if _real_path(path, base, real_base, link) != real:
                return False
            continue
        if _fingerprint(path) != (real, size, digest):
            return False
        noted[:] = [_stamp(info), when]  # the same bytes: their stamp may stand for them from now on
    return True


def _real_path(path: str, base: str, real_base: str, link: bool) -> str:
    """``os.path.realpath(path)``, given *real_base*, the real path of directory *base* just now, and whether
    *path* is a symbolic link: a file named directly in *base* that is not a link is *real_base* joined with
    its name (``realpath`` would ``lstat`` every component of *base* again); anything else asks ``realpath``."""
    if not link:
        head, name = os.path.split(path)
        if head == base and name not in ("", ".", ".."):
            return os.path.join(real_base, name)
    return os.path.realpath(path)


def read_scenario(config: str) -> Scenario:
    """The :class:`Scenario` of the ``.sumocfg`` at *config*; problems are in :attr:`Scenario.problems`.

    A scenario read before without problems whose files all still have the same real path, size
    and content is returned as it was (see the module docstring); anything else is read again.
    """
    config = os.path.abspath(config)
    base = os.path.dirname(config)
    limits = (MAX_XML_BYTES, MAX_SCENARIO_BYTES, MAX_XML_DEPTH, MAX_SHAPE_POINTS)
    with _cache_lock:
        kept = _cache.get(config)
    if kept is not None and kept[0] == limits and _unchanged(base, kept[1], kept[2]):
        with _cache_lock:
            if config in _cache:
                _cache.move_to_end(config)
        return kept[3]
    real_base = os.path.realpath(base)
    seen: _Seen = {}
    scenario = _read_scenario(config, seen)
    if not scenario.problems and set(seen) >= set(scenario.files):
        with _cache_lock:
            _cache[config] = (limits, real_base, tuple((path, seen[path]) for path in scenario.files), scenario)
            _cache.move_to_end(config)
            while len(_cache) > CACHE_SIZE:
                _cache.popitem(last=False)
    return scenario


def _read_scenario(config: str, seen: _Seen) -> Scenario:
    shown = os.path.basename(config)
    base = os.path.dirname(config)
    try:
        options, inputs = _read_config(config, shown, base, seen)
        net = inputs.get("net-file", [])
        if len(net) != 1:
            raise ScenarioError(f"{shown}: needs exactly one 'net-file' (found {len(net)})")
        _check_total([config, *net, *inputs.get("route-files", []), *inputs.get("additional-files", [])], shown)
        lanes: dict[str, int] = {}
        signals: dict[str, int] = {}
        shapes: list[tuple[str, float, tuple[float, ...]]] = []
        net_problem: list[str | None] = [None]
        _read_net(net[0], os.path.relpath(net[0], base), lanes, signals, shapes, seen, net_problem)
        demand = _Demand(lanes)
        for path in inputs.get("route-files", []) + inputs.get("additional-files", []):
            demand.read(path, os.path.relpath(path, base), seen)
        demand.check()
    except ScenarioError as exc:
        return Scenario(config, problems=(str(exc),))
    files = tuple(dict.fromkeys((config, *net, *inputs.get("route-files", []), *inputs.get("additional-files", []))))
    digest = hashlib.blake2b(digest_size=16)
    for path in files:
        digest.update(seen[path][2] if path in seen else b"?")
    return Scenario(config, demand.vehicles, frozenset(demand.routes), frozenset(demand.types), lanes,
                    demand.route_edges, signals, options, shapes=tuple(shapes), files=files,
                    digest=digest.hexdigest(), restore_problem=net_problem[0] or demand.restore_problem())  # fmt: skip


def _check_total(paths: list[str], shown: str) -> None:
    """Raise if the files SUMO would read add up to more than :data:`MAX_SCENARIO_BYTES` (each file is
    checked on its own when it is read)."""
    total = 0
    for path in dict.fromkeys(paths):
        try:
            total += os.stat(path).st_size
        except OSError:
            continue  # reading it says why
    if total > MAX_SCENARIO_BYTES:
        raise ScenarioError(f"{shown}: the configuration and the files it names are {total} bytes together; "
                            f"the limit is {MAX_SCENARIO_BYTES}")  # fmt: skip


_SECTIONS = frozenset({
    "input", "output", "time", "processing", "routing", "report", "random_number", "gui_only", "traci_server",
    "mesoscopic", "emissions", "communication", "battery", "pedestrian", "ssm_device", "toc_device",
})  # fmt: skip


def _read_config(config: str, shown: str, base: str, seen: _Seen | None = None) -> tuple[dict[str, str], dict[str, list[str]]]:
    options: dict[str, str] = {}
    inputs: dict[str, list[str]] = {}
    empty = True
    for tag, attributes, line, depth in _elements(config, shown, seen):
        where = f"{shown}:{line}"
        empty = False
        if depth == 1:
            if tag not in ("configuration", "sumoConfiguration"):
                raise ScenarioError(f"{where}: not a SUMO configuration (root element <{tag}>)")
            continue
        if depth == 2 and tag in _SECTIONS:
            if attributes:
                raise ScenarioError(f"{where}: write options as <name value=\"...\"/> elements inside <{tag}>")
            continue
        value = attributes.get("value")
        if value is None or len(attributes) != 1:
            raise ScenarioError(f"{where}: <{tag}> needs exactly one attribute, 'value'")
        if tag in INPUTS:
            names = [n for n in _SPLIT.split(value.strip()) if n]
            inputs.setdefault(tag, []).extend(_inside(base, n, where) for n in names)
        elif tag in OPTIONS:
            why = OPTIONS[tag][0](value)
            if why:
                raise ScenarioError(f"{where}: {tag}: {why}")
            options[tag] = value
        else:
            raise ScenarioError(f"{where}: option {tag!r} is not allowed in the configuration of a test case "
                                f"(only {', '.join(INPUTS)} and the options of docs/sumo.md)")  # fmt: skip
    if empty:
        raise ScenarioError(f"{shown}: empty configuration")
    return options, inputs


def _check_element(tag: str, attributes: Mapping[str, str], where: str) -> None:
    if tag in _FILE_ELEMENTS:
        raise ScenarioError(f"{where}: <{tag}> is not allowed (a test case must not make SUMO read other files)")
    for name in attributes:
        if name in _FILE_ATTRIBUTES or name.lower().endswith(("file", "output")):
            raise ScenarioError(f"{where}: attribute {name!r} of <{tag}> names a file; "
                                "a test case must not make SUMO read or write files")  # fmt: skip
    if tag == "param" and attributes.get("key", "").startswith(_PARAM_PREFIXES):
        raise ScenarioError(f"{where}: <param key={attributes['key']!r}> equips a device (devices may write files)")


def _points(text: str) -> tuple[float, ...]:
    """``"x,y x,y ..."`` (a SUMO shape) as flat floats; ``()`` when it does not read."""
    try:
        flat = tuple(float(v) for pair in text.split() for v in pair.split(",")[:2])
    except ValueError:
        return ()
    return flat if len(flat) % 2 == 0 and all(math.isfinite(v) for v in flat) else ()


def _read_net(path: str, shown: str, lanes: dict[str, int], signals: dict[str, int],
              shapes: list[tuple[str, float, tuple[float, ...]]] | None = None, seen: _Seen | None = None,
              restore: list[str | None] | None = None) -> None:  # fmt: skip
    """Read the network: lanes per edge, traffic lights, the scene's shapes; ``restore[0]`` gets why a kept
    simulation of it cannot be restored exactly (a traffic light that is not fixed-time keeps detector
    state that SUMO's state file leaves out)."""
    edge: str | None = None
    logic = ""
    empty = True
    room = MAX_SHAPE_POINTS
    for tag, attributes, line, depth in _elements(path, shown, seen):
        where = f"{shown}:{line}"
        if depth == 1 and tag != "net":
            raise ScenarioError(f"{where}: not a SUMO network (root element <{tag}>)")
        empty = False
        _check_element(tag, attributes, where)
        if tag == "edge":
            edge = None if attributes.get("function") == "internal" else attributes.get("id")
            if edge is not None:
                lanes[edge] = 0
        elif tag == "lane" and edge is not None:
            lanes[edge] += 1
        if shapes is not None and room > 0 and tag in ("lane", "junction") and "shape" in attributes:
            points = _points(attributes["shape"])
            if tag == "junction" and attributes.get("type") == "internal":
                points = ()
            if points:
                try:
                    width = float(attributes.get("width", "3.2")) if tag == "lane" else 0.0
                except ValueError:
                    width = 3.2
                shapes.append((tag, width if math.isfinite(width) else 3.2, points))
                room -= len(points) // 2
        elif tag == "tlLogic":
            logic = attributes.get("id", "")
            signals.setdefault(logic, 0)
            kind = attributes.get("type", "static")
            if restore is not None and restore[0] is None and kind != "static":
                restore[0] = f"traffic light {logic!r} is {kind!r}, not fixed-time ('static')"
        elif tag == "phase" and depth == 3:
            signals[logic] = max(signals.get(logic, 0), len(attributes.get("state", "")))
    if empty:
        raise ScenarioError(f"{shown}: empty network file")


RESTORE_DEPART = 100.0
"""Latest departure (s) of a vehicle of a scenario whose kept simulation is restored between runs: half of
SUMO's ``--route-steps`` (200 s), so every vehicle has been read from its file when SUMO starts."""

_RESTORABLE = frozenset({"vType", "vTypeDistribution", "route", "routeDistribution", "vehicle", "trip"})


def _early(depart: str) -> bool:
    try:
        value = float(depart)
    except ValueError:
        return False
    return math.isfinite(value) and 0 <= value <= RESTORE_DEPART


class _Demand:
    """Collects vehicles, routes and types from route and additional files."""

    def __init__(self, lanes: Mapping[str, int]):
        self.lanes = lanes
        self.vehicles: dict[str, str] = {}
        self.routes: set[str] = set()
        self.types: set[str] = set(DEFAULT_TYPES)
        self.route_edges: dict[str, str] = {}
        self.uses: list[tuple[str, str, str, str]] = []  # (where, vehicle, "type"/"route", id)
        self.restore: str | None = None  # the first reason a kept simulation cannot be restored exactly

    def restore_problem(self) -> str | None:
        """Why a simulation of this demand cannot be set back to time 0 with ``simulation.loadState``.

        SUMO reads route files bit by bit (``--route-steps``, 200 s ahead) and a state loaded later does
        not rewind that reading; flows, persons and other elements have state of their own. Exact: only
        ``vType``, ``route`` (and their distributions), ``vehicle`` and ``trip`` elements, every vehicle
        departing at a number of seconds up to :data:`RESTORE_DEPART` - all read when SUMO starts.
        """
        return self.restore

    def read(self, path: str, shown: str, seen: _Seen | None = None) -> None:
        in_distribution = False
        empty = True
        for tag, attributes, line, depth in _elements(path, shown, seen):
            where = f"{shown}:{line}"
            if depth == 1:
                if tag not in ("routes", "additional"):
                    raise ScenarioError(f"{where}: not a SUMO route or additional file (root element <{tag}>)")
                empty = False
                continue
            _check_element(tag, attributes, where)
            ident = attributes.get("id")
            if depth == 2:
                in_distribution = tag == "routeDistribution"
                if self.restore is None and tag not in _RESTORABLE:
                    self.restore = f"{where}: <{tag}> (only {', '.join(sorted(_RESTORABLE))} are restored exactly)"
            if tag in ("vType", "vTypeDistribution") and ident:
                self.types.add(ident)
            elif tag == "routeDistribution" and ident:
                self.routes.add(ident)
            elif tag == "route":
                edges = attributes.get("edges", "").split()
                for e in edges:
                    if e not in self.lanes:
                        raise ScenarioError(f"{where}: the route uses edge {e!r}, which the network does not have")
                if ident and (depth == 2 or in_distribution):
                    self.routes.add(ident)
                    if edges:
                        self.route_edges[ident] = edges[0]
            elif tag in ("vehicle", "trip") and depth == 2:
                if not ident:
                    raise ScenarioError(f"{where}: <{tag}> without an id")
                if ident in self.vehicles:
                    raise ScenarioError(f"{where}: vehicle {ident!r} is declared twice")
                self.vehicles[ident] = attributes.get("depart", "")
                if self.restore is None and not _early(self.vehicles[ident]):
                    self.restore = (f"{where}: vehicle {ident!r} departs at {self.vehicles[ident]!r} (restored exactly: "
                                    f"a number of seconds up to {RESTORE_DEPART:g})")  # fmt: skip
                for key in ("type", "route"):
                    if key in attributes:
                        self.uses.append((where, ident, key, attributes[key]))
        if empty:
            raise ScenarioError(f"{shown}: empty file")

    def check(self) -> None:
        for where, vehicle, key, ident in self.uses:
            known = self.types if key == "type" else self.routes
            if ident not in known:
                raise ScenarioError(f"{where}: vehicle {vehicle!r} uses {key} {ident!r}, which no file declares")
