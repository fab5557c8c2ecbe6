"""Export a generated tree as BehaviorTree.CPP v4 XML, so it opens in Groot2.

One ``<root BTCPP_format="4">`` with one ``<BehaviorTree>`` (its ID is the test
name) and a ``<TreeNodesModel>`` declaring every node type that is not a
BT.CPP built-in, with its ports, so Groot2 knows them all. Nodes use the
explicit form (``<Action ID="set" name="B1" signal="mode" value="1"/>``).

How py_trees maps (``docs/views.md`` says exactly what differs):

* ``Sequence(memory=True)`` → ``Sequence``: both resume at the running child
  and restart from the first child after a failure. ``memory=False`` →
  ``ReactiveSequence``; ``Selector`` → ``Fallback``/``ReactiveFallback`` alike.
* ``Parallel`` → ``Parallel`` with ``success_count``/``failure_count``:
  ``SuccessOnAll`` is ``-1``/``1``, ``SuccessOnOne`` is ``1``/``1``. BT.CPP 4's
  Parallel does not tick a finished child again, which is py_trees'
  ``synchronise=True``.
* ``SuccessOnSelected`` has no count that says *which* children must succeed.
  The export keeps ``success_count`` = the number of selected children and
  wraps every other child as ``Sequence(child, KeepRunningUntilFailure(AlwaysSuccess))``:
  such a branch can still fail the Parallel, but never succeeds, so only the
  selected children can reach the count, and a finished unselected child is
  not started again.
* every leaf is an ``<Action>``, also constraints and oracles: they stay
  RUNNING over many ticks and must be halted when the run ends, and a BT.CPP
  ``Condition`` can do neither (its ``halt()`` is final and does nothing). An
  entry's leaf is named by its id (and its ``name`` label in parentheses, if
  it has one) and carries its ``params`` as ports; a
  criterion's carries ``expect``, ``from``/``to``/``at`` and its params.
* the generator's wiring keeps its class name: ``Trigger`` (ports
  ``waits_for``, ``join``), ``RunStart``, and the decorators ``Completion``
  (``marks``) and ``OrMember`` (``member``, ``group``); lists are ``;``-joined,
  BT.CPP's convention.

>>> from btgen_pytrees import load, generate
>>> xml = btcpp_xml(generate(load("examples/fig1.json")))
>>> for line in xml.splitlines():
...     if "<Parallel" in line or "not selected" in line:
...         print(line)
    <Parallel name="fig1" success_count="1" failure_count="1">
      <Sequence name="execute (not selected)">
          <Parallel name="timeline" success_count="-1" failure_count="1">
              <Parallel name="roots" success_count="-1" failure_count="1">
                  <Parallel name="fork B1" success_count="-1" failure_count="1">
      <Parallel name="oracle" success_count="1" failure_count="1">
        <Sequence name="record &amp;&amp; (not selected)">
          <Parallel name="record &amp;&amp;" success_count="-1" failure_count="1">
        <Parallel name="others &amp;&amp;" success_count="-1" failure_count="1">
"""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Any

import networkx as nx
import py_trees
from py_trees.composites import Composite, Parallel, Selector, Sequence
from py_trees.decorators import Decorator

from ..errors import xml_safe
from ..leaves.control import Attempts, Controlled, Gate, Repetitions, StopGuard, VirtualTimeout
from ..leaves.wiring import Completion, Cuttable, OrMember, RunStart, Trigger
from .nodes import is_selected, policy_name, selected

__all__ = ["btcpp_xml", "btcpp_document", "BtcppDocument", "port_value", "port_name", "port_names", "BUILTINS",
           "format_btcpp"]

Policy = py_trees.common.ParallelPolicy

BUILTINS = frozenset({
    "Sequence", "ReactiveSequence", "SequenceWithMemory", "Fallback", "ReactiveFallback", "Parallel",
    "ParallelAll", "KeepRunningUntilFailure", "AlwaysSuccess", "AlwaysFailure", "Inverter", "ForceSuccess",
    "ForceFailure", "Repeat", "RetryUntilSuccessful", "Timeout", "Delay", "RunOnce", "SubTree", "Script",
    "ScriptCondition", "SetBlackboard", "Sleep", "Switch2", "IfThenElse", "WhileDoElse",
})  # fmt: skip
"""BT.CPP's own node types; an action of the same name gets a suffix so Groot2 cannot confuse them."""

