"""Catalogs: ``CatalogLocations`` directories and ``CatalogReference`` s resolved, parameters assigned.

ASAM OpenSCENARIO 1.2, clause 7.5 "Reuse mechanisms" (catalogs; 1.0: 8.5): a reference names a
catalog (``catalogName``, the ``name`` of a ``Catalog`` element in some file of the directory the
scenario's ``CatalogLocations`` give for that kind) and an entry (``entryName``); its
``ParameterAssignments`` replace the defaults of the entry's own ``ParameterDeclarations``, in a
scope of its own above the scenario's. A missing directory, catalog or entry is a problem at the
reference, naming what was looked for.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from typing import Any

from ..errors import InvalidTestCase
from .parameters import Scope
from .xmltree import Node, XmlProblem, read_xml

__all__ = ["Catalogs", "KINDS", "MAX_CATALOG_FILES", "CACHE_SIZE", "forget"]

KINDS = ("VehicleCatalog", "ControllerCatalog", "PedestrianCatalog", "MiscObjectCatalog", "EnvironmentCatalog",
         "ManeuverCatalog", "TrajectoryCatalog", "RouteCatalog")  # fmt: skip

MAX_CATALOG_FILES = 256
"""Most ``.xosc`` files read from one catalog directory."""


_CACHE: "OrderedDict[tuple[str, int, int], Node]" = OrderedDict()
CACHE_SIZE = 64
"""Catalog files kept parsed (a sweep converts its scenario once per variation), each by its real path,
size and modification time: an edited file is read again."""


def forget() -> None:
    """Drop the parsed catalog files (their nodes remember which entries a conversion used: the coverage
    of one scenario starts from none)."""
    _CACHE.clear()


def _read_cached(path: str) -> Node:
    info = os.stat(path)
    key = (os.path.realpath(path), info.st_size, info.st_mtime_ns)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    root = read_xml(path)
    _CACHE[key] = root
    while len(_CACHE) > CACHE_SIZE:
        _CACHE.popitem(last=False)
    return root


class Catalogs:
    """The catalogs a scenario may reference, read lazily (only a directory some reference needs)."""

    def __init__(self, locations: Node | None, scope: Scope, base: str):
        self.dirs: dict[str, tuple[Node, str]] = {}
        self.files: list[Node] = []  # every catalog file read (for the coverage table)
        self.entries: dict[str, dict[str, Node]] | None = None
        if locations is not None:
            for kind in locations.children:
                kind.use()
                if kind.tag not in KINDS:
                    raise XmlProblem(kind, f"unknown catalog kind {kind.tag} (known: {', '.join(KINDS)})")
                directory = kind.need_child("Directory")
                path = scope.text(directory, "path") or ""
                self.dirs[kind.tag] = (directory, os.path.normpath(os.path.join(base, path)))
        self.loaded: dict[str, dict[str, dict[str, Node]]] = {}

    def load(self, kind: str, where: Node) -> dict[str, dict[str, Node]]:
        if kind in self.loaded:
            return self.loaded[kind]
        if kind not in self.dirs:
            raise XmlProblem(where, f"a catalog reference needs a {kind} under CatalogLocations")
        directory, path = self.dirs[kind]
        if not os.path.isdir(path):
            raise XmlProblem(directory, f"catalog directory {path!r} not found")
        catalogs: dict[str, dict[str, Node]] = {}
        names = sorted(n for n in os.listdir(path) if n.endswith(".xosc"))[:MAX_CATALOG_FILES]
        for name in names:
            try:
                root = _read_cached(os.path.join(path, name))
            except InvalidTestCase as exc:
                raise XmlProblem(directory, f"catalog file {os.path.join(path, name)!r}: {exc.problems[0].message}") from None
            catalog = root.child("Catalog") if root.tag == "OpenSCENARIO" else None
            if catalog is None:
                continue
            root.use()
            for c in root.children:
                if c.tag == "FileHeader":
                    c.use_all()
            self.files.append(root)
            entries = catalogs.setdefault(catalog.need("name"), {})
            for entry in catalog.children:
                entries.setdefault(entry.attrs.get("name", ""), entry)
        self.loaded[kind] = catalogs
        return catalogs

    def resolve(self, kind: str, reference: Node, scope: Scope) -> tuple[Node, Scope]:
        """The entry a ``CatalogReference`` names, and the scope of its parameters (assignments applied)."""
        catalog = scope.text(reference, "catalogName") or ""
        entry = scope.text(reference, "entryName") or ""
        catalogs = self.load(kind, reference)
        if catalog not in catalogs:
            raise XmlProblem(reference, f"catalog {catalog!r} not found in {self.dirs[kind][1]!r}"
                                        + (f" (found: {', '.join(sorted(catalogs))})" if catalogs else ""))  # fmt: skip
        if entry not in catalogs[catalog]:
            raise XmlProblem(reference, f"entry {entry!r} not found in catalog {catalog!r} (entries: {', '.join(sorted(catalogs[catalog]))})")
        node = catalogs[catalog][entry].use()
        inner = Scope(scope)
        given: dict[str, Any] = {}
        assignments = reference.child("ParameterAssignments")
        if assignments is not None:
            for a in assignments.all("ParameterAssignment"):
                given[a.need("parameterRef")] = scope.value(a, a.need("value"))
        declarations = node.child("ParameterDeclarations")
        declared = {d.attrs.get("name") for d in declarations.children} if declarations is not None else set()
        unknown = sorted(set(given) - declared)
        if unknown:
            raise XmlProblem(reference, f"assigns {', '.join(unknown)}, which entry {entry!r} does not declare")
        inner.declare(declarations, given)
        return node, inner
