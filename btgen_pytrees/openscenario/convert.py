"""An OpenSCENARIO file as a test-case document: a concrete scenario, or a distribution as a sweep.

:func:`read_openscenario` is what the project's loader calls for a ``.xosc`` file
(``load/read.py``'s :func:`~btgen_pytrees.load.read.load_json`), so ``validate``, ``show``,
``run``, ``expand``, ``falsify`` and the pytest plugin take ``.xosc`` files as they take ``.json``:

* a scenario (``Storyboard``) gives the case document (:mod:`.scenario`), with its default
  parameters and the default pass criteria, and the oracle of its sidecar
  ``SCENARIO.oracle.json`` when there is one (:mod:`.oracle`);
* a ``ParameterValueDistribution`` gives a :class:`ScenarioSweep`: a ``dict`` (the document of the
  scenario's defaults, plus the ``variations`` block of the distributions the project's block can
  express - what ``falsify`` searches) that also renders the document of any variation
  (:meth:`ScenarioSweep.render`) and lists the variations (:class:`ScenarioVariations`): the
  sweep machinery (``load/template.py``'s ``Sweep``) asks it, so each variation is the scenario
  converted again with its values - ``${...}`` expressions and catalog references included.

Variations whose values break a parameter's ``ConstraintGroup`` s are discarded, as the standard
expects a generator to do (1.2, clause 9.4): the count is the product the file defines minus those.

Every problem is an :class:`~btgen_pytrees.errors.InvalidTestCase` (exit 2) naming the file and the
element's path; every element the conversion did not use is one problem, never silently dropped.
"""

from __future__ import annotations

import math
import os
import xml.parsers.expat
from typing import Any, Callable, Iterator, Mapping

from ..errors import InvalidTestCase, Problem
from .distributions import Distribution, parse_distribution
from .oracle import Sidecar, read_sidecar
from .parameters import Scope, convert_value
from .scenario import Options, convert_scenario, header
from .xmltree import CAUSE, Node, XmlProblem, problem, read_xml, unused

__all__ = ["read_openscenario", "ScenarioSweep", "ScenarioVariations", "is_openscenario", "convert_file", "SUFFIX", "scan",
           "is_catalog"]

SUFFIX = ".xosc"


def is_openscenario(path: Any) -> bool:
    """Whether *path* names an OpenSCENARIO file (by its suffix)."""
    return isinstance(path, (str, os.PathLike)) and os.fspath(path).lower().endswith(SUFFIX)


class _Found(Exception):
    pass


PEEK_BYTES = 1024 * 1024
"""How much of a ``.xosc`` :func:`is_catalog` reads at most to find the element after its header."""


def is_catalog(path: str) -> bool:
    """Whether the ``.xosc`` file *path* is a catalog (its root holds a ``Catalog``): a directory of
    scenarios keeps its catalogs beside them, and they are no case. Only the start of the file is
    read, by expat with no DOCTYPE; a file that cannot be read or told is not a catalog (so the
    loader, given it, says what is wrong with it)."""
    parser = xml.parsers.expat.ParserCreate()
    depth = [0]

    def start(tag: str, _attributes: Any) -> None:
        depth[0] += 1
        if depth[0] == 2 and tag != "FileHeader":
            raise _Found(tag == "Catalog")

    def end(_tag: str) -> None:
        depth[0] -= 1

    def refuse(*_args: Any) -> None:
        raise _Found(False)

    parser.StartElementHandler, parser.EndElementHandler = start, end
    parser.StartDoctypeDeclHandler = parser.EntityDeclHandler = refuse
    try:
        with open(path, "rb") as fh:
            left = PEEK_BYTES
            while left > 0:
                chunk = fh.read(min(65536, left))
                left -= len(chunk)
                parser.Parse(chunk, not chunk)
                if not chunk:
                    break
    except _Found as found:
        return bool(found.args[0])
    except (OSError, xml.parsers.expat.ExpatError):
        pass
    return False


def _fail(exc: XmlProblem, path: str) -> InvalidTestCase:
    node = exc.node
    if node is not None and os.path.abspath(node.file) != os.path.abspath(path):
        return InvalidTestCase([Problem(node.path, f"{node.file}: {exc.message}", CAUSE)], path)
    return InvalidTestCase([problem(node, exc.message)], path)


def scan(root: Node, catalogs: Any) -> list[Problem]:
    """Every element (and attribute) of the scenario and of the catalog entries it used that the conversion did not use."""
    found = unused(root)
    for cat in catalogs.files:
        for catalog in cat.children:
            for entry in catalog.children:
                if entry.used:
                    found.extend(Problem(p.path, f"{cat.file}: {p.message}", CAUSE) for p in unused(entry))
    return found