_FIXED_KINDS = ("wiring", "other")
"""Models named after a py_trees class: their ID is the class name, always."""

_PORT_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_RESERVED_PORTS = frozenset({"name", "ID"})
_TYPES = {bool: "bool", int: "double", float: "double", str: "std::string"}
"""Port types for Groot2. Numbers are ``double`` even when written as ``1``: ``"1"`` reads as a
double, while an ``int`` port would reject ``"0.5"`` from the next entry that uses the action."""


@dataclass(frozen=True)
class _Port:
    """One port of one node: its value, and for the model a description and type (``None``: from the value)."""

    name: str
    value: Any
    description: str
    type: str | None = None


def port_value(value: Any) -> str:
    """A param as a BT.CPP port string: strings as written, anything else as JSON (``true``, ``2.5``, ``[1,2]``)."""
    if isinstance(value, str):
        return value
    return json.dumps(value, ensure_ascii=False, separators=(",", ":"), allow_nan=False)


def port_name(key: str) -> str:
    """The port for param *key*: itself when BT.CPP allows it, else ``p_`` + the key with other characters as ``_``.

    BT.CPP port names start with a letter, hold letters, digits and ``_``, and
    may not be ``name`` or ``ID`` (those are the node's own attributes).
    """
    if _PORT_NAME.fullmatch(key) and key not in _RESERVED_PORTS:
        return key
    return "p_" + re.sub(r"[^A-Za-z0-9_]", "_", key)


def port_names(keys: list[str]) -> list[str]:
    """The ports for a node's *keys*, in order: :func:`port_name` of each, and a trailing ``_``
    while one clashes with an earlier port (two params can map to one name); all are kept."""
    taken = {"ID", "name"}
    names = []
    for key in keys:
        name = port_name(key)
        while name in taken:
            name += "_"
        taken.add(name)
        names.append(name)
    return names


@dataclass
class _Model:
    """One node type of the ``<TreeNodesModel>``: its tag, ports (name → types seen, description)."""

    tag: str
    preferred: str
    kind: str
    description: str
    ports: dict[str, tuple[set[str], str]] = field(default_factory=dict)
    id: str = ""

    def add_port(self, port: _Port) -> None:
        types, _ = self.ports.setdefault(port.name, (set(), port.description))
        types.add(port.type or _TYPES.get(type(port.value), ""))


