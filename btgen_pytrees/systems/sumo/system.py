"""One SUMO simulation driven by a run, through libsumo.

libsumo is SUMO linked into the Python process: no socket, no child process,
about 15 times faster than TraCI over a socket, but *one simulation per
process*. :class:`SumoSystem` therefore refuses to start while another one is
running in the same process (batch mode runs cases in worker processes, one at a
time each), and :meth:`SumoSystem.close` always gives the simulation back.

Time. SUMO executes the step at time 0 inside :meth:`SumoSystem.start`, so
vehicles that depart at 0 are in the network when the tree first ticks; the
state the tree sees at run time *t* is SUMO's state after its step at *t* (what
SUMO's own outputs label *t*), and a command a leaf gives at *t* acts in the
step at *t + tick*. :meth:`SumoSystem.now` is SUMO's own time of that step
(``simulation.getTime()`` before it), so the run's clock is SUMO's clock and
nothing else: SUMO keeps time in whole milliseconds, and a case whose tick is
not a whole number of them is refused when it is loaded (:func:`tick_problem`),
so SUMO's steps are the case's ticks.

Signals. For every *tracked* vehicle V (declared in the route files with an id
that is a signal name, or added by ``sumo.spawn``)::

    V.present   bool   in the network now
    V.collided  bool   has been in a collision (stays true)
    V.lane      int    lane index, -1 while not in the network
    V.speed     m/s    V.accel  m/s²   V.x, V.y  m   V.lateral  m from the lane centre
    V.distance  m driven since departure
    V.gap       m bumper to bumper to the leader SUMO sees ahead, up to LOOKAHEAD (inf without one)
    V.ttc       s to collision with that leader at current speeds (inf when not closing or no leader)

and ``sim.collisions`` (collision events so far; a pair in contact over several
steps counts once) and ``sim.vehicles`` (vehicles in the network). While V is
not in the network only ``present``, ``collided`` and ``lane`` have values: an
expression that reads another attribute then has no value and a criterion on it
fails ("signal 'ego.gap' has no value") instead of passing on a stale number.

Values are read with libsumo subscriptions (one call per step for all vehicles)
and written straight into the tree's blackboard namespace (``<ns>/signals/``,
see :mod:`btgen_pytrees.contracts.environment`). A run that records no trace reads
and writes only the signals its tree reads (``Environment.wanted``; :meth:`SumoSystem._plan`).
"""

from __future__ import annotations

import atexit
import contextlib
import io
import math
import multiprocessing.util
import os
import re
import subprocess
import sys
import tempfile
import threading
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, Mapping

from py_trees.blackboard import Blackboard

from ...contracts.system import SystemFailure
from .opendrive import Pose
from .roads import RoadCase
from .scenario import Scenario

if TYPE_CHECKING:  # pragma: no cover
    from ...contracts.environment import Environment

__all__ = ["SumoSystem", "CommandError", "ATTRIBUTES", "ROAD_ATTRIBUTES", "PAIR_ATTRIBUTES", "SIM_SIGNALS", "ROAD_SIM_SIGNALS", "DEFAULTS", "libsumo_module", "INSTALL_HINT", "tick_problem",
           "LOOKAHEAD", "reuse_simulations", "reuse_for", "kept_simulation", "keep_simulations",
           "release_simulations"]

INSTALL_HINT = "pip install -e '.[sumo]'"
ATTRIBUTES = ("speed", "accel", "x", "y", "lane", "lateral", "distance", "gap", "ttc", "present", "collided")
"""The signals of each vehicle, ``<vehicle>.<attribute>``."""
ROAD_ATTRIBUTES = ("ref_x", "ref_y", "heading", "road", "lane_id", "s", "t", "offset", "still", "end_of_road")
"""The further signals of each entity of a case on an OpenDRIVE road, ``<entity>.<attribute>`` (docs/opendrive.md)."""
_SUMO_ROAD = frozenset(("still", "end_of_road"))
"""Road signals of SUMO's own state (speed, lane position): they need no OpenDRIVE pose and have a value while the
entity is in the network, also where its reference point is on no lane of the road."""
PAIR_ATTRIBUTES = ("distance", "distance_free", "dx", "dy", "dx_free", "dy_free", "ds", "dt", "ds_free", "dt_free",
                   "dlane", "headway", "headway_free", "ttc", "ttc_free")  # fmt: skip
"""The signals of each ordered pair of entities A, B on an OpenDRIVE road, ``A.B.<attribute>`` (docs/opendrive.md)."""
SIM_SIGNALS = ("sim.collisions", "sim.vehicles")
ROAD_SIM_SIGNALS = ("sim.time",)
"""The further signals of the simulation of a case on an OpenDRIVE road: ``sim.time``, SUMO's time of the tick (s)."""
DEFAULTS = {"collision.action": "warn"}
"""SUMO options a run sets where neither the case's ``options`` nor its ``.sumocfg`` do. SUMO's own
``collision.action`` is ``teleport``: in the step of the collision the collider is moved hundreds of
metres ahead (or to its next edge), so no signal, trace or scene ever shows the two vehicles where they
met. ``warn`` leaves them where they are, in contact, on the tick the collision counts (docs/sumo.md)."""
HALTING = 0.1
"""m/s: slower than this an entity stands still (``E.still``), SUMO's own halting speed (its car-following
models approach a standing car ever slower, never reaching 0)."""

ARRIVAL_EPS = 0.1
"""SUMO arrives a vehicle (takes it off the road) once its front is within this distance of the end of its
route (its POSITION_EPS): ``E.end_of_road`` holds from the step that brings it there, so it is never missed."""
LOOKAHEAD = 1000.0
"""Metres ahead in which a vehicle's leader counts (``V.gap`` and ``V.ttc`` are inf beyond; SUMO itself
reports a leader further ahead on the same lane)."""

_MOTION = ("speed", "accel", "x", "y", "lateral", "distance", "gap", "ttc")
_INF = math.inf

# libsumo variable ids (traci.constants)
_SPEED, _POSITION, _LANE_INDEX, _LEADER, _ACCEL, _DISTANCE, _LATERAL = 0x40, 0x42, 0x52, 0x68, 0x72, 0x84, 0xB8
_ANGLE = 0x43
_LANE_ID, _LANE_POSITION = 0x51, 0x56
_ROAD = (_SPEED, _POSITION, _ANGLE, _LANE_ID, _LANE_POSITION, _LATERAL)
"""What an entity on an OpenDRIVE road is read for when a road signal of it (or of a pair with it) is wanted."""
_VARIABLES = (_SPEED, _ACCEL, _POSITION, _LANE_INDEX, _LATERAL, _DISTANCE, _ANGLE)
_PLACE = (_POSITION, _ANGLE)  # every other vehicle: where it is, for the replay page's scene
_CORE = (_SPEED, _POSITION, _LANE_INDEX)
"""What a tracked vehicle is always read for: its speed and lane (the action leaves ask), and where it is."""
_OWN = {"accel": _ACCEL, "lateral": _LATERAL, "distance": _DISTANCE}
"""The attributes read with a variable of their own when the run wants them (:attr:`Environment.wanted`)."""
_DIRECT = (("lane", _LANE_INDEX), ("speed", _SPEED), ("accel", _ACCEL), ("lateral", _LATERAL), ("distance", _DISTANCE))
"""The attributes published as SUMO gives them, each from its variable."""