def convert_file(path: str, given: Mapping[str, Any] | None = None, options: Options | None = None,
                 case_dir: str | None = None, root: Node | None = None, check: bool = True) -> dict[str, Any]:  # fmt: skip
    """The case document of the scenario file *path*; raises :class:`InvalidTestCase`."""
    root = root if root is not None else read_xml(path)
    try:
        doc, catalogs = convert_scenario(root, path, given, options, case_dir=case_dir)
    except XmlProblem as exc:
        raise _fail(exc, path) from None
    if check:
        problems = scan(root, catalogs)
        if problems:
            raise InvalidTestCase(problems, path)
    return doc


class ScenarioVariations:
    """A distribution's variations as the sweep asks for them (the interface of ``load.variations.Variations``)."""

    def __init__(self, distribution: Distribution, keep: Callable[[tuple[tuple[str, Any], ...]], bool],
                 types: Mapping[str, str] | None = None):  # fmt: skip
        self.distribution = distribution
        self.keep = keep
        self.types = dict(types or {})
        self._kept: list[int] | None = None
        self.axes = tuple(_box(distribution))
        self.samples = distribution.runs
        self.seed = distribution.seed

    @property
    def total(self) -> int:
        """The product (or ``numberOfTestRuns``) the file defines."""
        return self.distribution.count

    def _indices(self) -> list[int]:
        if self._kept is None:
            self._kept = [i for i, p in enumerate(self.distribution.points()) if self.keep(p)]
        return self._kept

    @property
    def count(self) -> int:
        return len(self._indices())

    @property
    def discarded(self) -> int:
        return self.total - self.count

    @property
    def names(self) -> tuple[str, ...]:
        return self.distribution.names

    @property
    def grid(self) -> tuple[Any, ...]:
        return () if self.distribution.stochastic else tuple(_Named(n) for n in self.distribution.names)

    @property
    def randoms(self) -> tuple[Any, ...]:
        return tuple(_Named(n) for n in self.distribution.names) if self.distribution.stochastic else ()

    def points(self) -> Iterator[tuple[tuple[str, Any], ...]]:
        """The kept variations, each value of its parameter's declared type (``"3"`` of an int parameter is 3)."""
        kept = set(self._indices())
        for i, p in enumerate(self.distribution.points()):
            if i in kept:
                yield tuple((k, v if k == "sample" else _typed(v, self.types.get(k, "string"))) for k, v in p)


class _Named:
    def __init__(self, name: str):
        self.name = name


class _BoxAxis:
    """An axis of the ``variations`` block ``falsify`` searches (name, kind, spec as ``load.variations.Axis``)."""

    def __init__(self, name: str, kind: str, spec: Any):
        self.name, self.kind, self.spec = name, kind, spec

    @property
    def random(self) -> bool:
        return self.kind in ("uniform", "normal")


def _typed(value: Any, kind: str) -> Any:
    try:
        return convert_value(value, kind)
    except ValueError:
        return value  # discarded by its constraints or refused when converted, with the reason


def _number(x: Any) -> Any:
    try:
        f = float(x)
    except (TypeError, ValueError):
        return x
    return int(f) if f.is_integer() else f


def _box(d: Distribution) -> Iterator[_BoxAxis]:
    """The distribution as the box ``falsify`` searches: ranges as ranges, sets as choices, a
    value set as the choices of each of its parameters, a stochastic distribution as its Range
    (uniform), or its own shape where it has none."""
    for a in d.axes:
        if a.kind == "range":
            low, high, step = a.spec
            yield _BoxAxis(a.names[0], "range", {"from": _number(low), "to": _number(high), "step": _number(step)})
        else:
            for i, name in enumerate(a.names):
                yield _BoxAxis(name, "list", list(dict.fromkeys(_number(row[i]) for row in a.spec)))
    for s in d.stochastic:
        if "range" in (s.spec if isinstance(s.spec, dict) else {}):
            yield _BoxAxis(s.name, "uniform", {"uniform": list(s.spec["range"])})
        elif s.kind == "normal":
            yield _BoxAxis(s.name, "normal", {"normal": [s.spec["mean"], math.sqrt(s.spec["variance"])]})
        elif s.kind == "lognormal":
            m, v = s.spec["mean"], s.spec["variance"]
            yield _BoxAxis(s.name, "uniform", {"uniform": [0, m + 4 * math.sqrt(v)]})
        elif s.kind == "poisson":
            m = s.spec["mean"]
            yield _BoxAxis(s.name, "range", {"from": 0, "to": int(m + 4 * math.sqrt(m)) + 1, "step": 1})
        elif s.kind == "histogram":
            bins = s.spec[0]
            yield _BoxAxis(s.name, "uniform", {"uniform": [min(b[0] for b in bins), max(b[1] for b in bins)]})
        else:
            yield _BoxAxis(s.name, "list", [_number(v) for v in s.spec[0]])