class _Export:
    """One export: builds the tree element, collecting the node models on the way."""

    def __init__(self) -> None:
        self.models: dict[tuple[str, str], _Model] = {}
        self.uses: list[tuple[ET.Element, _Model]] = []
        self.elements: dict[int, ET.Element] = {}
        self.wrappers: dict[int, tuple[ET.Element, ET.Element, ET.Element]] = {}
        self.inner: dict[int, ET.Element] = {}  # a node whose children go under an element of its own (a Gate's Delay)

    # -- node types -------------------------------------------------------------

    def model(self, key: tuple[str, str], tag: str, preferred: str, description: str) -> _Model:
        found = self.models.get(key)
        if found is None:
            found = self.models[key] = _Model(tag, preferred, key[0], description)
        return found

    def custom(self, parent: ET.Element, tag: str, key: tuple[str, str], preferred: str, description: str,
               name: str, ports: list[_Port]) -> ET.Element:  # fmt: skip
        """A non-built-in node ``<tag ID=… name=… port=…>``; its ID is settled in :meth:`settle_ids`."""
        model = self.model(key, tag, preferred, description)
        element = ET.SubElement(parent, tag, {"ID": "", "name": name})
        for port, unique in zip(ports, port_names([p.name for p in ports])):
            port = _Port(unique, port.value, port.description, port.type)
            element.set(port.name, port_value(port.value))
            model.add_port(port)
        self.uses.append((element, model))
        return element

    def settle_ids(self) -> None:
        """Give every model its ID: the preferred one, unless it is taken.

        Wiring and other py_trees classes keep their class name. An action (or
        criterion) gets ``_<kind>`` when its name is a BT.CPP built-in, a class
        name in use, or the action of another kind too.
        """
        fixed = {m.preferred for m in self.models.values() if m.kind in _FIXED_KINDS} | BUILTINS
        wanted: dict[str, int] = {}
        for model in self.models.values():
            wanted[model.preferred] = wanted.get(model.preferred, 0) + 1
        for model in self.models.values():
            clash = model.kind not in _FIXED_KINDS and (wanted[model.preferred] > 1 or model.preferred in fixed)
            model.id = f"{model.preferred}_{model.kind}" if clash else model.preferred
        for element, model in self.uses:
            element.set("ID", model.id)

    # -- nodes ------------------------------------------------------------------

    def control(self, parent: ET.Element, node: py_trees.behaviour.Behaviour) -> ET.Element | None:
        """Elements for the nodes of the control-flow keys (BT.CPP's own where it has one); ``None`` for others."""
        if isinstance(node, Controlled):
            control = node.control
            ports = []
            if control.stops:
                ports.append(_Port("stops", ";".join(control.stops), "ids of the entries it stops when it starts, ';'-separated"))
            if control.race is not None:
                ports.append(_Port("race", control.race, "its race group: the first member to succeed stops the others"))
            return self.custom(parent, "Decorator", ("wiring", "Controlled"), "Controlled",
                               "an entry with control keys: its status is the entry's; it honours stop requests",
                               node.entry.label, ports)  # fmt: skip
        if isinstance(node, Repetitions):
            return ET.SubElement(parent, "Repeat", name=node.name, num_cycles=str(node.num_success))
        if isinstance(node, Attempts):
            return ET.SubElement(parent, "RetryUntilSuccessful", name=node.name, num_attempts=str(node.num_failures))
        if isinstance(node, VirtualTimeout):
            return ET.SubElement(parent, "Timeout", name=node.name, msec=str(round(node.duration * 1000)))
        if isinstance(node, Gate):  # BT.CPP's Delay for the delay; the when, before it, is a Gate of ours
            condition = node.condition
            delay = None
            if condition.when is not None:
                ports = [_Port("when", condition.when.source, "the start condition (expression)"),
                         _Port("edge", condition.edge, "none: holds; rising/falling/any: changes so")]  # fmt: skip
                element = self.custom(parent, "Decorator", ("wiring", "Gate"), "Gate",
                                      "holds its child until the condition fires (the entry's trigger)", node.name, ports)  # fmt: skip
                if condition.delay:
                    delay = ET.SubElement(element, "Delay", name=f"delay {condition.delay:g} s",
                                          delay_msec=str(round(condition.delay * 1000)))  # fmt: skip
                    self.inner[id(node)] = delay
                return element
            return ET.SubElement(parent, "Delay", name=node.name, delay_msec=str(round(condition.delay * 1000)))
        if isinstance(node, StopGuard):
            ports = [_Port("when", ";".join(s.when.source for s in node.stops), "the stop conditions, ';'-separated"),
                     _Port("edge", ";".join(s.edge for s in node.stops), "each condition's edge, ';'-separated"),
                     _Port("delay_msec", ";".join(str(round(s.delay * 1000)) for s in node.stops),
                           "each condition's delay in milliseconds, ';'-separated")]  # fmt: skip
            return self.custom(parent, "Decorator", ("wiring", "StopGuard"), "StopGuard",
                               "halts the timeline and succeeds when a stop condition fires", node.name, ports)  # fmt: skip
        if isinstance(node, Cuttable):
            return self.custom(parent, "Decorator", ("wiring", "Cuttable"), "Cuttable",
                               "a branch a stopped entry ends as finished: its stop's failure becomes success", node.name, [])  # fmt: skip
        return None

    def leaf_or_wiring(self, parent: ET.Element, node: py_trees.behaviour.Behaviour) -> ET.Element | None:
        """Elements for entries, criteria and wiring; ``None`` for other nodes."""
        entry = getattr(node, "btgen_entry", None) or getattr(node, "btgen_action", None)
        if entry is not None and not isinstance(node, Controlled):
            ports = [_Port(k, v, f"param {k!r} of the {entry.kind}") for k, v in entry.params.items()]
            return self.custom(parent, "Action", (entry.kind, entry.action), entry.action,
                               f"{entry.kind} action {entry.action!r} (execute entry)", entry.label, ports)  # fmt: skip
        criterion = getattr(node, "btgen_criterion", None)
        if criterion is not None:
            return self.criterion(parent, criterion)
        if isinstance(node, Trigger):
            ports = [_Port("waits_for", ";".join(node.waits_for), "ids of the entries waited for, ';'-separated"),
                     _Port("join", node.join, "any: one of them finished is enough; all: every one")]  # fmt: skip
            return self.custom(parent, "Action", ("wiring", "Trigger"), "Trigger",
                               "RUNNING until the entries it waits for are marked done", node.name, ports)  # fmt: skip
        if isinstance(node, RunStart):
            return self.custom(parent, "Action", ("wiring", "RunStart"), "RunStart",
                               "resets the blackboard namespace, starts the clock, sets initial signals", node.name, [])  # fmt: skip
        if isinstance(node, Completion):
            marks = node.marks if node.marks is not None else "execute"
            return self.custom(parent, "Decorator", ("wiring", "Completion"), "Completion",
                               "passes the child's status through; marks it done on the blackboard when it succeeds",
                               node.name, [_Port("marks", marks, "id of the entry marked done ('execute': the execute subtree)")])  # fmt: skip
        if isinstance(node, OrMember):
            ports = [_Port("member", node.member, "this criterion's id"),
                     _Port("group", ";".join(node.group), "ids of every member of the || group, ';'-separated")]  # fmt: skip
            return self.custom(parent, "Decorator", ("wiring", "OrMember"), "OrMember",
                               "latches its criterion's failure; fails only when every member of the group failed",
                               node.name, ports)  # fmt: skip
        return None

    def criterion(self, parent: ET.Element, criterion: Any) -> ET.Element:
        ports = [_Port("expect", criterion.expect.source, "the expectation (expression)")]
        for key, value, text in (("from", criterion.start, "window start, s"), ("to", criterion.end, "window end, s"),
                                 ("at", criterion.at, "evaluation time, s")):  # fmt: skip
            if value is not None:
                ports.append(_Port(key, value, text, "double"))
        ports += [_Port(k, v, f"param {k!r} of the criterion") for k, v in criterion.params.items()]
        preferred = criterion.action or criterion.type.capitalize()
        what = f"{criterion.type} criterion" + (f" action {criterion.action!r}" if criterion.action else "")
        return self.custom(parent, "Action", (criterion.type, criterion.action or ""), preferred,
                           f"oracle: {what}", criterion.label, ports)  # fmt: skip

    def composite(self, parent: ET.Element, node: py_trees.behaviour.Behaviour) -> ET.Element:
        """Elements for py_trees' composites and for any other node (by its class name)."""
        name = node.name
        if isinstance(node, Parallel):
            return self.parallel(parent, node)
        if isinstance(node, Sequence):
            return ET.SubElement(parent, "Sequence" if node.memory else "ReactiveSequence", name=name)
        if isinstance(node, Selector):
            return ET.SubElement(parent, "Fallback" if node.memory else "ReactiveFallback", name=name)
        cls = type(node).__name__
        tag = "Decorator" if isinstance(node, Decorator) else "Control" if isinstance(node, Composite) else "Action"
        return self.custom(parent, tag, ("other", cls), cls, f"py_trees {cls}", name, [])

    def parallel(self, parent: ET.Element, node: Parallel) -> ET.Element:
        policy = node.policy
        if isinstance(policy, Policy.SuccessOnOne):
            success = "1"
        elif isinstance(policy, Policy.SuccessOnSelected):
            success = str(len(policy.children))
            chosen = ", ".join(c.name for c in policy.children)
            parent.append(ET.Comment(
                f" SuccessOnSelected({chosen}): only selected children count; the others are wrapped to fail it, never succeed "))
        else:
            success = "-1"
        if not policy.synchronise and not isinstance(policy, Policy.SuccessOnOne):
            parent.append(ET.Comment(
                f" py_trees {policy_name(node)} without synchronise ticks children that succeeded again; "
                "BT.CPP's Parallel does not "))  # fmt: skip
        return ET.SubElement(parent, "Parallel", name=node.name, success_count=success, failure_count="1")


