"""A run as a BehaviorTree.CPP ``.btlog`` file (FileLogger2's layout), so Groot2 can replay it.

The layout, as BehaviorTree.CPP 4's ``FileLogger2`` writes it::

    "BTCPP4-FileLogger2"            18 bytes of ASCII
    protocol                        1 byte, 1
    XML length                      int32, little-endian
    XML                             the tree, every node with its "_uid"
    first timestamp                 int64 microseconds, little-endian
    transition *                    9 bytes each:
        timestamp                   6 bytes: microseconds since the first, little-endian
        uid                         2 bytes: the node's "_uid", little-endian
        status                      1 byte: 0 IDLE, 1 RUNNING, 2 SUCCESS, 3 FAILURE

The XML is the tree of :mod:`btgen_pytrees.render.btcpp` (the ``--format btcpp``
export) in the compact form BT.CPP's own ``WriteTreeToXML`` writes
(``<set name="B1" _uid="7" .../>`` rather than ``<Action ID="set" ...>``),
numbered 1, 2, ... in document order, as BT.CPP numbers the nodes it builds.

The transitions are the run's :class:`~.trace.RunTrace`, in order, stamped
with the run's (virtual) time; the first timestamp is 0, so the same run gives
the same bytes. py_trees' ``INVALID`` is BT.CPP's ``IDLE``. The export's
wrappers around children a ``SuccessOnSelected`` policy did not select follow
their child: RUNNING while it runs, FAILURE with it, still RUNNING (and its
``KeepRunningUntilFailure`` RUNNING, ``AlwaysSuccess`` SUCCESS) once it has
succeeded, IDLE when it is halted. Nodes inside an entry's leaf (a user
factory's subtree) have no element of their own and are left out.

>>> from btgen_pytrees import generate, load
>>> from btgen_pytrees.run import run
>>> case = load("examples/fig1.json")
>>> data = btlog_bytes(run(case).trace, generate(case))
>>> data[:19], len(parse_btlog(data).transitions) > 0
(b'BTCPP4-FileLogger2\\x01', True)
"""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import py_trees

from ..errors import xml_safe
from ..render.btcpp import btcpp_document
from ..render.nodes import walk
from .trace import RunTrace

__all__ = ["btlog_bytes", "check_btlog", "parse_btlog", "Btlog", "BtlogError", "MAGIC", "MAX_UID", "MAX_TIME_US"]

MAGIC = b"BTCPP4-FileLogger2"
PROTOCOL = 1
MAX_UID = 0xFFFF
"""A uid has 16 bits: a tree of more elements cannot be logged."""
MAX_TIME_US = 2**48 - 1
"""A transition's time has 48 bits of microseconds (about 8.9 years): a run that may last longer cannot be logged."""

_GENERIC = ("Action", "Condition", "Decorator", "Control", "SubTree")


class BtlogError(ValueError):
    """The tree cannot be written as a ``.btlog`` (too many nodes); ``str()`` says why."""


def _nodes(tree: ET.Element) -> list[ET.Element]:
    nodes = [e for e in tree.iter() if e is not tree and isinstance(e.tag, str)]
    if len(nodes) > MAX_UID:
        raise BtlogError(f"the tree has {len(nodes):,} BT.CPP nodes; a .btlog numbers nodes with 16 bits (at most {MAX_UID:,})")
    return nodes


def _check_time(seconds: float) -> None:
    if not round(seconds * 1_000_000) <= MAX_TIME_US:
        raise BtlogError(f"the run may last {seconds:g} s; a .btlog stamps transitions with 48-bit microseconds, "
                         f"at most {MAX_TIME_US / 1e6:,.0f} s (about 8.9 years)")  # fmt: skip


def check_btlog(root: py_trees.behaviour.Behaviour, last: float | None = None) -> None:
    """Raise :class:`BtlogError` if *root* cannot be logged, or a run that may last until *last*
    seconds could not be stamped (before a run, so a run is not wasted)."""
    if last is not None:
        _check_time(last)
    _nodes(btcpp_document(root).tree)


def _compact(tree: ET.Element) -> list[ET.Element]:
    """Rewrite *tree*'s nodes in BT.CPP's compact form, number them, and return them in uid order."""
    nodes = _nodes(tree)
    for uid, element in enumerate(nodes, start=1):
        if element.tag in _GENERIC and "ID" in element.attrib:
            element.tag = element.attrib.pop("ID")
        attrs = dict(element.attrib)
        element.attrib.clear()
        if "name" in attrs:
            element.set("name", attrs.pop("name"))
        element.set("_uid", str(uid))
        element.attrib.update(attrs)
    return nodes


