"""Outputs never destroy inputs or devices, and are checked before the work (issue 13 class 3, issue 10 items 4 and 6)."""

from __future__ import annotations

import json
import os
import pathlib
import pty
import shutil
import stat
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from helpers import case, crit, entry
from hypothesis import given, settings
from hypothesis import strategies as st

from btgen_pytrees import batch
from btgen_pytrees.writing import commit

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1 = ROOT / "examples" / "fig1.json"


def cli(*args: str, cwd: pathlib.Path = ROOT, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd)  # fmt: skip


def one_line_exit_2(result: subprocess.CompletedProcess[str], *words: str) -> None:
    assert result.returncode == 2, (result.returncode, result.stdout, result.stderr)
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr
    for word in words:
        assert word in result.stderr, result.stderr


# -- inputs are never overwritten ---------------------------------------------------------------


@pytest.mark.parametrize("option", ["--json", "--junit", "--plot"])
def test_an_output_that_is_the_input_is_refused(tmp_path: pathlib.Path, option: str) -> None:
    path = tmp_path / ("x.json" if option != "--plot" else "x.svg")
    shutil.copy(FIG1, path)
    before = path.read_bytes()
    link = tmp_path / "alias.json"
    link.symlink_to(path)
    for target in (path, link):
        result = cli("run", str(path), option, str(target))
        one_line_exit_2(result, "is one of the input files")
        assert result.stdout == ""  # checked before the run
    assert path.read_bytes() == before


def test_out_dir_inside_an_input_directory_is_refused_for_json_outputs(tmp_path: pathlib.Path) -> None:
    suite = tmp_path / "suite"
    suite.mkdir()
    shutil.copy(FIG1, suite / "x.json")
    before = (suite / "x.json").read_bytes()
    one_line_exit_2(cli("show", str(suite), "--out-dir", str(suite), "-f", "json"), "read as test cases")
    one_line_exit_2(cli("run", str(suite), "--out-dir", str(suite / "reports")), "read as test cases")
    assert (suite / "x.json").read_bytes() == before and not (suite / "reports").exists()
    assert cli("show", str(suite), "--out-dir", str(suite / "trees"), "-f", "ascii").returncode == 0  # .txt is not read


# -- names unique over the batch ----------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["a", "b", "a/b", "c"]),
                          st.sampled_from(["x", "X", "x-2", "x-3", "x-2-2", "y", ".json", "x.report"])),
                min_size=1, max_size=12))  # fmt: skip
def test_output_names_are_unique_over_the_whole_batch(files: list[tuple[str, str]]) -> None:
    paths = [f"{folder}/{stem}.json" for folder, stem in files]
    names = batch.output_names(paths, ".report.json")
    assert len({n.casefold() for n in names}) == len(names), (paths, names)
    assert all(n.endswith(".report.json") and "/" not in n for n in names)


def test_same_stem_in_two_folders_and_a_dash_2_file(tmp_path: pathlib.Path) -> None:
    for folder, stem in (("a", "x"), ("b", "x"), ("c", "x-2")):
        (tmp_path / folder).mkdir()
        shutil.copy(FIG1, tmp_path / folder / f"{stem}.json")
    out = tmp_path / "out"
    result = cli("run", str(tmp_path / "a"), str(tmp_path / "b"), str(tmp_path / "c"), "--out-dir", str(out))
    assert result.returncode == 0, result.stderr
    assert len(list(out.glob("*.report.json"))) == 3
    assert "x-2.report.json" in result.stdout and "c/x-2.json" in result.stdout  # the summary says which came from where


# -- devices, symlinks, staging -----------------------------------------------------------------


def test_devices_are_written_in_place_and_symlinks_followed(tmp_path: pathlib.Path) -> None:
    real = tmp_path / "real.txt"
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    assert cli("show", str(FIG1), "-o", str(link)).returncode == 0
    assert link.is_symlink() and "fig1" in real.read_text()
    result = cli("run", str(FIG1), "--json", "/dev/null", "--junit", "/dev/stdout")
    assert result.returncode == 0, result.stderr
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert "<testsuite " in result.stdout and "fig1: PASS" in result.stderr  # stdout: the document only


def test_commit_is_all_or_nothing(tmp_path: pathlib.Path) -> None:
    good = tmp_path / "good.json"
    with pytest.raises(OSError):
        commit([(str(good), "{}"), (str(tmp_path / "missing" / "x.xml"), "<x/>")])
    assert list(tmp_path.iterdir()) == [] or [p.name for p in tmp_path.iterdir()] == []


