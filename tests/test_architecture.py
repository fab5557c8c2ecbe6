"""The package's import structure, read from its own source with ``ast``.

docs/architecture.md states the rule: imports go one way (a module imports only from its own layer
or lower ones), no import cycles - not even hidden behind ``TYPE_CHECKING``, an import inside a
function or a package's ``__init__`` -, no function-level import of a project module, no underscore
name imported from another module. The restructuring that brings the package there spans several
commits; until it is done, what still breaks the rule is listed below, *exactly*. The list is a
ratchet: a new break fails the test, and so does a listed break that no longer exists (take it off
the list), so the list only shrinks. ``python tests/test_architecture.py`` prints the lists as the
code is now (sorted, one break a line), to paste after a change has removed breaks.
"""

from __future__ import annotations

import ast
import functools
import pathlib
import tomllib
from dataclasses import dataclass

import networkx as nx
import pytest

PACKAGE_NAME = "btgen_pytrees"
PACKAGE = pathlib.Path(__file__).resolve().parent.parent / PACKAGE_NAME

#: The layers, lowest first: a module may import from its own layer and from lower ones.
#: A name stands for a module and everything under it (the longest matching name decides), except the
#: package's own name, which stands for its ``__init__`` only: a new module needs a line here.
LAYERS: dict[str, int] = {
    # L0: the vocabulary every step speaks
    "btgen_pytrees.text": 0,
    "btgen_pytrees.order": 0,
    "btgen_pytrees.errors": 0,
    "btgen_pytrees.expressions": 0,
    "btgen_pytrees.formulas": 0,
    "btgen_pytrees.clock": 0,
    "btgen_pytrees.writing": 0,
    "btgen_pytrees.progress": 0,
    "btgen_pytrees.validator": 0,
    "btgen_pytrees.model": 0,
    # L1: contracts and algorithms that know no leaf, system or view
    "btgen_pytrees.timeline": 1,
    "btgen_pytrees.monitor": 1,
    "btgen_pytrees.contracts": 1,
    "btgen_pytrees.parallel": 1,
    # L2: systems under test; L3: built-in behaviours (the SUMO actions among them) and their registration
    "btgen_pytrees.systems": 2,
    "btgen_pytrees.leaves": 3,
    # L4: what a case is made into
    "btgen_pytrees.load": 4,
    "btgen_pytrees.construct": 4,
    "btgen_pytrees.openscenario": 4,
    # L5: views of a tree; L6: a run and what it leaves
    "btgen_pytrees.render": 5,
    "btgen_pytrees.run": 6,
    # L7: many cases
    "btgen_pytrees.sweep": 7,
    "btgen_pytrees.batch": 8,
    "btgen_pytrees.falsify": 8,
    # L9: the faces: command line, pytest plugin, the package's own face
    "btgen_pytrees.cli": 9,
    "btgen_pytrees.supervise": 9,
    "btgen_pytrees.pytest_plugin": 9,
    "btgen_pytrees.pytest_cases": 9,
    "btgen_pytrees.__main__": 9,
    "btgen_pytrees": 9,
}


@dataclass(frozen=True)
class Import:
    module: str  # the importing module
    target: str  # the project module it reads
    name: str  # the name imported ("" for a module), or the private attribute read from an imported module
    function_level: bool
    type_checking: bool
    attribute: bool = False  # ``module._name`` read from a module imported whole, not an import