def _unselected(parent: py_trees.behaviour.Behaviour, child: py_trees.behaviour.Behaviour) -> bool:
    return selected(parent) is not None and not is_selected(parent, child)


def _walk(root: py_trees.behaviour.Behaviour, top: ET.Element, export: _Export) -> None:
    """Pre-order, without recursion; entries and criteria are opaque (their subtree is the action)."""
    stack: list[tuple[py_trees.behaviour.Behaviour, ET.Element]] = [(root, top)]
    while stack:
        node, parent = stack.pop()
        wrapper = None
        if node is not root and node.parent is not None and _unselected(node.parent, node):
            # Sequence(child, KeepRunningUntilFailure(AlwaysSuccess)): fails with the child, never succeeds
            wrapper = parent = ET.SubElement(parent, "Sequence", name=f"{node.name} (not selected)")
        element = export.control(parent, node)
        opaque = False
        if element is None:
            element = export.leaf_or_wiring(parent, node)
            opaque = element is not None and not isinstance(node, (Completion, OrMember))
        if element is None:
            element = export.composite(parent, node)
        export.elements[id(node)] = element
        if wrapper is not None:
            keep = ET.SubElement(wrapper, "KeepRunningUntilFailure", name=f"{node.name} finished")
            export.wrappers[id(node)] = (wrapper, keep, ET.SubElement(keep, "AlwaysSuccess"))
        if not opaque:
            below = export.inner.get(id(node), element)
            stack.extend((child, below) for child in reversed(node.children))


