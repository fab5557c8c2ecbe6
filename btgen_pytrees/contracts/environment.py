"""What the nodes of one generated tree share: a blackboard namespace and a clock.

Every key a generated tree reads or writes lives under its own namespace on the
py_trees blackboard (default ``/btgen_pytrees/<test name>``, made unique per
generated tree), so two trees in one process never see each other's signals or
completion flags, and keys of the host application are never touched::

    <ns>/signals/<name>   signal values (written by leaves, published by a system or host)
    <ns>/done/<id>        set when an entry that a trigger waits for has succeeded
    <ns>/failed/<id>      set when a member of an ``||`` oracle group has failed
    <ns>/failed_count/<id> how many members of the ``||`` group whose first member is <id> have failed
    <ns>/execute_done     set when the execute subtree has succeeded
    <ns>/t0               clock time of the run's first tick
    <ns>/stop/<id>        stop requests for an entry (``stops``, ``race``: docs/semantics.md#control-flow)
    <ns>/cut/<id>         set when an entry can no longer succeed (stopped, or its branch was)
    <ns>/stopped          the case's ``stop`` that ended the run, and when

**One tick, one time.** The clock is read once per tick of the tree, when its
root (:class:`~btgen_pytrees.leaves.wiring.TreeRoot`) begins the tick
(:meth:`Environment.begin_tick`): every leaf, oracle and visitor of that tick
sees the same :meth:`Environment.now`, whatever clock it is (a wall clock moves
while a tick runs), and so does whatever reads it after the tick, until the
next one begins.

Values are stored in :attr:`py_trees.blackboard.Blackboard.storage` under those
absolute keys (so py_trees' blackboard views show them).

**Who reads and writes what: py_trees clients.** Every test leaf that touches
the blackboard - a built-in behaviour or constraint, an oracle, the run's start -
has its own :class:`py_trees.blackboard.Client`, attached to the leaf
(``leaf.blackboards``) and named after it, with the keys it reads and writes
declared (:meth:`Environment.attach`): ``set x`` writes ``<ns>/signals/x``, a
criterion ``speed <= 30`` reads ``<ns>/signals/speed``. So py_trees' own tools
show them: ``Blackboard.clients``, ``unicode_blackboard(display_only_key_metadata=True)``
(the readers and writers of each key), ``render_dot_tree(root,
with_blackboard_variables=True)`` (an edge between each leaf and its keys), and,
once the *host* turns it on (``Blackboard.enable_activity_stream()``; the
library never does), ``unicode_blackboard_activity_stream()``: while the stream
is on, every read and write of a leaf goes through its client (``getattr`` /
``setattr`` with the absolute key), so py_trees itself records it, under the
leaf's name. While it is off, the same read or write goes to the storage
directly - what the client does then, minus its access check (the keys are the
declared ones by construction) and about a microsecond per access on the hot path
of every tick. A leaf without blackboard keys (``hold``, ``wait``, the SUMO
actions, which act on the system) gets no client, and neither do the
generator's wiring nodes (see below). A tree's clients are unregistered by
:meth:`Environment.release` (``run()`` does it for the tree it made; a host that
generated a tree may do it when it drops the tree).

Writes that are not a leaf's (a system's :meth:`Environment.publish`, the
completion flags) go to the storage directly too (what :meth:`Blackboard.set
<py_trees.blackboard.Blackboard.set>` does for an absolute key without dots; a
signal name may hold dots, which ``Blackboard.set`` would read as an attribute
path), adding the key's metadata only when the key is new: ``Blackboard.set``
builds a fresh metadata object on every call, even for a key it already has. The
completion flags (``done``, ``failed``, ``execute_done``) of one tree share one
(empty) metadata object: they are the wiring's, not a test leaf's - a client per
:class:`~btgen_pytrees.leaves.wiring.Completion` would cost a 100,000-entry
``fan_in`` 100,000 clients - and four long-lived objects per flag - 400,000 for
a 100,000-entry run - would make CPython's collector traverse the whole heap
during the run. (A ``period``/``final`` criterion that waits for the execute
subtree declares its read of ``execute_done``.)
"""