def test_a_failing_output_check_leaves_no_other_output(tmp_path: pathlib.Path) -> None:
    report = tmp_path / "r.json"
    result = cli("run", str(FIG1), "--json", str(report), "--junit", str(tmp_path / "no" / "j.xml"))
    one_line_exit_2(result, "does not exist")
    assert not report.exists() and result.stdout == ""


def test_an_all_invalid_batch_makes_no_out_dir(tmp_path: pathlib.Path) -> None:
    (tmp_path / "a.json").write_text("{")
    (tmp_path / "b.json").write_text("[]")
    out = tmp_path.parent / f"{tmp_path.name}-out"
    result = cli("run", str(tmp_path / "a.json"), str(tmp_path / "b.json"), "--out-dir", str(out))
    assert result.returncode == 2 and not out.exists()


def test_non_regular_inputs_are_refused_and_walk_oddities_reported(tmp_path: pathlib.Path) -> None:
    result = cli("validate", "/dev/ptmx", timeout=10)
    one_line_exit_2(result, "not a regular file")
    suite = tmp_path / "suite"
    suite.mkdir()
    shutil.copy(FIG1, suite / "a.json")
    os.mkfifo(suite / "fifo.json")
    (suite / "dangling.json").symlink_to(suite / "nowhere.json")
    result = cli("validate", str(suite), timeout=20)
    assert result.returncode == 2
    assert "fifo.json: /: not a regular file (a pipe or socket)" in result.stderr
    assert "dangling.json: /: cannot read file: dangling symbolic link" in result.stderr
    assert "3 files: 1 ok, 2 invalid" in result.stdout


def test_stdin_is_an_input() -> None:
    result = subprocess.run([sys.executable, "-m", "btgen_pytrees", "validate", "-"], input=FIG1.read_text(),
                            capture_output=True, text=True, timeout=60, cwd=ROOT)  # fmt: skip
    assert result.returncode == 0 and "ok: 6 entries" in result.stdout


def test_a_deep_directory_tree_is_walked(tmp_path: pathlib.Path) -> None:
    """1,000 folders deep: no RecursionError (pathlib's rglob and os.walk recurse in Python 3.11)."""
    levels = [tmp_path]
    for _ in range(1000):
        levels.append(levels[-1] / "d")
        levels[-1].mkdir()
    try:
        assert batch.expand([str(tmp_path)]) == []
        shutil.copy(FIG1, levels[-1] / "bottom.json")
        assert [p.endswith("/d/bottom.json") for p in batch.expand([str(tmp_path)])] == [True]
        result = cli("validate", str(tmp_path))
        assert result.returncode == 0 and "ok: 6 entries" in result.stdout
    finally:  # pytest's own clean-up (shutil.rmtree) recurses: remove the levels bottom-up here
        (levels[-1] / "bottom.json").unlink(missing_ok=True)
        for level in reversed(levels[1:]):
            level.rmdir()


# -- issue 10 item 4: output paths are user errors, checked before the run ---------------------


def test_output_paths_are_user_errors_before_the_run(tmp_path: pathlib.Path) -> None:
    one_line_exit_2(cli("show", str(FIG1), "-o", "newdir/tree.dot", cwd=tmp_path), "newdir does not exist")
    result = cli("run", str(FIG1), "--plot", "newdir/run.png", cwd=tmp_path)
    one_line_exit_2(result, "newdir does not exist")
    assert result.stdout == ""
    one_line_exit_2(cli("run", str(FIG1), "--junit", str(tmp_path)), "is a directory")


def test_o_suffix_chooses_the_format(tmp_path: pathlib.Path) -> None:
    assert cli("show", str(FIG1), "-o", str(tmp_path / "t.json")).returncode == 0
    assert json.loads((tmp_path / "t.json").read_text())["name"] == "fig1"
    assert cli("show", str(FIG1), "-o", str(tmp_path / "t.xml")).returncode == 0
    assert ET.parse(tmp_path / "t.xml").getroot().tag == "root"
    assert cli("show", str(FIG1), "-o", str(tmp_path / "t.dot")).returncode == 0
    assert (tmp_path / "t.dot").read_text().startswith("digraph")
    if shutil.which("dot") or os.environ.get("CI"):
        assert cli("show", str(FIG1), "-o", str(tmp_path / "t.svg")).returncode == 0
        assert (tmp_path / "t.svg").read_text().lstrip().startswith("<?xml")