def _model_element(model: _Model) -> ET.Element:
    element = ET.Element(model.tag, ID=model.id)
    for port, (types, text) in model.ports.items():
        attrs = {"name": port}
        if len(types) == 1 and "" not in types:
            attrs["type"] = next(iter(types))
        ET.SubElement(element, "input_port", attrs).text = text
    ET.SubElement(element, "description").text = model.description
    return element


@dataclass
class BtcppDocument:
    """The export as an element tree, with where each py_trees node went.

    Attributes:
        document: the ``<root>`` element
        tree: its ``<BehaviorTree>``
        elements: ``id(node)`` -> the node's element (nodes inside an entry's or
            criterion's leaf subtree have none: the leaf is one Action)
        wrappers: ``id(node)`` -> ``(Sequence, KeepRunningUntilFailure, AlwaysSuccess)``
            around a child that a ``SuccessOnSelected`` policy did not select
    """

    document: ET.Element
    tree: ET.Element
    elements: dict[int, ET.Element]
    wrappers: dict[int, tuple[ET.Element, ET.Element, ET.Element]]


def btcpp_document(root: py_trees.behaviour.Behaviour) -> BtcppDocument:
    """*root* as a BehaviorTree.CPP v4 element tree (what :func:`btcpp_xml` prints)."""
    tree_id = root.name or "tree"
    document = ET.Element("root", BTCPP_format="4", main_tree_to_execute=tree_id)
    document.append(ET.Comment(
        " btgen_pytrees: each Sequence is py_trees' Sequence(memory=True); each leaf an Action, as it may stay RUNNING "))
    tree = ET.SubElement(document, "BehaviorTree", ID=tree_id)
    export = _Export()
    _walk(root, tree, export)
    export.settle_ids()
    models = ET.SubElement(document, "TreeNodesModel")
    for model in sorted(export.models.values(), key=lambda m: (m.id, m.tag)):
        models.append(_model_element(model))
    return BtcppDocument(document, tree, export.elements, export.wrappers)


def btcpp_xml(root: py_trees.behaviour.Behaviour) -> str:
    """*root* as BehaviorTree.CPP v4 XML text (deterministic; see the module notes)."""
    document = btcpp_document(root).document
    ET.indent(document, space="  ")
    # characters XML forbids can only sit in names and params: escaped, the document stays well-formed
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + xml_safe(ET.tostring(document, encoding="unicode")) + "\n"


def format_btcpp(root: py_trees.behaviour.Behaviour, graph: nx.DiGraph, **_: Any) -> str:
    return btcpp_xml(root)
