"""The README says true things (issue 23 item 18): exit codes, the batch example, install lines,
where its pictures come from, and a suite time that was measured (with the machine named)."""

from __future__ import annotations

import pathlib
import re
import tomllib

from btgen_pytrees.errors import ExitCode

ROOT = pathlib.Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def flat(text: str) -> str:
    return " ".join(text.split())


def test_exit_code_line_lists_every_code() -> None:
    line = flat(README[README.index("Exit codes:"):][:400])
    for code, meaning in ((ExitCode.OK, "pass"), (ExitCode.FAIL, "fail, timeout or error"), (ExitCode.INVALID, "invalid"),
                          (ExitCode.INTERNAL, "internal error"), (130, "Ctrl-C"), (143, "SIGTERM")):  # fmt: skip
        assert str(code) in line and meaning in line, (code, line)


def test_batch_example_names_what_exists() -> None:
    example = flat(README)[flat(README).index("**Batch mode**"):][:400]
    command = re.search(r"`(python -m btgen_pytrees run [^`]+)`", example)
    assert command
    words = command.group(1).split()
    folder, plugin = words[4], words[words.index("--plugin") + 1]
    assert (ROOT / folder).is_dir() and list((ROOT / folder).rglob("*.json")), folder
    assert (ROOT / plugin).is_file() and "def register(" in (ROOT / plugin).read_text(encoding="utf-8")


def test_install_lines_work_from_a_checkout() -> None:
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for line in re.findall(r"pip install [^`\n]*", doc.read_text(encoding="utf-8")):
            assert "btgen_pytrees[" not in line or "plot" in line or "parquet" in line, (doc.name, line)  # hints only
            for group in re.findall(r"'\.\[([a-z,]+)\]'", line):
                assert all(name in extras for name in group.split(",")), (doc.name, line)
    scaling = (ROOT / "docs" / "scaling.md").read_text(encoding="utf-8")
    assert "pip install -e '.[dask]'" in scaling


def test_pictures_are_made_by_a_script_in_the_repo() -> None:
    script = (ROOT / "docs" / "pictures.py").read_text(encoding="utf-8")
    assert "python docs/pictures.py" in flat(README)
    for picture in re.findall(r"\]\((docs/images/[^)]+)\)", README):
        assert (ROOT / picture).is_file(), picture
    for name in ("fig1-replay.png", "fig1-run.svg"):  # the README's run pictures: remade by the script, never stale
        assert f"docs/images/{name}" in README and f'"{name}"' in script


def test_the_suite_time_is_a_measurement() -> None:
    line = next(ln for ln in README.splitlines() if ln.startswith("python -m pytest ") and "see below for its time" in ln)
    assert "under a minute" not in line
    assert re.search(r"measured", README[README.index(line):][:800]) and "time python -m pytest" in README
