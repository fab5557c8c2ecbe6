"""Usage errors are exit 2 with one line, never "internal error" (issue 13 class 5)."""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import pytest
from helpers import case, entry

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1 = str(ROOT / "examples" / "fig1.json")


def cli(*args: str, **kw: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=120, cwd=ROOT, **kw)  # type: ignore[call-overload]  # fmt: skip


def usage_error(result: subprocess.CompletedProcess[str], word: str) -> None:
    assert result.returncode == 2, (result.returncode, result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and word in lines[0], result.stderr
    assert "internal error" not in result.stderr and "Traceback" not in result.stderr


@pytest.mark.parametrize("jobs", ["0", "-1", "65", "3000"])
@pytest.mark.parametrize("command", ["validate", "show", "run"])
def test_jobs_out_of_range(command: str, jobs: str) -> None:
    usage_error(cli(command, FIG1, FIG1, "--jobs", jobs), "--jobs")


def test_jobs_at_the_cap_starts_no_more_workers_than_files() -> None:
    result = cli("validate", FIG1, FIG1, "--jobs", "64")
    assert result.returncode == 0 and "2 files: 2 ok" in result.stdout


@pytest.mark.parametrize("depth", ["-1", "-100", "x"])
def test_max_depth_must_be_a_non_negative_whole_number(depth: str) -> None:
    usage_error(cli("show", FIG1, "--max-depth", depth, "-f", "dot"), "--max-depth")


@pytest.mark.parametrize("indent", ["-1", "17", "x", "1.5", "", "2e3", "None2", "99999999999999999999"])
def test_indent_must_be_spaces_or_none(indent: str) -> None:
    usage_error(cli("show", FIG1, "-f", "json", "--indent", indent), "--indent")


@pytest.mark.parametrize("fmt", ["unicode", "dot", "matrix"])
def test_indent_applies_to_json_only(fmt: str, tmp_path: pathlib.Path) -> None:
    usage_error(cli("show", FIG1, "-f", fmt, "--indent", "2"), "--indent applies to the json format only")
    usage_error(cli("show", FIG1, FIG1, "--out-dir", str(tmp_path / "out"), "-f", fmt, "--indent", "none"),
                "--indent applies to the json format only")  # fmt: skip
    usage_error(cli("show", FIG1, "-o", str(tmp_path / "t.txt"), "--indent", "0"), "not unicode")
    assert list(tmp_path.iterdir()) == []


def test_out_dir_that_is_a_file_or_cannot_be_made(tmp_path: pathlib.Path) -> None:
    afile = tmp_path / "afile"
    afile.write_text("x")
    usage_error(cli("run", FIG1, "--out-dir", str(afile)), "not a directory")
    usage_error(cli("run", FIG1, "--out-dir", str(afile / "sub")), "cannot be created")
    assert afile.read_text() == "x"


def test_argparse_errors_are_one_line() -> None:
    usage_error(cli("show"), "FILE")
    usage_error(cli(FIG1, "--nope"), "--nope")
    usage_error(cli("run", FIG1, "--plot"), "--plot")


def test_closed_stdout_is_a_usage_error() -> None:
    result = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", FIG1], stdout=None, stderr=subprocess.PIPE,
                            text=True, timeout=60, cwd=ROOT, pass_fds=(), preexec_fn=lambda: os.close(1))  # fmt: skip
    assert result.returncode == 2 and "standard output is closed" in result.stderr and "Traceback" not in result.stderr


def test_a_leaf_returning_none_is_that_entrys_error(tmp_path: pathlib.Path) -> None:
    (tmp_path / "noneplug.py").write_text(
        "import py_trees\n"
        "class L(py_trees.behaviour.Behaviour):\n"
        "    def update(self):\n"
        "        return None\n"
        "def register(r):\n"
        "    r.register('none', lambda e, env: L(e.name), kind='behavior')\n"
    )
    path = tmp_path / "c.json"
    path.write_text(json.dumps(case(entry("A"), entry("N", ["A"], action="none"), timeout=5)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT)]))
    result = cli("run", str(path), "--plugin", "noneplug", "--json", str(tmp_path / "r.json"), env=env)
    assert result.returncode == 1
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["verdict"] == "error" and report["message"].startswith("N raised LeafError")
    assert report["ticks"] == 11  # the run ended at the first such tick
    assert "invalid status" not in result.stdout + result.stderr  # py_trees' per-tick log line
