"""The command line's boundary (docs/architecture.md): only the faces parse options and print.

Domain packages (the pipeline, sweep/, falsify/, batch, parallel/) take plain arguments and return
data: they never import argparse, never call print() and never write to sys.stdout/sys.stderr
themselves. cli/__init__.py knows no command's flags: each command module adds its own sub-parser.
"""

from __future__ import annotations

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "btgen_pytrees"
FACES = ("cli/", "pytest_plugin.py", "pytest_cases.py", "__main__.py", "supervise.py")
DOMAIN = sorted(p for p in PACKAGE.rglob("*.py") if not p.relative_to(PACKAGE).as_posix().startswith(FACES))


def crossings(path: pathlib.Path) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import) and any(a.name == "argparse" for a in node.names):
            found.append(f"{node.lineno}: import argparse")
        elif isinstance(node, ast.ImportFrom) and node.module == "argparse":
            found.append(f"{node.lineno}: from argparse import")
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print":
            found.append(f"{node.lineno}: print()")
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "write"
              and isinstance(node.func.value, ast.Attribute) and node.func.value.attr in ("stdout", "stderr")):  # fmt: skip
            found.append(f"{node.lineno}: sys.{node.func.value.attr}.write()")
    return found


@pytest.mark.parametrize("path", DOMAIN, ids=lambda p: p.relative_to(PACKAGE).as_posix())
def test_a_domain_module_neither_parses_options_nor_prints(path: pathlib.Path) -> None:
    assert crossings(path) == []


def test_the_main_module_knows_no_command_flags() -> None:
    tree = ast.parse((PACKAGE / "cli" / "__init__.py").read_text(encoding="utf-8"))
    flags = [n.args[0].value for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
             and n.func.attr == "add_argument" and n.args and isinstance(n.args[0], ast.Constant)]  # fmt: skip
    assert flags == ["--version"]


def test_the_check_sees_a_crossing(tmp_path: pathlib.Path) -> None:
    sample = tmp_path / "m.py"
    sample.write_text("import argparse\nimport sys\nprint(1)\nsys.stderr.write('x')\n", encoding="utf-8")
    assert crossings(sample) == ["1: import argparse", "3: print()", "4: sys.stderr.write()"]
