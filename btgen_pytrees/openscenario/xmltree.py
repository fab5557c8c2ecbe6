"""An OpenSCENARIO (or catalog) file read safely, as a tree of :class:`Node` s that know their place.

The file comes from anyone, so it is parsed with :mod:`defusedxml` (no DTD, no entity of any
kind - so no expansion bomb and no external reference -), within :data:`MAX_XML_BYTES` and
:data:`MAX_DEPTH`. Every node knows its path in the form problems are reported in
(``/OpenSCENARIO/Storyboard/Story[@name='S']/Act[@name='A']``), and whether the converter *used*
it: an element nothing used is an unsupported element, reported, never silently dropped
(:func:`unused`). Attributes are read through :meth:`Node.get`, which marks them used the same way.
"""

from __future__ import annotations

import os
import stat
from typing import Iterator

import defusedxml.ElementTree as safe_et
from defusedxml import DefusedXmlException

from ..errors import InvalidTestCase, Problem

__all__ = ["Node", "read_xml", "XmlProblem", "MAX_XML_BYTES", "MAX_DEPTH", "CAUSE", "problem"]

MAX_XML_BYTES = 16 * 1024 * 1024
"""Largest OpenSCENARIO or catalog file read (16 MiB; the ALKS files are below 20 kB)."""

MAX_DEPTH = 64
"""Deepest element nesting accepted (the standard's deepest path is about 20 levels)."""

XSI = "{http://www.w3.org/2001/XMLSchema-instance}"
"""The XML Schema instance namespace: ``xsi:noNamespaceSchemaLocation`` (every ASAM example names its
schema so) and ``xsi:schemaLocation`` are for validators, not OpenSCENARIO attributes: read, not reported."""

CAUSE = "openscenario"
"""The cause of every problem this package reports."""


class XmlProblem(Exception):
    """A problem at a node: raised where the converter cannot go on with the element."""

    def __init__(self, node: "Node | None", message: str):
        super().__init__(message)
        self.node = node
        self.message = message


def problem(node: "Node | None", message: str) -> Problem:
    return Problem(node.path if node is not None else (), message, CAUSE)


class Node:
    """One element: its tag, attributes and children, its path, and which of them were used."""

    __slots__ = ("tag", "attrs", "children", "path", "used", "read", "text", "file")

    def __init__(self, tag: str, attrs: dict[str, str], path: tuple[str, ...], file: str):
        self.tag = tag
        self.attrs = attrs
        self.children: list[Node] = []
        self.path = path
        self.used = False
        self.read: set[str] = set()
        self.text = ""
        self.file = file

    def __repr__(self) -> str:
        return f"Node({'/'.join(self.path)})"

    def use(self) -> "Node":
        self.used = True
        return self

    def use_all(self) -> "Node":
        """Mark this element and everything below it used (parts the converter reads as a whole or documents as ignored)."""
        for node in self.walk():
            node.used = True
            node.read.update(node.attrs)
        return self

    def get(self, name: str, default: str | None = None) -> str | None:
        """The raw text of attribute *name* (marked read), or *default*."""
        self.read.add(name)
        return self.attrs.get(name, default)

    def need(self, name: str) -> str:
        value = self.get(name)
        if value is None:
            raise XmlProblem(self, f"{self.tag} needs the attribute {name!r}")
        return value

    def child(self, tag: str) -> "Node | None":
        for c in self.children:
            if c.tag == tag:
                return c.use()
        return None

    def need_child(self, tag: str) -> "Node":
        found = self.child(tag)
        if found is None:
            raise XmlProblem(self, f"{self.tag} needs a {tag} element")
        return found

    def all(self, tag: str) -> list["Node"]:
        found = [c for c in self.children if c.tag == tag]
        for c in found:
            c.use()
        return found

    def only(self) -> "Node":
        """The one child element (a choice in the standard's schema)."""
        if len(self.children) != 1:
            raise XmlProblem(self, f"{self.tag} must hold exactly one element, not {len(self.children)}")
        return self.children[0].use()

    def walk(self) -> Iterator["Node"]:
        stack = [self]
        while stack:
            node = stack.pop()
            yield node
            stack.extend(reversed(node.children))


