"""Docs cannot rot: every code block in README.md and docs/*.md is checked.

* ``python`` blocks with ``>>>`` prompts run as doctests (``--doctest-glob='*.md'``
  in pyproject.toml); ``python`` blocks without prompts are executed here;
* ``json`` blocks must parse, and those that are test cases must load;
* ``toml`` blocks must parse.
Other languages (``sh``, ``text``, ``jsonc``, ``xml``) are shown, not run.
"""

from __future__ import annotations

import json
import pathlib
import re
import pytest

import btgen_pytrees

ROOT = pathlib.Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^( *)```(\w*)\n(.*?)^\1```", re.S | re.M)
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def blocks(lang: str) -> list[tuple[str, str]]:
    found = []
    for path in DOCS:
        for indent, language, body in FENCE.findall(path.read_text(encoding="utf-8")):
            if language == lang:
                body = "\n".join(line[len(indent):] for line in body.splitlines())
                found.append((f"{path.name}:{len(found)}", body))
    return found


@pytest.mark.parametrize("where, body", blocks("python"))
def test_python_blocks(where: str, body: str, monkeypatch: pytest.MonkeyPatch) -> None:
    if ">>>" in body:
        return  # a doctest, collected by pytest's doctest-glob
    monkeypatch.chdir(ROOT)
    exec(compile(body, where, "exec"), {"__name__": "__docs__"})  # noqa: S102 - our own docs


@pytest.mark.parametrize("where, body", blocks("json"))
def test_json_blocks(where: str, body: str) -> None:
    data = json.loads(body)
    if isinstance(data, dict) and "execute" in data:
        btgen_pytrees.load(data)


@pytest.mark.parametrize("where, body", blocks("toml"))
def test_toml_blocks(where: str, body: str) -> None:
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    tomllib.loads(body)


def test_docs_exist() -> None:
    names = {p.name for p in DOCS}
    assert {"README.md", "format.md", "algorithms.md", "embedding.md"} <= names


LINK = re.compile(r"\]\(([^)\s]+)\)")
FENCED = re.compile(r"^( *)```.*?^\1```", re.S | re.M)


def anchors(path: pathlib.Path) -> set[str]:
    """The anchors GitHub gives a Markdown file's headings (code blocks left out)."""
    seen: dict[str, int] = {}
    found = set()
    for line in FENCED.sub("", path.read_text(encoding="utf-8")).splitlines():
        if not line.startswith("#"):
            continue
        slug = re.sub(r"[^\w\- ]", "", line.lstrip("#").strip().lower()).replace(" ", "-")
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        found.add(slug if count == 0 else f"{slug}-{count}")
    return found


def test_relative_links_and_their_anchors_exist() -> None:
    """Every relative link in README.md and docs/*.md names a file that exists, and its #anchor a heading there."""
    broken = []
    for path in DOCS:
        for target in LINK.findall(FENCED.sub("", path.read_text(encoding="utf-8"))):
            if re.match(r"[a-z]+:", target):
                continue  # http:, https:, mailto:
            name, _, anchor = target.partition("#")
            linked = (path.parent / name).resolve() if name else path
            if not linked.exists():
                broken.append(f"{path.name}: {target} (no such file)")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
                broken.append(f"{path.name}: {target} (no such heading)")
    assert not broken, "\n".join(broken)