def btlog_bytes(trace: RunTrace | None, root: py_trees.behaviour.Behaviour) -> bytes:
    """The run recorded in *trace* (of a tree like *root*: same case, freshly generated) as ``.btlog`` bytes.

    Without a trace (a run that ended before its first tick) the file has the
    tree and no transitions.

    Raises:
        BtlogError: the export has more than 65,535 nodes, or the run lasted past 2**48 microseconds
    """
    exported = btcpp_document(root)
    tree = exported.tree
    tree.set("_fullpath", "")
    for parent in list(exported.document.iter()):
        for child in list(parent):
            if not isinstance(child.tag, str):  # comments: not part of what BT.CPP writes
                parent.remove(child)
    uids = {id(element): uid for uid, element in enumerate(_compact(tree), start=1)}
    behaviours = [node for _, node in walk(root)]
    if trace is not None and len(behaviours) != len(trace.nodes):
        raise ValueError("the trace is of another tree")
    node_uid = [uids.get(id(exported.elements.get(id(b))), 0) for b in behaviours]
    wrapped = {i: tuple(uids[id(e)] for e in exported.wrappers[id(b)]) for i, b in enumerate(behaviours)
               if id(b) in exported.wrappers}  # fmt: skip
    xml = xml_safe(ET.tostring(exported.document, encoding="unicode")).encode("utf-8")  # well-formed whatever the names
    out = bytearray(MAGIC)
    out.append(PROTOCOL)
    out += struct.pack("<i", len(xml))
    out += xml
    out += struct.pack("<q", 0)
    last: dict[int, int] = {}

    def emit(usec: int, uid: int, code: int) -> None:
        if last.get(uid, 0) != code:
            last[uid] = code
            out.extend(usec.to_bytes(6, "little") + uid.to_bytes(2, "little") + bytes((code,)))

    if trace is None:
        return bytes(out)
    if trace.times:
        _check_time(max(trace.times))  # never wrap silently
    for tick, i, code in zip(trace.ticks, trace.nodes_changed, trace.statuses):
        usec = max(0, round(trace.times[tick] * 1_000_000))
        if i in wrapped:
            wrapper, keep, always = wrapped[i]
            if code == 0:
                for uid in (always, keep, wrapper):
                    emit(usec, uid, 0)
            elif code == 2:
                emit(usec, wrapper, 1)
        uid = node_uid[i]
        if uid:
            emit(usec, uid, code)
        if i in wrapped:
            wrapper, keep, always = wrapped[i]
            if code in (1, 3):
                emit(usec, wrapper, code)
            elif code == 2:
                emit(usec, keep, 1)
                emit(usec, always, 2)
    return bytes(out)


@dataclass
class Btlog:
    """A ``.btlog`` read back: its XML and its transitions ``(microseconds, uid, status)``."""

    xml: str
    first_timestamp: int
    transitions: list[tuple[int, int, int]]

    def names(self) -> dict[int, str]:
        """uid -> the node's ``name`` attribute (or its tag)."""
        root = ET.fromstring(self.xml)
        return {int(e.get("_uid", "0")): e.get("name", e.tag) for e in root.iter() if e.get("_uid")}


def parse_btlog(data: bytes) -> Btlog:
    """Read ``.btlog`` bytes (the layout in the module notes); :class:`ValueError` if they are not one."""
    if not data.startswith(MAGIC) or len(data) < len(MAGIC) + 5:
        raise ValueError("not a BTCPP4-FileLogger2 file")
    at = len(MAGIC)
    if data[at] != PROTOCOL:
        raise ValueError(f"unknown protocol {data[at]}")
    (size,) = struct.unpack_from("<i", data, at + 1)
    at += 5
    xml = data[at:at + size].decode("utf-8")
    at += size
    (first,) = struct.unpack_from("<q", data, at)
    at += 8
    body = data[at:]
    if len(body) % 9:
        raise ValueError(f"{len(body)} bytes of transitions is not a multiple of 9")
    transitions = [(int.from_bytes(body[j:j + 6], "little"), int.from_bytes(body[j + 6:j + 8], "little"), body[j + 8])
                   for j in range(0, len(body), 9)]  # fmt: skip
    return Btlog(xml, first, transitions)