_active: "SumoSystem | None" = None
"""The simulation libsumo is running in this process, if any (read and changed only under :data:`_claim`)."""
_claim = threading.Lock()
_kept: "_Kept | None" = None
"""A simulation left open by the last run, for the next run of the same key (only under :data:`_claim`)."""
_scopes = 0
"""How many :func:`reuse_simulations` blocks are open in this process (only under :data:`_claim`)."""
_unrestorable: set[tuple[Any, ...]] = set()
"""Keys whose snapshot could not be taken (SUMO refused a step of it): those start afresh every run."""
_drawing: dict[tuple[Any, ...], frozenset[str]] = {}
"""Key -> the random number generators its runs were seen to draw from (see :class:`_Kept`)."""


@contextlib.contextmanager
def reuse_simulations() -> Iterator[None]:
    """Within this block, a SUMO run leaves its simulation open for the next run of the same key.

    The key is the whole command line and the digest of every scenario file's contents. The next
    run with that key sets the simulation back to time 0 with ``simulation.loadState`` instead of
    starting SUMO (with the check of the generators after each run, about 60 % of a start and a
    close on the example); a run with another key, or a run outside any block, closes it first;
    the end of the outermost block closes it; a key's first run in a process is not kept (it
    learns which generators the snapshot must hold). Only scenarios SUMO restores
    exactly are kept (:attr:`~.scenario.Scenario.restore_problem`), and the random number
    generators are set back too, so a run gives the same report whatever ran before it in the
    process (docs/sumo.md, "One process, many runs"). Blocks nest; any thread may open one.
    """
    keep_simulations()
    try:
        yield
    finally:
        release_simulations()


def keep_simulations() -> None:
    """Open a :func:`reuse_simulations` block without a ``with``: until :func:`release_simulations`, or for
    the rest of the process. A kept pool's worker process (:class:`~btgen_pytrees.parallel.pool.Workers`,
    a search's) calls it before its first task, and a Dask worker before its first task of a sweep or a
    search, so its SUMO stays open from one task to the next and is set back between them. A simulation
    still kept is closed when the process leaves (atexit, or multiprocessing's finalizers), or by a run
    with another key."""
    global _scopes
    with _claim:
        _scopes += 1


def release_simulations() -> None:
    """Close the block :func:`keep_simulations` opened (the end of the outermost closes the kept simulation)."""
    global _scopes
    with _claim:  # closed under the claim: no run may start libsumo while it closes
        _scopes = max(0, _scopes - 1)
        kept = _take_kept() if _scopes == 0 else None
        if kept is not None:
            kept.close()


def reuse_for(runs: int) -> contextlib.AbstractContextManager[None]:
    """:func:`reuse_simulations` for a job of *runs* runs: the block when there are two or more, nothing for
    one (no next run to keep SUMO for). What the sweep's and the search's jobs open."""
    return reuse_simulations() if runs > 1 else contextlib.nullcontext()


def kept_simulation() -> tuple[Any, ...] | None:
    """The key of the simulation kept open in this process (``(command line, scenario digest)``), or ``None``."""
    with _claim:
        return _kept.key if _kept is not None else None


def _take_kept() -> "_Kept | None":
    """Take the kept simulation out of :data:`_kept` (the caller holds :data:`_claim`)."""
    global _kept
    kept, _kept = _kept, None
    return kept


def _close_kept_at_exit() -> None:
    with _claim:
        kept = _take_kept()
        if kept is not None:
            kept.close()


def _forget_kept_in_child() -> None:
    """A forked child (a worker of the local pool) gets a copy of a kept simulation: close the copy, never
    use it (the parent's stays the parent's). No lock: the child has one thread, and a lock another thread
    of the parent held at the fork stays held in the child."""
    global _kept, _scopes
    kept, _kept, _scopes = _kept, None, 0
    if kept is not None:
        kept.close()


_exit_hooks = 0
"""The process that registered :func:`_close_kept_at_exit` with multiprocessing (0: none yet)."""


def _close_at_exit() -> None:
    """Make sure this process closes a kept simulation when it leaves: ``atexit`` for a normal process, and
    multiprocessing's finalizers for a worker process (which leaves by ``os._exit`` after running them, not
    atexit; a forked one starts with none, so this is called anew in each process that keeps one)."""
    global _exit_hooks
    if _exit_hooks != os.getpid():
        _exit_hooks = os.getpid()
        multiprocessing.util.Finalize(None, _close_kept_at_exit, exitpriority=0)


atexit.register(_close_kept_at_exit)
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_kept_in_child)


def tick_problem(tick: Any) -> str | None:
    """What is wrong with *tick* (s) as SUMO's step length, or ``None``.

    SUMO keeps time in whole milliseconds and rounds ``--step-length`` to them
    (0.0125 s steps 0.013 s): a tick that is not a whole number of milliseconds
    would make the case's time and SUMO's disagree. Other problems of the value
    (not a number, not finite, not positive) are the loader's to report.

    >>> tick_problem(0.1) is None, tick_problem(0.0125)
    (True, 'SUMO keeps time in whole milliseconds: a tick of 0.0125 s is not one; the nearest valid ticks are 0.012 and 0.013 s')
    >>> tick_problem(0.0005)
    "SUMO keeps time in whole milliseconds: a tick of 0.0005 s is below SUMO's resolution; the smallest valid tick is 0.001 s"
    """
    if isinstance(tick, bool) or not isinstance(tick, (int, float)) or not math.isfinite(tick) or tick <= 0:
        return None
    ms = tick * 1000
    whole = math.floor(ms + 0.5)
    if whole >= 1 and abs(ms - whole) <= 1e-9 * ms:
        return None
    if ms < 1:
        return (f"SUMO keeps time in whole milliseconds: a tick of {tick:g} s is below SUMO's resolution; "
                "the smallest valid tick is 0.001 s")  # fmt: skip
    return (f"SUMO keeps time in whole milliseconds: a tick of {tick:g} s is not one; the nearest valid ticks are "
            f"{math.floor(ms) / 1000:g} and {math.ceil(ms) / 1000:g} s")  # fmt: skip


def libsumo_module() -> Any:
    """Import libsumo (only SUMO cases need it); a clear :class:`SystemFailure` when it is missing.

    libsumo's first import prints a warning on stdout when a pyarrow of another
    version than SUMO's own is installed (the ``parquet`` extra); stdout carries
    the run's table and ``--json -``, so that print goes nowhere.
    """
    try:
        if "libsumo" not in sys.modules:
            with contextlib.redirect_stdout(io.StringIO()):
                import libsumo  # noqa: F401
        import libsumo
    except ImportError as exc:
        raise SystemFailure(f"the 'sumo' system needs libsumo ({exc}); install the extra: {INSTALL_HINT}") from None
    return libsumo


def _release(system: "SumoSystem") -> None:
    global _active
    with _claim:
        if _active is system:
            _active = None


