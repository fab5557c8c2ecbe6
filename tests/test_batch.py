"""Batch mode: many files, worker processes, a summary, the worst exit code; one bad file stops nothing."""

from __future__ import annotations

import json
import pathlib
import shutil
import subprocess
import sys

import pytest
from helpers import case, crit, entry

ROOT = pathlib.Path(__file__).resolve().parent.parent


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True, timeout=120, cwd=ROOT)


@pytest.fixture
def suite(tmp_path: pathlib.Path) -> pathlib.Path:
    d = tmp_path / "suite"
    (d / "nested").mkdir(parents=True)
    shutil.copy(ROOT / "examples" / "fig1.json", d / "a_pass.json")
    shutil.copy(ROOT / "examples" / "fig1_failing.json", d / "b_fail.json")
    (d / "c_invalid.json").write_text(json.dumps(case(entry("A", ["Z"]))))
    (d / "nested" / "d_broken.json").write_text("{not json")
    (d / "nested" / "e_pass.json").write_text(json.dumps(case(entry("A"), criteria=[crit("F", "final", "true")])))
    (d / "notes.txt").write_text("not a test case")
    return d


def test_run_batch_summary_outputs_and_worst_exit_code(suite: pathlib.Path, tmp_path: pathlib.Path) -> None:
    out = tmp_path / "out"
    result = cli("run", str(suite), "--jobs", "2", "--out-dir", str(out))
    assert result.returncode == 2  # worst of pass, fail, invalid
    rows = {line.split()[0]: line.split()[1] for line in result.stdout.splitlines() if line.startswith(str(suite))}
    assert rows == {
        f"{suite}/a_pass.json": "ok", f"{suite}/b_fail.json": "FAIL", f"{suite}/c_invalid.json": "INVALID",
        f"{suite}/nested/d_broken.json": "INVALID", f"{suite}/nested/e_pass.json": "ok",
    }  # fmt: skip
    assert "5 files: 2 ok, 1 fail, 2 invalid" in result.stdout
    assert f"{suite}/c_invalid.json: /execute/0/after/0: unknown id 'Z'" in result.stderr
    assert "invalid JSON at line 1" in result.stderr and "Traceback" not in result.stderr
    assert "\r" not in result.stderr  # no progress bar when stderr is not a terminal
    assert sorted(p.name for p in out.iterdir()) == sorted(
        f"{n}.{kind}" for n in ("a_pass", "b_fail", "e_pass") for kind in ("report.json", "junit.xml"))
    assert json.loads((out / "b_fail.report.json").read_text())["verdict"] == "fail"


def test_show_batch_writes_one_file_each(suite: pathlib.Path, tmp_path: pathlib.Path) -> None:
    out = tmp_path / "trees"
    result = cli("show", str(suite / "a_pass.json"), str(suite / "nested" / "e_pass.json"), "-f", "json", "--out-dir", str(out))
    assert result.returncode == 0, result.stderr
    assert json.loads((out / "a_pass.json").read_text())["name"] == "fig1"
    assert json.loads((out / "e_pass.json").read_text())["name"] == "t"


def test_same_stem_twice_gets_distinct_outputs(suite: pathlib.Path, tmp_path: pathlib.Path) -> None:
    other = tmp_path / "other"
    other.mkdir()
    shutil.copy(suite / "a_pass.json", other / "a_pass.json")
    out = tmp_path / "out"
    assert cli("show", str(suite / "a_pass.json"), str(other / "a_pass.json"), "--out-dir", str(out)).returncode == 0
    assert sorted(p.name for p in out.iterdir()) == ["a_pass-2.txt", "a_pass.txt"]


def test_validate_directory(suite: pathlib.Path) -> None:
    result = cli("validate", str(suite), "-j", "2")
    assert result.returncode == 2
    assert f"{suite}/a_pass.json: ok" in result.stdout and "5 files: 3 ok, 2 invalid" in result.stdout
    assert cli("validate", str(suite / "nested" / "e_pass.json"), str(suite / "a_pass.json")).returncode == 0


def test_single_file_options_are_refused_in_batch(suite: pathlib.Path) -> None:
    result = cli("run", str(suite), "--json", "r.json")
    assert result.returncode == 2 and "take one file" in result.stderr


def test_in_process_and_pool_agree(suite: pathlib.Path) -> None:
    from btgen_pytrees import batch
    from btgen_pytrees.parallel import process

    files = batch.expand([str(suite)])
    args = [((), None)] * len(files)
    one = process(batch.job_run, args, files, workers=1)
    two = process(batch.job_run, args, files, workers=2)
    assert [(o.path, o.code, o.summary) for o in one] == [(o.path, o.code, o.summary) for o in two]