def test_binary_format_to_a_terminal_is_refused() -> None:
    controller, terminal = pty.openpty()
    try:
        result = subprocess.run([sys.executable, "-m", "btgen_pytrees", str(FIG1), "-f", "png"], stdout=terminal,
                                stderr=subprocess.PIPE, text=True, timeout=60, cwd=ROOT)  # fmt: skip
    finally:
        os.close(terminal)
        os.close(controller)
    assert result.returncode == 2 and "-o FILE.png" in result.stderr


# -- issue 10 item 6: several files -------------------------------------------------------------


def test_show_several_files_prints_the_trees() -> None:
    result = cli("show", str(FIG1), str(ROOT / "examples" / "fig1_failing.json"), "-f", "ascii")
    assert result.returncode == 0
    assert f"==> {FIG1} <==" in result.stdout and result.stdout.count("--> B4") == 2
    assert "characters" not in result.stdout


def test_out_dir_with_one_file_is_honoured(tmp_path: pathlib.Path) -> None:
    assert cli("show", str(FIG1), "--out-dir", str(tmp_path / "t")).returncode == 0
    assert (tmp_path / "t" / "fig1.txt").exists()
    assert cli("run", str(FIG1), "--out-dir", str(tmp_path / "r")).returncode == 0
    assert sorted(p.name for p in (tmp_path / "r").iterdir()) == ["fig1.junit.xml", "fig1.report.json"]


def test_batch_plots_and_one_junit_file(tmp_path: pathlib.Path) -> None:
    pytest.importorskip("matplotlib")
    suite = tmp_path / "suite"
    suite.mkdir()
    shutil.copy(FIG1, suite / "a.json")
    shutil.copy(ROOT / "examples" / "fig1_failing.json", suite / "b.json")
    (suite / "c.json").write_text(json.dumps(case(entry("A", ["Z"]))))
    (suite / "d.json").write_text(json.dumps(case(entry("A"), criteria=[crit("F", "final", "true")])))
    out, junit = tmp_path / "out", tmp_path / "all.xml"
    result = cli("run", str(suite), "--out-dir", str(out), "--plot", "svg", "--junit", str(junit), "-j", "2")
    assert result.returncode == 2, result.stderr
    assert sorted(p.name for p in out.glob("*.svg")) == ["a.svg", "b.svg", "d.svg"]
    root = ET.parse(junit).getroot()
    suites = root.findall("testsuite")
    assert [s.get("file") for s in suites] == [str(suite / n) for n in ("a.json", "b.json", "c.json", "d.json")]
    assert int(root.get("failures", "0")) >= 1 and int(root.get("errors", "0")) >= 1
    assert suites[2].find("testcase/error") is not None  # the invalid file is counted, not dropped


def test_a_failing_write_leaves_no_temporary_file(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A write that fails half-way (disk full) removes its temporary file, for plots too."""
    pytest.importorskip("matplotlib")
    import builtins

    from btgen_pytrees.run import run
    from btgen_pytrees.run.plot import plot_run

    loaded = btgen_pytrees_load(FIG1)
    report = run(loaded)
    real_open = builtins.open

    class Full:
        def __init__(self, fh: object) -> None:
            self.fh = fh

        def __enter__(self) -> "Full":
            return self

        def __exit__(self, *exc: object) -> None:
            self.fh.close()  # type: ignore[attr-defined]

        def write(self, data: bytes) -> int:
            self.fh.write(data[:10])  # type: ignore[attr-defined]
            raise OSError(28, "No space left on device")

    def full_open(path: object, mode: str = "r", *args: object, **kw: object) -> object:
        fh = real_open(path, mode, *args, **kw)  # type: ignore[call-overload]
        return Full(fh) if "w" in mode and ".tmp" in str(path) else fh

    monkeypatch.setattr(builtins, "open", full_open)
    with pytest.raises(OSError):
        plot_run(report, loaded, str(tmp_path / "run.svg"))
    with pytest.raises(OSError):
        commit([(str(tmp_path / "a.json"), "{}"), (str(tmp_path / "b.xml"), "<x/>")])
    assert list(tmp_path.iterdir()) == []


def btgen_pytrees_load(path: pathlib.Path):  # type: ignore[no-untyped-def]
    import btgen_pytrees

    return btgen_pytrees.load(path)