class ScenarioSweep(dict):  # type: ignore[type-arg]
    """A distribution file: the defaults' document (a ``dict``), the variations, and the document of each."""

    def __init__(self, document: Mapping[str, Any], render: Callable[[Mapping[str, Any]], dict[str, Any]],
                 variations: ScenarioVariations, defaults: Mapping[str, Any], source: str):  # fmt: skip
        super().__init__(document)
        self.render = render
        self.scenario_variations = variations
        self.defaults = dict(defaults)
        self.source = source

    def __reduce__(self) -> Any:  # sent to a worker as the plain document it is
        return (dict, (dict(self),))


def read_openscenario(path: str, options: Options | None = None, given: Mapping[str, Any] | None = None,
                      oracle: str | None = None) -> dict[str, Any]:  # fmt: skip
    """The document of the OpenSCENARIO file *path* (a :class:`ScenarioSweep` for a distribution);
    *oracle*: a sidecar file to use instead of ``NAME.oracle.json`` beside it."""
    root = read_xml(path)
    sidecar = read_sidecar(path, oracle)
    options = sidecar.options(options)
    if root.tag != "OpenSCENARIO":
        raise InvalidTestCase([Problem((root.tag,), f"the root element is {root.tag}, not OpenSCENARIO", CAUSE)], path)
    kinds = [c.tag for c in root.children]
    if "ParameterValueDistribution" in kinds:
        return _sweep(root, path, options, sidecar)
    if "Catalog" in kinds:
        raise InvalidTestCase([Problem(("OpenSCENARIO", "Catalog"), "a catalog file is not a scenario: run the scenario that references it", CAUSE)], path)
    if "Storyboard" not in kinds:
        raise InvalidTestCase([Problem(("OpenSCENARIO",), "neither a scenario (Storyboard) nor a ParameterValueDistribution", CAUSE)], path)
    return sidecar.apply(convert_file(path, given, options, root=root), path)


def _sweep(root: Node, path: str, options: Options, sidecar: Sidecar) -> ScenarioSweep:
    root.use()
    try:
        from_header(root)
        distribution = parse_distribution(root, Scope())
    except XmlProblem as exc:
        raise _fail(exc, path) from None
    problems = unused(root)
    if problems:
        raise InvalidTestCase(problems, path)
    here = os.path.dirname(os.path.abspath(path))
    scenario = os.path.normpath(os.path.join(here, distribution.scenario))
    file_node = distribution.node.child("ScenarioFile")
    if not os.path.isfile(scenario):
        raise InvalidTestCase([problem(file_node, f"scenario file {distribution.scenario!r} not found (looked for {scenario!r})")], path)
    scenario_root = read_xml(scenario)
    sidecar = sidecar if sidecar.found else read_sidecar(scenario)
    options = sidecar.options(options)
    document = convert_file(scenario, None, options, case_dir=here, root=scenario_root)
    declarations = scenario_root.child("ParameterDeclarations")
    declared = {d.attrs.get("name"): d for d in (declarations.children if declarations is not None else [])}
    unknown = [n for n in distribution.names if n not in declared]
    if unknown:
        raise InvalidTestCase([problem(distribution.node, f"{', '.join(map(repr, unknown))} {'is' if len(unknown) == 1 else 'are'} "
                                                          f"not declared in {distribution.scenario!r} (declared: {', '.join(sorted(map(str, declared)))})")], path)  # fmt: skip
    defaults = Scope()
    defaults.declare(declarations, check=False)

    def keep(point: tuple[tuple[str, Any], ...]) -> bool:
        try:
            Scope().declare(declarations, {k: v for k, v in point if k != "sample"})
        except XmlProblem:
            return False
        return True

    def render(values: Mapping[str, Any]) -> dict[str, Any]:
        given = {k: v for k, v in values.items() if k in declared}
        return sidecar.apply(convert_file(scenario, given, options, case_dir=here, root=scenario_root, check=False), path)

    types = {str(d.attrs.get("name")): d.attrs.get("parameterType", "string") for d in declared.values()}
    variations = ScenarioVariations(distribution, keep, types)
    doc = sidecar.apply(document, path)
    doc["name"] = os.path.splitext(os.path.basename(path))[0] or doc["name"]
    doc["variations"] = _block(variations)
    return ScenarioSweep(doc, render, variations, {n: defaults.values[n] for n in distribution.names}, path)


def _block(variations: ScenarioVariations) -> dict[str, Any]:
    """The ``variations`` block of the box (what a reader of the document sees of the distribution)."""
    block: dict[str, Any] = {a.name: a.spec for a in variations.axes}
    if variations.distribution.stochastic:
        block["samples"] = variations.samples
        block["seed"] = variations.seed
    return block


def from_header(root: Node) -> None:
    header(root, Scope())