def unused(root: Node) -> list[Problem]:
    """One problem per element the converter did not use (its subtree is not walked further), and per
    attribute of a used element it did not read."""
    found: list[Problem] = []
    stack = [root]
    while stack:
        node = stack.pop()
        if not node.used:
            found.append(problem(node, f"unsupported element {node.tag}: not converted (see docs/openscenario.md)"))
            continue
        for name in node.attrs:
            if name not in node.read:
                found.append(problem(node, f"unsupported attribute {name}={node.attrs[name]!r} of {node.tag}"))
        stack.extend(reversed(node.children))
    return found


def _label(tag: str, attrs: dict[str, str], index: int, same: int) -> str:
    name = attrs.get("name")
    if name is not None and "'" not in name:
        return f"{tag}[@name='{name}']"
    if name is None and "entityRef" in attrs and tag == "Private":
        return f"{tag}[@entityRef='{attrs['entityRef']}']"
    return f"{tag}[{index}]" if same > 1 else tag


def read_bytes(path: str) -> bytes:
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise InvalidTestCase([Problem((), "not a regular file", CAUSE)], path)
        if info.st_size > MAX_XML_BYTES:
            raise InvalidTestCase([Problem((), f"file is {info.st_size} bytes; the limit is {MAX_XML_BYTES}", "limit")], path)
        with open(path, "rb") as fh:
            raw = fh.read(MAX_XML_BYTES + 1)
    except OSError as exc:
        raise InvalidTestCase([Problem((), f"cannot read file: {exc.strerror or exc}", CAUSE)], path) from None
    if len(raw) > MAX_XML_BYTES:
        raise InvalidTestCase([Problem((), f"file is larger than {MAX_XML_BYTES} bytes", "limit")], path)
    return raw


def read_xml(path: str) -> Node:
    """The file at *path* as a :class:`Node` tree; :class:`InvalidTestCase` (exit 2) for anything unsafe or malformed."""
    raw = read_bytes(path)
    try:
        root = safe_et.fromstring(raw, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException as exc:
        raise InvalidTestCase([Problem((), f"refused XML: {type(exc).__name__} (no DTD, entities or external references)", CAUSE)], path) from None
    except safe_et.ParseError as exc:
        raise InvalidTestCase([Problem((), f"not well-formed XML: {exc}", CAUSE)], path) from None
    except (ValueError, UnicodeError) as exc:
        raise InvalidTestCase([Problem((), f"not readable XML: {exc}", CAUSE)], path) from None
    top = Node(root.tag, dict(root.attrib), (root.tag,), path)
    top.text = (root.text or "").strip()
    top.read.update(k for k in top.attrs if k.startswith(XSI))
    stack = [(root, top, 1)]
    while stack:
        element, node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise InvalidTestCase([Problem(node.path, f"elements nest deeper than {MAX_DEPTH} levels", "limit")], path)
        counts: dict[str, int] = {}
        kids = [k for k in element if isinstance(k.tag, str)]  # comments and processing instructions are not elements
        for k in kids:
            counts[k.tag] = counts.get(k.tag, 0) + 1
        seen: dict[str, int] = {}
        for k in kids:
            seen[k.tag] = seen.get(k.tag, 0) + 1
            attrs = dict(k.attrib)
            child = Node(k.tag, attrs, (*node.path, _label(k.tag, attrs, seen[k.tag], counts[k.tag])), path)
            child.text = (k.text or "").strip()
            child.read.update(a for a in attrs if a.startswith(XSI))
            node.children.append(child)
            stack.append((k, child, depth + 1))
    return top