from __future__ import annotations

import re
from typing import Any, Callable, Iterable, Mapping

import py_trees
from py_trees.blackboard import Blackboard, Client, KeyMetaData
from py_trees.common import Access

from ..clock import Clock, WallClock

__all__ = ["Environment", "unique_namespace"]

_used_namespaces: set[str] = set()
_last_number: dict[str, int] = {}  # base -> the number of the last namespace given for it (1: the base itself)


def unique_namespace(test_name: str) -> str:
    """A namespace derived from *test_name* that no earlier tree in this process used.

    >>> unique_namespace("my test") == "/btgen_pytrees/my_test"
    True
    >>> unique_namespace("my test")
    '/btgen_pytrees/my_test#2'
    """
    base = "/btgen_pytrees/" + (re.sub(r"[^A-Za-z0-9_-]", "_", test_name)[:64] or "_")
    candidate, n = base, _last_number.get(base, 1)  # '#' is never in a base: '<base>#n' is only ever this base's
    if n > 1:
        candidate = f"{base}#{n}"
    while candidate in _used_namespaces:  # from the last number given, not from 1: a process that generates
        n += 1  # many trees of one case (a sweep, a search) would try every number taken before
        candidate = f"{base}#{n}"
    _used_namespaces.add(candidate)
    _last_number[base] = n
    return candidate


def _set(key: str, value: Any, metadata: KeyMetaData | None = None) -> None:
    """``Blackboard.set(key, value)`` for an absolute *key* taken whole (dots too), minus its throwaway metadata.

    A new key gets *metadata* (default: a new :class:`~py_trees.blackboard.KeyMetaData`).
    """
    Blackboard.storage[key] = value
    if key not in Blackboard.metadata:
        Blackboard.metadata[key] = metadata if metadata is not None else KeyMetaData()