class CommandError(RuntimeError):
    """SUMO refused a command of an action leaf (the leaf fails with this message)."""


class SumoSystem:
    """A SUMO scenario for one run (see the module docstring for time and signals).

    Args:
        scenario: the checked scenario (:func:`~.scenario.read_scenario`)
        options: allowed options, ``{name: value}`` (from the case; they win over the configuration's)
        tick: the step length, the case's ``tick``
        tracked: vehicles that get signals
        spawns: whether the case adds vehicles (then an empty network does not end the run)
        road: the case's OpenDRIVE road and entities (docs/opendrive.md), or None
    """

    def __init__(self, scenario: Scenario, options: Mapping[str, str], tick: float, tracked: Iterable[str],
                 spawns: bool = False, road: RoadCase | None = None):  # fmt: skip
        self.road = road
        self.exact: frozenset[str] = frozenset(n for n, e in road.entities.items() if not e.controller) if road else frozenset()
        """Entities driven storyboard-exactly: no car-following, no lane changes of their own (speed and lane-change mode 0)."""
        self.poses: dict[str, Pose] = {}  # entity -> its pose on the road at the last step read (road cases)
        self._posed: dict[str, tuple[int, Pose | None]] = {}  # entity -> (the step, its pose then): pose()'s memo
        self._since: dict[str, float] = {}  # entity -> time since which it stands still
        self.home: dict[str, tuple[str, int]] = {n: (p.pose.road, p.pose.lane) for n, p in road.placed.items()} if road else {}
        """Entity -> the OpenDRIVE road and lane its lane offsets refer to: the lane its position named, then the
        lane of its last lane change or teleport (its reference point may be in another lane: an offset)."""
        self.commanded: dict[str, float] = {}  # entity -> the speed last commanded (storyboard-exact: what it drives)
        self.lateral: dict[str, float] = {}  # entity -> road t its reference point moves to in SUMO's next step
        self._road_keys: list[tuple[str, dict[str, str], bool]] = []
        self._pair_keys: list[tuple[str, str, dict[str, str]]] = []
        self.scenario = scenario
        self.options = dict(options)
        self.tick_length = float(tick)
        self.tracked = tuple(tracked)
        self._tracked = frozenset(self.tracked)
        self.spawns = spawns
        self.steps = 0
        self.time = 0.0  # SUMO's time of the last step (s)
        self.collisions = 0
        self.collided: set[str] = set()
        self.teleported: frozenset[str] = frozenset()  # vehicles SUMO moved (not drove) in the last step: scene only
        self.seen: set[str] = set()
        self.sizes: dict[str, tuple[float, float]] = {}  # every departed vehicle: (length, width), for the scene
        self.min_gap: dict[str, float] = {}
        self.results: dict[str, dict[int, Any]] = {}
        self.vehicle_count = 0
        self.taken: dict[str, tuple[int, int]] = {}  # vehicle -> (speed mode, lane change mode) before take-over
        self._contacts: frozenset[tuple[str, str]] = frozenset()
        self._lib: Any = None
        self._started = False
        self._kept: _Kept | None = None  # the snapshot this run started from, when its simulation may be kept
        self._sound = True  # no step failed or was interrupted, no traffic light was switched: it may be kept
        self._keys: list[tuple[Any, ...]] = []  # per tracked vehicle, its keys and what they are read from (_plan)
        self._subscribe: dict[str, tuple[tuple[int, ...], bool]] = {}  # tracked vehicle -> (variables, its leader too)
        self._scene = True  # every vehicle's place and heading are read, for the replay page's scene
        self._sim_collisions = self._sim_vehicles = True  # sim.collisions and sim.vehicles are published
        self._sim_time = road is not None  # sim.time (cases on an OpenDRIVE road)
        self.timer: Callable[[], float] | None = None
        """A clock (e.g. :func:`time.process_time`) to fill :attr:`timing` with; ``None``: no timing."""
        self.timing = dict.fromkeys(("start", "sumo", "adapter", "close"), 0.0)
        """Seconds spent loading SUMO, in SUMO's steps, in this adapter (reading, publishing, commands), closing."""

    # -- life cycle --------------------------------------------------------------
    def arguments(self) -> list[str]:
        """The command line libsumo starts with: the configuration, the tick, no outputs, quiet."""
        args = ["sumo", "-c", self.scenario.config, "--step-length", repr(self.tick_length), "--begin", "0",
                "--no-step-log", "true", "--no-warnings", "true", "--duration-log.disable", "true",
                "--xml-validation", "never", "--xml-validation.net", "never", "--xml-validation.routes", "never"]  # fmt: skip
        own = self.scenario.options
        for name, value in self.options.items():
            args += ["--" + name, value]
        for name, value in DEFAULTS.items():
            if name not in self.options and name not in own:
                args += ["--" + name, value]
        return args

    def start(self, env: "Environment") -> None:
        global _active
        lib = libsumo_module()
        with _claim:  # check and take at once: two threads must never both start libsumo
            if _active is not None:
                raise SystemFailure("libsumo runs one simulation per process and another run is using it; "
                                    "run the cases one after the other (batch mode gives each worker process its own)")  # fmt: skip
            _active = self
            kept = _take_kept()
            reuse = _scopes > 0 and self.scenario.restore_problem is None
        args = self.arguments()
        key = (tuple(args), self.scenario.digest)
        t0 = self.timer() if self.timer else 0.0
        try:
            if kept is not None and (not reuse or kept.key != key or not kept.restore()):
                kept.close()
                kept = None
            if kept is None:
                if reuse and key not in _unrestorable:
                    kept = _Kept.start(lib, args, key)
                else:
                    lib.start(args)
        except Exception as exc:  # noqa: BLE001 - libsumo.TraCIException, FatalTraCIError
            _close(lib)
            if kept is not None:
                kept.forget()
            _release(self)
            raise SystemFailure(f"SUMO could not load {self.scenario.config}: {_why(exc, args)}") from None
        except BaseException:
            _close(lib)
            if kept is not None:
                kept.forget()
            _release(self)
            raise
        self._kept = kept
        self._lib, self._started = lib, True
        self._namespace = env.namespace + "/signals/"
        self._plan(env.wanted)
        if self.timer:
            self.timing["start"] += self.timer() - t0
        self._step()

    def now(self) -> float:
        """SUMO's time of the step whose state the signals show (s; 0.0 before the first step)."""
        return self.time

    def tick(self) -> None:
        if self.lateral:
            self._move_sideways()
        self._step()

    def close(self) -> None:
        global _kept
        if self._started:
            self._started = False
            t0 = self.timer() if self.timer else 0.0
            kept, self._kept = self._kept, None
            parked = False
            try:
                if kept is not None and self._sound and kept.check():
                    with _claim:
                        if _scopes > 0 and _kept is None:
                            _close_at_exit()
                            _kept, parked = kept, True
                if not parked:
                    if kept is not None:
                        kept.close()
                    else:
                        _close(self._lib)
            except BaseException:
                if not parked:
                    _close(self._lib)
                    if kept is not None:
                        kept.forget()
                raise
            finally:
                _release(self)  # only once libsumo is closed (or kept) may another run start it
            if self.timer:
                self.timing["close"] += self.timer() - t0

    # -- stepping and reading ----------------------------------------------------
    def _step(self) -> None:
        lib = self._lib
        if not self._started:
            raise SystemFailure("the SUMO simulation is not running")
        timer = self.timer
        if timer:
            t0 = timer()
            self._simulation_step(lib)
            t1 = timer()
            self._read(lib)
            self.timing["sumo"] += t1 - t0
            self.timing["adapter"] += timer() - t1
        else:
            self._simulation_step(lib)
            self._read(lib)
        self.steps += 1

    def _simulation_step(self, lib: Any) -> None:
        self._sound, sound = False, self._sound  # until the step is done: an interrupted step leaves SUMO unknown
        try:
            time = lib.simulation.getTime()  # the time of the step SUMO executes now, and the label of its state
            lib.simulationStep()
        except Exception as exc:  # noqa: BLE001
            raise SystemFailure(f"SUMO stopped at {self.now():g} s: {exc}") from None
        self._sound = sound
        self.time = time

    def _read(self, lib: Any) -> None:
        vehicle, simulation = lib.vehicle, lib.simulation
        for vid in simulation.getDepartedIDList():
            if vid in self._tracked:
                variables, leader = self._subscribe[vid]
                vehicle.subscribe(vid, variables)
                if leader:
                    vehicle.subscribeLeader(vid, LOOKAHEAD)
                self.min_gap[vid] = vehicle.getMinGap(vid)
                self.seen.add(vid)
            elif self._scene:
                vehicle.subscribe(vid, _PLACE)
            if vid in self.exact:  # storyboard-exact: it keeps its speed and lane until an action changes them
                vehicle.setSpeedMode(vid, 0)
                vehicle.setLaneChangeMode(vid, 0)
                self.commanded[vid] = vehicle.getSpeed(vid)
                vehicle.setSpeed(vid, self.commanded[vid])
            self.sizes[vid] = (vehicle.getLength(vid), vehicle.getWidth(vid))
        self.results = vehicle.getAllSubscriptionResults() if self.sizes else {}
        self.vehicle_count = vehicle.getIDCount()
        if self._scene:
            self.teleported = frozenset(simulation.getStartingTeleportIDList() + simulation.getEndingTeleportIDList())
        collisions = simulation.getCollisions()
        if collisions or self._contacts:
            contacts = frozenset((c.collider, c.victim) for c in collisions)
            self.collisions += len(contacts - self._contacts)
            self._contacts = contacts
            for pair in contacts:
                self.collided.update(pair)

    def publish(self, env: "Environment") -> None:
        timer = self.timer
        if timer:
            t0 = timer()
            self._publish()
            self.timing["adapter"] += timer() - t0
        else:
            self._publish()

    def _publish(self) -> None:
        if not self._started:
            raise SystemFailure("the SUMO simulation is not running")
        storage, prefix, results = Blackboard.storage, self._namespace, self.results
        collided = self.collided
        for vid, collided_key, present_key, lane_key, direct, x_key, y_key, gap_key, ttc_key, gone in self._keys:
            r = results.get(vid)  # (a key is None where the run wants no such signal: _plan)
            if collided_key is not None:
                storage[collided_key] = vid in collided
            if r is None:
                if present_key is not None:
                    storage[present_key] = False
                if lane_key is not None:
                    storage[lane_key] = -1
                for key in gone:
                    storage.pop(key, None)
                continue
            if present_key is not None:
                storage[present_key] = True
            for key, variable in direct:  # lane, speed, accel, lateral, distance: SUMO's values as they are
                storage[key] = r[variable]
            if x_key is not None or y_key is not None:
                x, y = r[_POSITION]
                if x_key is not None:
                    storage[x_key] = x
                if y_key is not None:
                    storage[y_key] = y
            if gap_key is not None or ttc_key is not None:
                speed = r[_SPEED]
                leader, distance = r[_LEADER] or ("", -1.0)
                gap = distance + self.min_gap[vid] if leader else _INF
                if gap <= LOOKAHEAD:  # SUMO reports a leader on the same lane however far ahead: none beyond LOOKAHEAD
                    ahead = results.get(leader)
                    closing = speed - (ahead[_SPEED] if ahead is not None and _SPEED in ahead
                                       else self._lib.vehicle.getSpeed(leader))  # fmt: skip
                    ttc = 0.0 if gap <= 0 else gap / closing if closing > 0 else _INF
                else:
                    gap = ttc = _INF
                if gap_key is not None:
                    storage[gap_key] = gap
                if ttc_key is not None:
                    storage[ttc_key] = ttc
        if self._road_keys or self._pair_keys:
            self._publish_road(storage)
        if self._sim_time:
            storage[prefix + "sim.time"] = self.time
        if self._sim_collisions:
            storage[prefix + "sim.collisions"] = self.collisions
        if self._sim_vehicles:
            storage[prefix + "sim.vehicles"] = self.vehicle_count
        if not self.spawns and self.vehicle_count == 0 and self._lib.simulation.getMinExpectedNumber() == 0:
            raise SystemFailure(f"the SUMO simulation has no vehicles left at {self.now():g} s (every vehicle has "
                                "arrived) while the test is still running")  # fmt: skip

    def _plan(self, wanted: frozenset[str] | None) -> None:
        """What each step reads and publishes: every signal (*wanted* None), or only the *wanted* ones (a run that
        records no trace: :attr:`Environment.wanted <btgen_pytrees.contracts.environment.Environment.wanted>`).
        A tracked vehicle is always subscribed to its speed, place and lane (:data:`_CORE`: the action leaves
        ask for the first and the last, and a subscription says whether it is in the network), to its leader
        only for ``gap`` or ``ttc``, to ``accel``, ``lateral`` and ``distance`` only where wanted, to its
        heading only for the scene; the other vehicles only for the scene. Fewer variables make SUMO's step
        and the reading of its results cheaper (about 0.3 ms of a 5.7 ms ``cut_in_3d`` run in a search)."""
        prefix = self._namespace

        def key(name: str) -> str | None:
            return prefix + name if wanted is None or name in wanted else None

        self._scene = wanted is None
        self._keys, self._subscribe = [], {}
        for vid in self.tracked:
            keys = {a: key(f"{vid}.{a}") for a in ATTRIBUTES}
            direct = tuple((keys[a], v) for a, v in _DIRECT if keys[a] is not None)
            gone = tuple(keys[a] for a in _MOTION if keys[a] is not None)  # no value while not in the network
            self._keys.append((vid, keys["collided"], keys["present"], keys["lane"], direct, keys["x"], keys["y"],
                               keys["gap"], keys["ttc"], gone))  # fmt: skip
            if wanted is None:
                self._subscribe[vid] = (_VARIABLES, True)
            else:
                variables = _CORE + tuple(v for a, v in _OWN.items() if keys[a] is not None)
                self._subscribe[vid] = (variables, keys["gap"] is not None or keys["ttc"] is not None)
        self._sim_collisions = wanted is None or "sim.collisions" in wanted
        self._sim_vehicles = wanted is None or "sim.vehicles" in wanted
        self._sim_time = self.road is not None and (wanted is None or "sim.time" in wanted)
        self._road_keys, self._pair_keys = [], []
        if self.road is not None:
            named = [v for v in self.tracked if v in self.road.entities]
            for vid in named:  # (vid, its keys, whether any needs its OpenDRIVE pose)
                keys = {a: k for a in ROAD_ATTRIBUTES if (k := key(f"{vid}.{a}")) is not None}
                if keys:
                    self._road_keys.append((vid, keys, any(a not in _SUMO_ROAD for a in keys)))
            for a in named:
                for b in named:
                    keys = {x: k for x in PAIR_ATTRIBUTES if a != b and (k := key(f"{a}.{b}.{x}")) is not None}
                    if keys:
                        self._pair_keys.append((a, b, keys))
            for vid in named:  # (the action leaves ask where entities are in OpenDRIVE terms, too)
                variables, leader = self._subscribe[vid]
                self._subscribe[vid] = (tuple(dict.fromkeys(variables + _ROAD)), leader)

    # -- an OpenDRIVE road's signals (docs/opendrive.md) --------------------------------
    def pose(self, vid: str) -> Pose | None:
        """Where entity *vid*'s reference point is now, in OpenDRIVE terms (None when it is not on the road).

        Worked out once per step (the signals and the action leaves ask alike; SUMO's state is that of the step)."""
        memo = self._posed.get(vid)
        if memo is not None and memo[0] == self.steps:
            return memo[1]
        pose = self._locate(vid)
        self._posed[vid] = (self.steps, pose)
        return pose

    def _locate(self, vid: str) -> Pose | None:
        r = self.results.get(vid)
        if r is None or self.road is None or _LANE_ID not in r:
            return None
        entity = self.road.entities[vid]
        h = math.radians(90.0 - r[_ANGLE])  # SUMO's heading of the vehicle: its front and back bumper's line
        cy = entity.center[1]
        fx, fy = r[_POSITION]  # the front bumper's middle; the reference point is `front` behind it on that line
        x = fx - entity.front * math.cos(h) + cy * math.sin(h)
        y = fy - entity.front * math.sin(h) - cy * math.cos(h)
        last = self.poses.get(vid)
        found = self.road.network.locate(x, y, (last.road, last.s) if last is not None else None)
        if found is None:
            self.poses.pop(vid, None)
            return None
        h = math.atan2(math.sin(h), math.cos(h))
        pose = Pose(x, y, h, found.road, found.lane, found.s, found.t, found.offset)
        self.poses[vid] = pose
        return pose

    def _publish_road(self, storage: Any) -> None:
        assert self.road is not None
        results, now = self.results, self.time
        poses: dict[str, Pose | None] = {}
        for vid, keys, posed in self._road_keys:
            r = results.get(vid)
            if r is None or _LANE_ID not in r:
                for k in keys.values():
                    storage.pop(k, None)
                self._since.pop(vid, None)
                continue
            speed = r[_SPEED]
            if abs(speed) >= HALTING:
                self._since.pop(vid, None)
            since = self._since.setdefault(vid, now)
            lane = self.road.net.lanes.get(r[_LANE_ID])
            route = self.road.routes.get(vid, ())
            end = (lane is not None and bool(route) and lane.edge == route[-1]
                   and lane.length - r[_LANE_POSITION] <= speed * self.tick_length + ARRIVAL_EPS)  # fmt: skip
            if not posed:  # only what SUMO's own state says (still, end_of_road): no OpenDRIVE pose needed
                for a, k in keys.items():
                    storage[k] = now - since if a == "still" else end
                continue
            pose = poses[vid] = self.pose(vid)
            if pose is None:  # in the network, on no lane of the road: no road coordinates
                for a, k in keys.items():
                    if a in _SUMO_ROAD:
                        storage[k] = now - since if a == "still" else end
                    else:
                        storage.pop(k, None)
                continue
            values = {"ref_x": pose.x, "ref_y": pose.y, "heading": pose.h, "road": _road_number(pose.road, self.road),
                      "lane_id": pose.lane, "s": pose.s, "t": pose.t, "offset": pose.offset, "still": now - since,
                      "end_of_road": end}  # fmt: skip
            for a, k in keys.items():
                storage[k] = values[a]
        for a, b, keys in self._pair_keys:
            pa = poses[a] if a in poses else poses.setdefault(a, self.pose(a))
            pb = poses[b] if b in poses else poses.setdefault(b, self.pose(b))
            ra, rb = results.get(a), results.get(b)
            if pa is None or pb is None or ra is None or rb is None:
                for k in keys.values():
                    storage.pop(k, None)
                continue
            values = _pair(self.road, a, b, pa, pb, ra[_SPEED], rb[_SPEED])
            for x, k in keys.items():
                storage[k] = values[x]

    # -- the scene (the replay page's bird's-eye view; docs/systems.md) ---------
    def scene_map(self) -> dict[str, Any]:
        """The road network: every lane as a polyline with its width, every junction's outline, and the ego's id."""
        lanes = [[width, list(points)] for kind, width, points in self.scenario.shapes if kind == "lane"]
        junctions = [list(points) for kind, _, points in self.scenario.shapes if kind == "junction"]
        return {"lanes": lanes, "areas": junctions, "ego": "ego" if "ego" in self._tracked else ""}

    def scene_vehicles(self) -> Iterable[tuple[str, float, float, float, float, float, bool, bool]]:
        """Every vehicle in the network now: ``(id, x, y, heading, length, width, collided, teleported)``.

        ``x, y``: the front bumper's middle, metres; ``heading``: degrees clockwise from north
        (SUMO's angle); ``collided``: has been in a collision; ``teleported``: SUMO teleported it in
        this step (a jam's ``time-to-teleport``, or ``collision.action teleport``): it got here without
        driving. Sorted by id.
        """
        results, sizes, collided, teleported = self.results, self.sizes, self.collided, self.teleported
        for vid in sorted(results):
            r = results[vid]
            if _POSITION in r and _ANGLE in r:
                x, y = r[_POSITION]
                length, width = sizes.get(vid, (5.0, 1.8))
                yield vid, x, y, r[_ANGLE], length, width, vid in collided, vid in teleported

    # -- commands of the action leaves -------------------------------------------
    def present(self, vid: str) -> bool:
        """Whether *vid* is in the network now."""
        if vid in self._tracked:
            return vid in self.results
        return vid in self._call(self._lib.vehicle.getIDList)

    def absent_reason(self, vid: str) -> str:
        if vid in self.seen or vid in self._call(self._lib.simulation.getArrivedIDList):
            return f"vehicle {vid!r} has left the network"
        depart = self.scenario.vehicles.get(vid)
        return f"vehicle {vid!r} is not in the network" + (f" (it departs at {depart!r})" if depart else "")

    def speed(self, vid: str) -> float:
        r = self.results.get(vid)
        return float(r[_SPEED]) if r is not None and _SPEED in r else float(self._call(self._lib.vehicle.getSpeed, vid))

    def lane(self, vid: str) -> int:
        r = self.results.get(vid)
        return int(r[_LANE_INDEX]) if r is not None and _LANE_INDEX in r else int(self._call(self._lib.vehicle.getLaneIndex, vid))

    def take_over(self, vid: str) -> None:
        """Remember *vid*'s modes before a leaf changes them, so that :meth:`release` restores them."""
        if vid not in self.taken:
            v = self._lib.vehicle
            self.taken[vid] = (self._call(v.getSpeedMode, vid), self._call(v.getLaneChangeMode, vid))

    def set_speed(self, vid: str, speed: float, safe: bool) -> None:
        self.take_over(vid)
        v = self._lib.vehicle
        if not safe:
            self._call(v.setSpeedMode, vid, 0)  # no safe speed, no accel/decel bounds, no right of way
        else:
            self._call(v.setSpeedMode, vid, self.taken[vid][0])
        self._call(v.setSpeed, vid, max(float(speed), 0.0))
        self.commanded[vid] = max(float(speed), 0.0)

    # -- motion in OpenDRIVE terms (the actions of docs/opendrive.md) ------------------------------
    def move_sideways(self, vid: str, t: float) -> None:
        """Have entity *vid*'s reference point at road coordinate *t* after SUMO's next step (its ``s`` moves on
        with its speed): the lateral motion of a lane change or a lane offset, one step at a time."""
        self.lateral[vid] = float(t)

    def _next_speed(self, vid: str) -> float:
        """The speed *vid* drives SUMO's next step with: the one commanded when SUMO does not choose it (speed
        mode 0), else the present one moved on by its acceleration."""
        r = self.results.get(vid) or {}
        v = self._lib.vehicle
        if vid in self.commanded and self._call(v.getSpeedMode, vid) == 0:
            return self.commanded[vid]
        speed = float(r[_SPEED]) if _SPEED in r else float(self._call(v.getSpeed, vid))
        return max(0.0, speed + float(self._call(v.getAcceleration, vid)) * self.tick_length)

    def _move_sideways(self) -> None:
        plans, self.lateral = self.lateral, {}
        assert self.road is not None
        for vid, t_next in plans.items():
            pose = self.pose(vid)
            if pose is None:
                continue
            road = self.road.network.roads[pose.road]
            sign = 1.0 if abs(math.remainder(pose.h - road.reference(pose.s)[2], 2 * math.pi)) < math.pi / 2 else -1.0
            step = self._next_speed(vid) * self.tick_length
            scale = 1.0 - _curvature_at(road, pose.s) * pose.t
            s_next = min(max(pose.s + sign * step / (scale if scale > 0.05 else 1.0), 0.0), road.length)
            x, y, h = road.point(s_next, t_next)
            heading = (h if sign > 0 else h + math.pi) + math.atan2(sign * (t_next - pose.t), step) if step > 0 else pose.h
            self.place(vid, x, y, heading)

    def place(self, vid: str, x: float, y: float, heading: float) -> None:
        """Put entity *vid*'s reference point at world point ``(x, y)`` heading *heading* (rad) for SUMO's next
        step: SUMO's ``moveToXY`` with its front bumper's place, on the lane there (its route kept where the
        lane is on it)."""
        assert self.road is not None
        e = self.road.entities[vid]
        c, s = math.cos(heading), math.sin(heading)
        fx, fy = x + e.front * c - e.center[1] * s, y + e.front * s + e.center[1] * c
        self._call(self._lib.vehicle.moveToXY, vid, "", -1, fx, fy, 90.0 - math.degrees(heading), 2)

    def change_lane(self, vid: str, lane: int, seconds: float, safe: bool) -> None:
        """Ask SUMO to move *vid* to *lane* and keep it there in its steps of the next *seconds* (none for 0).

        SUMO's request (``vehicle.changeLane``) holds from the step SUMO executes
        next, at ``now + tick``, to ``now + tick + duration`` inclusive; the
        duration given is therefore ``seconds - tick``: the steps up to run time
        ``now + seconds`` are held and the driver model decides again from the
        step after. ``seconds = 0`` replaces an earlier request by one that has
        ended before SUMO's next step: the driver model decides at once.
        """
        self.take_over(vid)
        v = self._lib.vehicle
        if not safe:
            self._call(v.setLaneChangeMode, vid, 0)  # no own lane changes; the request ignores others' gaps
        self._call(v.changeLane, vid, int(lane), float(seconds) - self.tick_length)

    def control(self, vid: str, longitudinal: bool, lateral: bool) -> None:
        """Hand entity *vid* to SUMO's driver model (OpenSCENARIO's ActivateControllerAction): SUMO's default
        speed mode (31) and its own speed where *longitudinal* - its desired speed the speed it has now (its
        speed factor set so: SUMO's drivers would otherwise speed up to the lane's limit) -, its default
        lane-change mode (1621) where *lateral*; the other domain stays storyboard-exact."""
        v = self._lib.vehicle
        self.taken.pop(vid, None)
        if longitudinal:
            speed, allowed = self.speed(vid), float(self._call(v.getAllowedSpeed, vid))
            if speed >= HALTING and allowed > 0:  # it wants to drive on at the speed it has, not at the lane's limit
                self._call(v.setSpeedFactor, vid, speed / allowed)
            self._call(v.setSpeedMode, vid, 31)
            self._call(v.setSpeed, vid, -1.0)
        if lateral:
            self._call(v.setLaneChangeMode, vid, 1621)

    def uncontrol(self, vid: str) -> None:
        """Take entity *vid* back from SUMO's driver model: storyboard-exact again, at the speed it has now."""
        v = self._lib.vehicle
        self.taken.pop(vid, None)
        self._call(v.setSpeedMode, vid, 0)
        self._call(v.setLaneChangeMode, vid, 0)
        self._call(v.setSpeed, vid, self.speed(vid))

    def release(self, vid: str) -> None:
        """Give *vid* back to SUMO's driver model: its own speed, its modes, and no lane request any more."""
        v = self._lib.vehicle
        speed_mode, lane_mode = self.taken.pop(vid, (None, None))
        self._call(v.setSpeed, vid, -1.0)
        if speed_mode is not None:
            self._call(v.setSpeedMode, vid, speed_mode)
            self._call(v.setLaneChangeMode, vid, lane_mode)
        self._call(v.changeLane, vid, self.lane(vid), -self.tick_length)  # a request that ended: the hold is over

    def spawn(self, vid: str, route: str, type_id: str | None, lane: int | None, position: float | None,
              speed: float | None) -> None:  # fmt: skip
        self._call(self._lib.vehicle.add, vid, route, typeID=type_id or "DEFAULT_VEHTYPE", depart="now",
                   departLane="first" if lane is None else str(lane),
                   departPos="base" if position is None else repr(float(position)),
                   departSpeed="0" if speed is None else repr(float(speed)))  # fmt: skip

    def set_signal(self, tls: str, state: str) -> None:
        self._sound = False  # SUMO keeps the program it makes for the state: a kept simulation would differ
        self._call(self._lib.trafficlight.setRedYellowGreenState, tls, state)

    def _call(self, function: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        if not self._started:
            raise CommandError("the SUMO simulation is not running")
        t0 = self.timer() if self.timer else 0.0
        try:
            return function(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001 - libsumo.TraCIException
            raise CommandError(str(exc) or type(exc).__name__) from None
        finally:
            if self.timer:
                self.timing["adapter"] += self.timer() - t0


def _curvature_at(road: Any, s: float) -> float:
    """The reference line's curvature at *s* (1/m, left +), from its heading half a metre either side."""
    a, b = max(0.0, s - 0.5), min(road.length, s + 0.5)
    return math.remainder(road.reference(b)[2] - road.reference(a)[2], 2 * math.pi) / (b - a) if b > a else 0.0


def _road_number(road: str, case: RoadCase) -> float:
    """A road id as a signal's value: the number it is, else its place in the file (docs/opendrive.md)."""
    try:
        return float(road) if road.strip().lstrip("-").replace(".", "", 1).isdigit() else float(list(case.network.roads).index(road))
    except ValueError:
        return -1.0


def _extent(length: float, center: float) -> tuple[float, float]:
    """The box's reach behind (negative) and ahead of its reference point along its axis."""
    return center - length / 2, center + length / 2


def _gap(low_a: float, high_a: float, low_b: float, high_b: float) -> float:
    """Signed free distance of interval b from interval a: + ahead, - behind, 0 overlapping."""
    if low_b > high_a:
        return low_b - high_a
    if high_b < low_a:
        return high_b - low_a
    return 0.0


def _pair(case: RoadCase, a: str, b: str, pa: Pose, pb: Pose, va: float, vb: float) -> dict[str, float]:
    """The signals of the pair (A, B): B seen from A (docs/opendrive.md "Two entities")."""
    ea, eb = case.entities[a], case.entities[b]
    dxw, dyw = pb.x - pa.x, pb.y - pa.y
    c, s = math.cos(pa.h), math.sin(pa.h)
    dx, dy = dxw * c + dyw * s, -dxw * s + dyw * c
    rel = pb.h - pa.h
    cr, sr = abs(math.cos(rel)), abs(math.sin(rel))
    half_len_b = (eb.length * cr + eb.width * sr) / 2  # B's box seen along A's axes
    half_wid_b = (eb.length * sr + eb.width * cr) / 2
    bx = dx + eb.center[0] * math.cos(rel) - eb.center[1] * math.sin(rel)
    by = dy + eb.center[0] * math.sin(rel) + eb.center[1] * math.cos(rel)
    low_a, high_a = _extent(ea.length, ea.center[0])
    dx_free = _gap(low_a, high_a, bx - half_len_b, bx + half_len_b)
    dy_free = _gap(ea.center[1] - ea.width / 2, ea.center[1] + ea.width / 2, by - half_wid_b, by + half_wid_b)
    road_a = case.network.roads.get(pa.road)
    sign = 1.0 if road_a is None or road_a.forward(pa.lane) else -1.0
    if pa.road == pb.road:
        ds, dt = sign * (pb.s - pa.s), sign * (pb.t - pa.t)
        dlane = float(_lanes_between(pa.lane, pb.lane)) * sign
    else:
        ds, dt, dlane = dx, dy, math.nan
    same_way = math.cos(rel) >= 0
    b_low, b_high = (-eb.rear, eb.front) if same_way else (-eb.front, eb.rear)
    ds_free = _gap(-ea.rear, ea.front, ds + b_low, ds + b_high)
    dt_free = _gap(-ea.width / 2, ea.width / 2, dt - eb.width / 2, dt + eb.width / 2)
    closing = va - vb if same_way else va + vb  # along the road, as the speeds are
    return {
        "distance": math.hypot(dxw, dyw), "distance_free": math.hypot(dx_free, dy_free), "dx": dx, "dy": dy,
        "dx_free": dx_free, "dy_free": dy_free, "ds": ds, "dt": dt, "ds_free": ds_free, "dt_free": dt_free,
        "dlane": dlane,
        "headway": ds / va if ds > 0 and va > 0 else _INF, "headway_free": ds_free / va if ds_free > 0 and va > 0 else _INF,
        "ttc": ds / closing if ds > 0 and closing > 0 else _INF,
        "ttc_free": 0.0 if ds_free == 0 and dt_free == 0 else ds_free / closing if ds_free > 0 and closing > 0 else _INF,
    }  # fmt: skip


def _lanes_between(a: int, b: int) -> int:
    """How many lanes b is from a (positive towards higher ids), the centre lane 0 not counted."""
    if (a < 0) == (b < 0):
        return b - a
    return b - a - 1 if b > a else b - a + 1


def _close(lib: Any) -> None:
    try:
        lib.close()
    except Exception:  # noqa: BLE001 - nothing was loaded
        pass


def _why(exc: BaseException, args: list[str]) -> str:
    """SUMO's own error lines for a failed load.

    libsumo's exception often says only "Process Error" or names the element,
    while SUMO prints the reason on stderr; the ``sumo`` binary of the
    eclipse-sumo wheel, run on the same (already checked) arguments up to time 0,
    tells it again on a pipe we can read.
    """
    message = " ".join(str(exc).split())
    try:
        import sumo

        binary = os.path.join(sumo.SUMO_HOME, "bin", "sumo")
        done = subprocess.run([binary, *args[1:], "--end", "0"], capture_output=True, text=True, timeout=60,
                              stdin=subprocess.DEVNULL, check=False)  # fmt: skip
        lines = [ln.strip() for ln in done.stderr.splitlines() if ln.strip() and not ln.startswith("Quitting")]
        if lines:
            return " ".join(lines)[:1000].removeprefix("Error: ")
    except Exception:  # noqa: BLE001 - best effort: the eclipse-sumo wheel may be missing
        pass
    return message or type(exc).__name__


# -- a simulation kept between runs (reuse_simulations) ----------------------------------------------

_EDGE_CONTROL = re.compile(r"\s*<edgeControl\b[^>]*/>")
_ATTRIBUTE = re.compile(r'([^\s=]+)="([^"]*)"')
_LANE_RNG = re.compile(r'<rngLane index="(\d+)" state="([^"]*)"/>')
_FULL = "1000000"
"""SUMO's ``SAVE_ONLY_COUNT``: a generator drawn this often is saved as count and full state, not as count alone."""


def _rng_span(text: str) -> tuple[int, int, int]:
    """Where the ``<rngState>`` element of a saved state begins, where its start tag ends, where it closes."""
    begin = text.find("<rngState")
    close = text.find("</rngState>", begin)
    if begin < 0 or close < 0:
        raise RuntimeError("SUMO saved no random number generators")
    return begin, text.index(">", begin), close


def _rng_values(text: str, span: tuple[int, int, int]) -> dict[str, str]:
    """Each generator's saved value in the ``<rngState>`` element at *span* (see :func:`_rng_span`):
    ``default``, ``routeHandler``, ... and ``lane <i>``."""
    begin, head_end, close = span
    values = dict(_ATTRIBUTE.findall(text, begin + 9, head_end))
    values.update((f"lane {i}", value) for i, value in _LANE_RNG.findall(text, head_end, close))
    return values


def _rngs(text: str) -> tuple[str, dict[str, str], str]:
    """Split a state saved with ``--save-state.rng``: the text before the generators, each generator's saved
    value (``default``, ``routeHandler``, ... and ``lane <i>``), the text after (without ``<edgeControl>``)."""
    span = _rng_span(text)
    values = _rng_values(text, span)
    begin, close = len(text[: span[0]].rstrip()), span[2]
    return text[:begin], values, _EDGE_CONTROL.sub("", text[close + 11:], count=1)


def _rng_element(values: Mapping[str, str]) -> str:
    """The ``<rngState>`` element that loads *values* (generators not named are left as they are)."""
    if not values:
        return ""
    head = "".join(f' {name}="{value}"' for name, value in values.items() if not name.startswith("lane "))
    lanes = "".join(f'<rngLane index="{name[5:]}" state="{value}"/>' for name, value in values.items() if name.startswith("lane "))
    return f"\n    <rngState{head}>{lanes}</rngState>"


class _File:
    """A file SUMO writes and reads by name: an anonymous memory file on Linux (``/proc/self/fd/N``,
    gone with the process whatever happens to it), else a private temporary file."""

    def __init__(self) -> None:
        self._dir: str | None = None
        if hasattr(os, "memfd_create") and os.path.isdir("/proc/self/fd"):
            self.fd = os.memfd_create("btgen-sumo-state", getattr(os, "MFD_CLOEXEC", 0))
            self.path = f"/proc/self/fd/{self.fd}"
        else:  # pragma: no cover - not Linux
            self._dir = tempfile.mkdtemp(prefix="btgen-sumo-")
            self.path = os.path.join(self._dir, "state.xml")
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)

    def read(self) -> str:
        size = os.fstat(self.fd).st_size
        return os.pread(self.fd, size, 0).decode("utf-8") if self._dir is None else open(self.path, encoding="utf-8").read()

    def write(self, text: str) -> None:
        data = text.encode("utf-8")
        os.ftruncate(self.fd, 0)
        os.pwrite(self.fd, data, 0)

    def close(self) -> None:
        """Close it (again: nothing; a descriptor closed twice could be another file's by then)."""
        if self.fd < 0:
            return
        fd, self.fd = self.fd, -1
        with contextlib.suppress(OSError):
            os.close(fd)
        if self._dir is not None:  # pragma: no cover - not Linux
            with contextlib.suppress(OSError):
                os.unlink(self.path)
                os.rmdir(self._dir)


class _Kept:
    """A running simulation with its snapshot at time 0, to be set back exactly for the next run.

    ``simulation.loadState`` restores the vehicles, routes, time and traffic lights, but not SUMO's random
    number generators: loaded without them the next run would go on drawing where the last one stopped;
    loaded with them (``--save-state.rng``) SUMO skips the saved *count* of draws from where each generator
    is now, not from its seed. So the snapshot carries the full state of the generators this key's runs
    draw from (SUMO saves a generator's full state once its counter is at :data:`_FULL`; loading a bare
    count of :data:`_FULL` sets the counter without touching the generator, and the next save writes the
    state out), and after every run the generators that drew are set back to it: a run starts from exactly
    the state, generators included, that a fresh start gives. Which generators a key's runs draw from is
    learnt (:data:`_drawing`): a run that drew from one the snapshot does not hold is exact (it started as
    a fresh start), but its simulation is closed, and the next start of its key holds that one too.
    Writing out all 71 full states (about 3 ms) would make the first run of every block that much dearer.
    """

    def __init__(self, lib: Any, key: tuple[Any, ...]):
        self.lib, self.key = lib, key
        self.snapshot, self.probe = _File(), _File()
        self.before = self.after = ""
        self.start_state: dict[str, str] = {}  # the full state at time 0 of each generator it can set back
        self.now: dict[str, str] = {}  # what SUMO saves for each generator now (at the start of the run)
        self.drew: set[str] = set()  # generators the last run drew from: set back by restore()
        self.loaded: str | None = None  # the text the snapshot file holds (only _load writes it; SUMO reads it)

    @classmethod
    def start(cls, lib: Any, args: list[str], key: tuple[Any, ...]) -> "_Kept":
        """Start SUMO and take the snapshot (the simulation is at time 0, as after ``libsumo.start``)."""
        lib.start([*args, "--save-state.rng", "true"])
        kept = cls(lib, key)
        try:
            before, values, after = kept._save()
            held = _drawing.get(key, frozenset()) & set(values)
            if held:  # their full states: a bare count of a million for each, loaded, then saved
                kept._load(before + _rng_element({n: values[n] if " " in values[n] else _FULL for n in held}) + after)
                before, values, after = kept._save()
                if any(" " not in values[n] for n in held):
                    raise RuntimeError("SUMO did not save the generators' full states")
            kept.before, kept.after = before, after
            kept.start_state = {n: values[n] for n in held}
            kept.now = values
        except Exception:  # noqa: BLE001 - SUMO refused: this key starts afresh from now on
            kept.close()
            _unrestorable.add(key)
            lib.start(args)
            return None  # type: ignore[return-value]
        except BaseException:
            kept.close()
            raise
        return kept

    def _save(self) -> tuple[str, dict[str, str], str]:
        self.lib.simulation.saveState(self.probe.path)
        return _rngs(self.probe.read())

    def _load(self, text: str) -> None:
        """Load the state *text*; the snapshot file is written only when it does not hold that text already
        (a run that drew from the same generators as the last one is set back with the same text)."""
        if text != self.loaded:
            self.loaded = None
            self.snapshot.write(text)
            self.loaded = text
        self.lib.simulation.loadState(self.snapshot.path)

    def check(self) -> bool:
        """After a run: note the generators it drew from; False if the simulation cannot be kept."""
        try:
            self.lib.simulation.saveState(self.probe.path)
            text = self.probe.read()
            values = _rng_values(text, _rng_span(text))  # the generators only: what _save() splits off is not needed
        except Exception:  # noqa: BLE001
            return False
        if set(values) != set(self.now):
            return False
        self.drew = {name for name, value in values.items() if value != self.now[name]}
        if not self.drew <= set(self.start_state):  # a generator the snapshot cannot set back: learn it
            if len(_drawing) >= 256:
                _drawing.clear()
            _drawing[self.key] = _drawing.get(self.key, frozenset()) | self.drew
            return False
        return True

    def restore(self) -> bool:
        """Set the simulation back to time 0; False if SUMO refused (then close it).

        Each generator set back is loaded twice, in this order: its full state at time 0 (which sets its
        counter to a million or more), then a count of 0, which SUMO loads as "draw 0 more" - the counter is
        0 again and the generator untouched. A generator whose counter is below a million is saved as that
        count alone, so the save after the run (:meth:`check`) writes and reads a count for it instead of
        its full state (about 7,000 characters of numbers each)."""
        back = {name: self.start_state[name] for name in self.now if name in self.drew}
        zero = dict.fromkeys(back, "0")
        try:
            self._load(self.before + _rng_element(back) + _rng_element(zero) + self.after)
        except Exception:  # noqa: BLE001
            return False
        self.now.update(zero)
        self.drew = set()
        return True

    def forget(self) -> None:
        """Drop the snapshot's files (SUMO itself is closed by the caller)."""
        self.snapshot.close()
        self.probe.close()

    def close(self) -> None:
        _close(self.lib)
        self.forget()