def module_name(path: pathlib.Path, package: pathlib.Path = PACKAGE) -> str:
    parts = list(path.relative_to(package.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules(package: pathlib.Path = PACKAGE) -> dict[str, pathlib.Path]:
    return {module_name(p, package): p for p in sorted(package.rglob("*.py"))}


def layer(module: str) -> int:
    best = max(
        (p for p in LAYERS if module == p or (p != PACKAGE_NAME and module.startswith(p + "."))),
        key=len,
        default=None,
    )
    if best is None:
        raise AssertionError(f"{module} has no layer: add it to LAYERS here and to docs/architecture.md")
    return LAYERS[best]


def parents(module: str) -> list[str]:
    """The packages Python imports before ``module`` (their ``__init__`` runs first), outermost first."""
    parts = module.split(".")
    return [".".join(parts[:k]) for k in range(1, len(parts))]


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _read(module: str, path: pathlib.Path, known: dict[str, pathlib.Path]) -> list[Import]:
    """The project imports of one module, and the private attributes it reads from imported project modules."""
    here = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: list[Import] = []
    bound: dict[str, str] = {}  # a local name bound to a project module -> that module

    def resolve(node: ast.ImportFrom) -> str:
        if not node.level:
            return node.module or ""
        base = here.split(".")[: len(here.split(".")) - (node.level - 1)]
        return ".".join(base + ([node.module] if node.module else []))

    def visit(node: ast.AST, in_function: bool, in_type_checking: bool) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.body:
                visit(child, in_function, True)
            for child in node.orelse:
                visit(child, in_function, in_type_checking)
            return
        function = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == PACKAGE_NAME or alias.name.startswith(PACKAGE_NAME + "."):
                    found.append(Import(module, alias.name, "", function, in_type_checking))
                    if alias.asname:
                        bound[alias.asname] = alias.name
        elif isinstance(node, ast.ImportFrom):
            source = resolve(node)
            if source == PACKAGE_NAME or source.startswith(PACKAGE_NAME + "."):
                for alias in node.names:
                    sub = f"{source}.{alias.name}"
                    if sub in known:  # ``from package import submodule``
                        found.append(Import(module, sub, "", function, in_type_checking))
                        bound[alias.asname or alias.name] = sub
                    else:
                        found.append(Import(module, source, alias.name, function, in_type_checking))
        elif (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in bound
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            found.append(Import(module, bound[node.value.id], node.attr, in_function, in_type_checking, True))
        for child in ast.iter_child_nodes(node):
            visit(child, function, in_type_checking)

    visit(ast.parse(path.read_text(encoding="utf-8")), False, False)
    return found


@functools.lru_cache(maxsize=None)
def imports(package: pathlib.Path = PACKAGE) -> tuple[Import, ...]:
    """Every project import of every module of the package: module level, in functions, under ``TYPE_CHECKING``."""
    known = modules(package)
    return tuple(imp for module, path in known.items() for imp in _read(module, path, known))


def edges(package: pathlib.Path = PACKAGE) -> set[tuple[str, str]]:
    """Who depends on whom. Importing ``a.b.c`` runs the ``__init__`` of ``a`` and ``a.b`` first: an edge to
    each of them too, except to the importer's own packages (Python imports those before the importer anyway);
    a name imported from one of the importer's own packages, though, is an edge to that package."""
    found = set()
    for imp in imports(package):
        if imp.attribute:
            continue
        for target in [*parents(imp.target), imp.target]:
            inside = imp.module.startswith(target + ".")
            if imp.module != target and (not inside or (target == imp.target and imp.name)):
                found.add((imp.module, target))
    return found


def cycles(package: pathlib.Path = PACKAGE) -> set[frozenset[str]]:
    """The modules of each import cycle (a strongly connected component), every kind of import counted."""
    graph = nx.DiGraph(list(edges(package)))
    return {frozenset(c) for c in nx.strongly_connected_components(graph) if len(c) > 1}


def function_level(package: pathlib.Path = PACKAGE) -> set[tuple[str, str]]:
    return {(i.module, i.target) for i in imports(package) if i.function_level and not i.attribute}


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_names(package: pathlib.Path = PACKAGE) -> set[tuple[str, str, str]]:
    """Underscore names read from another module; a private ``_module`` only from inside its own package."""
    found = set()
    for i in imports(package):
        if i.target == i.module:
            continue
        if _private(i.name):
            found.add((i.module, i.target, i.name))
        elif not i.name:
            owner, _, last = i.target.rpartition(".")
            if _private(last) and not i.module.startswith(owner + "."):
                found.add((i.module, i.target, ""))
    return found


def upward(package: pathlib.Path = PACKAGE) -> set[tuple[str, str]]:
    return {(module, target) for module, target in edges(package) if layer(target) > layer(module)}


# What still breaks the rule, exactly (see the module docstring). Filled from the code; shrink it.
KNOWN_CYCLES: set[frozenset[str]] = set()
KNOWN_FUNCTION_LEVEL: set[tuple[str, str]] = set()
KNOWN_PRIVATE: set[tuple[str, str, str]] = set()
KNOWN_UPWARD: set[tuple[str, str]] = set()


def shown(item: tuple[str, ...] | frozenset[str]) -> str:
    return repr(tuple(sorted(item)) if isinstance(item, frozenset) else item)


def diff(name: str, found: set, known: set) -> list[str]:
    new = sorted(map(shown, found - known))
    gone = sorted(map(shown, known - found))
    lines = [f"new {name} (not allowed): {x}" for x in new]
    lines += [f"{name} gone - take it off the list in tests/test_architecture.py: {x}" for x in gone]
    if lines:
        lines.append("(python tests/test_architecture.py prints the lists as they are now)")
    return lines


def test_every_module_has_a_layer() -> None:
    for module in modules():
        layer(module)


def test_docs_name_every_module() -> None:
    """docs/architecture.md has a line for every module (a package's ``__init__`` as ``folder/__init__.py``)."""
    text = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    missing = [
        path.relative_to(PACKAGE).as_posix()
        for path in modules().values()
        if f"`{path.relative_to(PACKAGE).as_posix()}`" not in text
    ]
    assert not missing, f"docs/architecture.md says nothing of: {', '.join(missing)}"


@pytest.mark.parametrize(
    ("name", "found", "known"),
    [
        ("import cycle", cycles, KNOWN_CYCLES),
        ("function-level project import", function_level, KNOWN_FUNCTION_LEVEL),
        ("private name across modules", private_names, KNOWN_PRIVATE),
        ("upward import", upward, KNOWN_UPWARD),
    ],
)
def test_imports_follow_the_rule(name: str, found, known) -> None:
    problems = diff(name, found(), known)
    assert not problems, "\n".join(problems)


def test_the_checks_find_each_kind_of_break(tmp_path: pathlib.Path) -> None:
    """A small package breaking each rule once: every check finds its break and nothing else."""
    pkg = tmp_path / "btgen_pytrees"
    (pkg / "run").mkdir(parents=True)
    files = {
        "__init__.py": "",
        "errors.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .model import Model\n",
        "model.py": "from btgen_pytrees.errors import Problem\n",
        "expressions.py": "from .run.runner import run\n",
        "clock.py": "def now():\n    from . import errors\n    return errors\n",
        "writing.py": "from .errors import _private, public\n",
        "run/__init__.py": "",
        "run/runner.py": "from ..errors import Problem\n",
    }
    for name, text in files.items():
        (pkg / name).write_text(text)
    assert cycles(pkg) == {frozenset({"btgen_pytrees.errors", "btgen_pytrees.model"})}
    assert function_level(pkg) == {("btgen_pytrees.clock", "btgen_pytrees.errors")}
    assert private_names(pkg) == {("btgen_pytrees.writing", "btgen_pytrees.errors", "_private")}
    # importing run.runner runs run/__init__ first: both are above expressions
    assert upward(pkg) == {
        ("btgen_pytrees.expressions", "btgen_pytrees.run"),
        ("btgen_pytrees.expressions", "btgen_pytrees.run.runner"),
    }
    with pytest.raises(AssertionError, match="has no layer"):
        layer("elsewhere.module")
    with pytest.raises(AssertionError, match="has no layer"):
        layer("btgen_pytrees.newcomer")
    assert layer("btgen_pytrees.run.newcomer") == layer("btgen_pytrees.run")


def test_the_checks_see_what_hides_an_import(tmp_path: pathlib.Path) -> None:
    """A cycle closed only through a package's ``__init__``, a private attribute read from a module
    imported whole, and private modules: allowed inside their package, a break from outside it."""
    pkg = tmp_path / "btgen_pytrees"
    for folder in ("leaves", "systems", "run"):
        (pkg / folder).mkdir(parents=True)
    files = {
        "__init__.py": "",
        "leaves/__init__.py": "from .builtin import register\n",
        "leaves/builtin.py": "from ..systems.simulated import Simulated\n",
        "leaves/registry.py": "class Registry: ...\n",
        "systems/__init__.py": "from .base import System\n",
        "systems/base.py": "from ..leaves.registry import Registry\n",
        "systems/simulated.py": "X = 1\n",
        "run/__init__.py": "",
        "run/_impl.py": "",
        "run/runner.py": "from . import _impl\nimport btgen_pytrees.clock as clock\nnow = clock._now\n",
        "clock.py": "",
        "writing.py": "from .run import _impl\n",
    }
    for name, text in files.items():
        (pkg / name).write_text(text)
    leaves = {"btgen_pytrees.leaves", "btgen_pytrees.leaves.builtin"}
    systems = {"btgen_pytrees.systems", "btgen_pytrees.systems.base"}  # not simulated: it imports nothing
    assert cycles(pkg) == {frozenset(leaves | systems)}
    assert private_names(pkg) == {
        ("btgen_pytrees.run.runner", "btgen_pytrees.clock", "_now"),
        ("btgen_pytrees.writing", "btgen_pytrees.run._impl", ""),
    }
    assert function_level(pkg) == set()


def literals() -> str:
    """The KNOWN_* lists as the code is now, as Python literals: sorted, one break a line."""
    out = []
    for name, found, kind in (
        ("KNOWN_CYCLES", cycles(), "set[frozenset[str]]"),
        ("KNOWN_FUNCTION_LEVEL", function_level(), "set[tuple[str, str]]"),
        ("KNOWN_PRIVATE", private_names(), "set[tuple[str, str, str]]"),
        ("KNOWN_UPWARD", upward(), "set[tuple[str, str]]"),
    ):
        if not found:
            out.append(f"{name}: {kind} = set()")
            continue
        out.append(f"{name}: {kind} = {{")
        for item in sorted(found, key=shown):
            if isinstance(item, frozenset):
                out.append("    frozenset({")
                out.extend(f"        {m!r}," for m in sorted(item))
                out.append("    }),")
            else:
                out.append(f"    {item!r},")
        out.append("}")
    return "\n".join(out)


if __name__ == "__main__":
    print(literals())


def test_every_package_is_installed() -> None:
    """pyproject.toml's package list finds every package of the tree (a package it missed would be absent
    from a wheel, while an editable install, which reads the tree, still imported it)."""
    find_packages = pytest.importorskip("setuptools").find_packages
    root = PACKAGE.parent
    config = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    found = set(find_packages(str(root), include=config["packages"]["find"]["include"]))
    packages = {".".join(p.relative_to(root).parent.parts) for p in PACKAGE.rglob("__init__.py")}
    assert packages and found == packages