class Environment:
    """The namespace, clock, initial signals and system under test of one generated tree.

    Leaves (built-in and user) receive it from their factory; the wiring nodes
    (triggers, completion marks) use it to talk to each other. A system's action
    leaves reach the running :class:`~btgen_pytrees.systems.System` as
    :attr:`system` (set by the runner for a run, or by a host that drives a
    system itself; ``None`` otherwise), at tick time, not when they are built.
    It is typed loosely (``Any``): the system's interface,
    :mod:`btgen_pytrees.contracts.system`, builds on this module, not the
    other way round, and a system's own leaves know the type they act on.
    """

    def __init__(self, namespace: str, clock: Clock | None = None, signals: Mapping[str, Any] | None = None,
                 system: Any = None):  # fmt: skip
        ns = "/" + namespace.strip("/")
        self.namespace = ns
        self.clock: Clock = clock if clock is not None else WallClock()
        self.system = system
        self.initial_signals: dict[str, Any] = dict(signals or {})
        self._written: set[str] = set()  # signals written with write() since the run began
        self._runs = 0
        self._signals = ns + "/signals/"
        self._done = ns + "/done/"
        self._failed = ns + "/failed/"
        self._execute_done = ns + "/execute_done"
        self._t0 = ns + "/t0"
        self._stop = ns + "/stop/"
        self._cut = ns + "/cut/"
        self._stopped = ns + "/stopped"
        self._pending: dict[str, Any] = {}  # states posted during a tick, written when the next begins (post())
        self.ticks = 0
        """Ticks of the tree begun so far (by its root: :meth:`begin_tick`), over every run."""
        self.cutting = False
        """Set by a stopped entry's node as its branch fails (docs/algorithms.md#control-flow); the branch's
        :class:`~btgen_pytrees.leaves.wiring.Cuttable` takes it back and ends the branch as finished."""
        self._cut_listeners: list[Callable[[str], None]] = []
        self._tick_time: float | None = None  # the clock as read when the current (or last) tick began
        self._done_listeners: list[Callable[[str], None]] = []
        self._flags = KeyMetaData()  # shared by the completion flags' keys (see the module docstring)
        self._clients: list[Client] = []
        self._shared: dict[tuple[str, ...], Client | None] = {}  # attach_shared(): keys -> their one client
        self._shared_signals: dict[tuple[str, ...], Client | None] = {}  # attach_signals(): names -> that client
        self._keys: dict[tuple[str, ...], tuple[tuple[str, str], ...]] = {}  # values(): names -> (name, key) pairs
        self.wanted: frozenset[str] | None = None
        """The signals a run needs, by name, where the runner knows them; ``None`` (the default): every one.
        A run that records no trace (a sweep's, a search's) of a tree made only of this package's nodes sets
        the signals the tree's clients declared (:meth:`declared_signals`): no node reads any other, and no
        trace samples them. A system may then publish only these (SUMO does: docs/sumo.md); it must publish
        every signal it owns while this is ``None``."""

    # -- keys and clients ----------------------------------------------
    def signal_key(self, name: str) -> str:
        """The blackboard key of signal *name*: ``<ns>/signals/<name>``."""
        return self._signals + name

    @property
    def execute_done_key(self) -> str:
        return self._execute_done

    @property
    def t0_key(self) -> str:
        return self._t0

    def attach(self, behaviour: py_trees.behaviour.Behaviour, *, reads: Iterable[str] = (),
               writes: Iterable[str] = (), name: str | None = None) -> Client | None:  # fmt: skip
        """Attach a py_trees client named after *behaviour* with the absolute keys it *reads*
        and *writes* declared (``Access.READ``/``Access.WRITE``); ``None`` when it has none.

        Pass the client to :meth:`read`, :meth:`write`, :meth:`values` and
        :meth:`execute_done`: while the host has the activity stream on, the access
        goes through it (and is recorded); otherwise to the storage directly.
        """
        writes = list(dict.fromkeys(writes))
        reads = [k for k in dict.fromkeys(reads) if k not in writes]  # WRITE access reads too
        if not writes and not reads:
            return None
        client = behaviour.attach_blackboard_client(name=name or behaviour.name)
        for key in writes:
            client.register_key(key, Access.WRITE)
        for key in reads:
            client.register_key(key, Access.READ)
        self._clients.append(client)
        return client

    def attach_shared(self, behaviour: py_trees.behaviour.Behaviour, reads: Iterable[str]) -> Client | None:
        """:meth:`attach` for the many wiring nodes that read the same keys (the start conditions of entries: a
        ``when`` written on every tenth entry of a 100,000-entry case): one client per set of keys, named ``when``,
        attached to the first of them, which declares the keys once (what a system publishes, what py_trees'
        views and activity stream show) without a client - four objects more for the collector - per node."""
        keys = tuple(sorted(dict.fromkeys(reads)))
        if not keys:
            return None
        found = self._shared.get(keys)
        if found is None:
            found = self._shared[keys] = self.attach(behaviour, reads=keys, name="when")
        return found

    def attach_signals(self, behaviour: py_trees.behaviour.Behaviour, names: tuple[str, ...]) -> Client | None:
        """:meth:`attach_shared` for the keys of the signals *names*: one dict lookup for every node after the first
        that reads the same names (a start condition on every tenth entry of a 100,000-entry case)."""
        found = self._shared_signals.get(names)
        if found is None and names not in self._shared_signals:
            found = self._shared_signals[names] = self.attach_shared(behaviour, [self._signals + n for n in names])
        return found

    def declared_signals(self) -> frozenset[str]:
        """The names of the signals this tree's clients declared, to read or to write (:meth:`attach`)."""
        prefix, n = self._signals, len(self._signals)
        return frozenset(key[n:] for client in self._clients for key in (*client.read, *client.write) if key.startswith(prefix))

    def release(self) -> None:
        """Unregister this tree's clients (their values stay on the blackboard); the tree's
        leaves keep running without them, unseen by the activity stream."""
        for client in self._clients:
            if client.id() in Blackboard.clients:
                client.unregister(clear=False)
        self._clients = []
        self._shared = {}
        self._shared_signals = {}

    def clear(self) -> None:
        """Take every key under this tree's namespace off the blackboard: values and metadata.

        ``run()`` does it for the tree it made, once its report is made: nobody can reach that tree
        again, and a process that runs many cases (a sweep, a search: thousands of trees) would
        otherwise keep every run's signals and flags - the blackboard's storage growing by a run's
        keys per run, and every later run's start scanning it all (:meth:`start_run`)."""
        prefix = self.namespace + "/"
        for table in (Blackboard.storage, Blackboard.metadata):
            for key in [k for k in table if k.startswith(prefix)]:
                del table[key]

    # -- run lifecycle -------------------------------------------------
    def start_run(self, client: Client | None = None) -> None:
        """Forget what an earlier run of this tree left, then set t0 and the initial signals.

        Forgotten: completion flags, t0, and every signal written with
        :meth:`write` since the earlier run began (by leaves, initial values, a
        host using ``write``). Kept: values the tree did not write - published by
        a system (:meth:`publish`) or by a host before the tree's first tick. An
        initial signal is written only where no value is kept, so it never
        overwrites a system's value or a host's. *client*: the writer of t0 and the
        initial signals (:class:`~btgen_pytrees.leaves.wiring.RunStart`'s).
        """
        prefix, signals = self.namespace + "/", self._signals
        storage = Blackboard.storage
        for key in [k for k in storage if k.startswith(prefix) and not k.startswith(signals)]:
            del storage[key]
        if self._runs:  # before the first run, every value was written by the host: keep it
            for name in self._written:
                storage.pop(signals + name, None)
        self._written = set()
        self._pending = {}
        self.cutting = False
        self._runs += 1
        t0 = self.clock.now() if self._tick_time is None else self._tick_time
        if client is not None and Blackboard.activity_stream is not None:
            setattr(client, self._t0, t0)
        _set(self._t0, t0)
        for name, value in self.initial_signals.items():
            if signals + name not in storage:
                self.write(name, value, client)

    def begin_tick(self) -> float:
        """A tick of the tree begins: read the clock, once; :meth:`now` answers from this reading
        until the next tick begins. Returns the reading."""
        t = self._tick_time = self.clock.now()
        self.ticks += 1
        if self._pending:
            self._flush()
        return t

    def _flush(self) -> None:
        pending, self._pending = self._pending, {}
        for name, value in pending.items():
            self.write(name, value)

    def now(self) -> float:
        """Seconds since the run's first tick (0.0 before it), as of the tick that runs (or ran last).

        Before the tree's root has ever ticked (a leaf ticked on its own) the clock is read at each call.
        """
        t = self._tick_time
        if t is None:
            t = self.clock.now()
        return t - Blackboard.storage.get(self._t0, t)

    # -- signals ---------------------------------------------------------
    def read(self, name: str, client: Client | None = None) -> Any:
        """The current value of signal *name*; ``KeyError`` if it has none."""
        key = self._signals + name
        if client is not None and Blackboard.activity_stream is not None and key in Blackboard.storage:
            return getattr(client, key)
        return Blackboard.storage[key]

    def write(self, name: str, value: Any, client: Client | None = None) -> None:
        """Set signal *name*, as the test: a re-run of the tree forgets it (see :meth:`start_run`)."""
        self._written.add(name)
        key = self._signals + name
        if client is not None and Blackboard.activity_stream is not None:
            setattr(client, key, value)  # the client records it (an absolute key: dots are not attributes)
        # the storage directly: Blackboard.set would take 'ego.speed' as attribute 'speed' of key 'ego'
        _set(key, value)

    def values(self, names: Iterable[str], client: Client | None = None) -> dict[str, Any]:
        """The current values of those *names* that have one."""
        storage, prefix = Blackboard.storage, self._signals
        if client is not None and Blackboard.activity_stream is not None:
            return {n: getattr(client, prefix + n) for n in names if prefix + n in storage}
        found = {}
        keys = self._keys.get(names) if type(names) is tuple else None  # a leaf's names: the same tuple every tick
        if keys is None:
            keys = tuple((n, prefix + n) for n in names)
            if type(names) is tuple and len(self._keys) < 1024:
                self._keys[names] = keys
        for n, key in keys:  # every oracle and `until` reads its values every tick: no key made per name
            if key in storage:
                found[n] = storage[key]
        return found

    def publish(self, name: str, value: Any) -> None:
        """Set signal *name* as its owner outside the tree (a system, the host): the tree's
        start never forgets it, and its initial value never overwrites it."""
        self._written.discard(name)
        Blackboard.storage[self._signals + name] = value

    # -- completion flags --------------------------------------------------
    def mark_done(self, entry_id: str) -> None:
        """Set ``<ns>/done/<entry_id>`` and tell every listener (see :meth:`listen_done`)."""
        _set(self._done + entry_id, True, self._flags)
        for listener in self._done_listeners:
            listener(entry_id)

    def listen_done(self, listener: Callable[[str], None]) -> None:
        """Call *listener* with the entry id each time :meth:`mark_done` marks one.

        This is how a waiting trigger is woken instead of polled: the composite
        holding the triggers (:class:`~btgen_pytrees.leaves.wiring.WakingParallel`)
        listens, so a tick costs what is active, not what waits.
        """
        self._done_listeners.append(listener)

    def forget_listeners(self) -> None:
        """Forget every :meth:`listen_done` listener. For a tree that will not tick again: a listener is
        a method of one of the tree's nodes, which hold this environment, so each keeps the other alive
        until the garbage collector finds the cycle (``run()`` takes the tree it made apart once its
        report is made: :func:`btgen_pytrees.run.runner.take_apart`)."""
        self._done_listeners = []
        self._cut_listeners = []

    def post(self, name: str, value: Any) -> None:
        """Set signal *name* when the next tick begins (an entry's state: docs/semantics.md#entry-states), so every
        node of the tree sees the change on the same tick, whatever its place in the tree."""
        self._pending[name] = value

    # -- stops and cuts (the control-flow keys: btgen_pytrees.leaves.control) ----------------------------
    def stop_key(self, entry_id: str) -> str:
        """The blackboard key of the stop requests for entry *entry_id*: ``<ns>/stop/<id>``."""
        return self._stop + entry_id

    def request_stop(self, entry_id: str, by: str, now: float, how: str) -> None:
        """Ask entry *entry_id* to stop (``stops`` or ``race``, said by *how*): a request of this tick, which the entry
        honours on its next tick if it was running on this one."""
        key = self._stop + entry_id
        requests = Blackboard.storage.get(key)
        if requests is None:
            _set(key, [(by, self.ticks, now, how)], self._flags)
        else:
            requests.append((by, self.ticks, now, how))

    def note_stop(self, label: str, now: float) -> None:
        """The case's ``stop`` *label* fired at *now*: ``<ns>/stopped``."""
        _set(self._stopped, (label, now), self._flags)

    def stopped(self) -> tuple[str, float] | None:
        """The ``stop`` that ended the run, and when (``None``: none did)."""
        found = Blackboard.storage.get(self._stopped)
        return found if isinstance(found, tuple) else None

    def mark_cut(self, entry_id: str) -> None:
        """Entry *entry_id* will never succeed in this run (stopped, or its branch was): ``<ns>/cut/<id>``; tells
        the :meth:`listen_cut` listeners (a join waiting for it may now never fire)."""
        _set(self._cut + entry_id, True, self._flags)
        for listener in self._cut_listeners:
            listener(entry_id)

    def is_cut(self, entry_id: str) -> bool:
        return (self._cut + entry_id) in Blackboard.storage

    def listen_cut(self, listener: Callable[[str], None]) -> None:
        """Call *listener* with the entry id each time :meth:`mark_cut` marks one."""
        self._cut_listeners.append(listener)

    def is_done(self, entry_id: str) -> bool:
        return (self._done + entry_id) in Blackboard.storage

    def mark_failed(self, criterion_id: str) -> None:
        _set(self._failed + criterion_id, True, self._flags)

    def is_failed(self, criterion_id: str) -> bool:
        return (self._failed + criterion_id) in Blackboard.storage

    def mark_execute_done(self) -> None:
        _set(self._execute_done, True, self._flags)

    def execute_done(self, client: Client | None = None) -> bool:
        done = self._execute_done in Blackboard.storage
        if done and client is not None and Blackboard.activity_stream is not None:
            getattr(client, self._execute_done)  # recorded as the read it is
        return done
