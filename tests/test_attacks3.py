"""Third round of attacks (issue 35, items 6-11 and 14): a plugin deaf to signals, outputs on a full
device, user code that closes stdout, kills its parent or changes directory, an executor that would be
ignored, a reason that names criteria that did not count, expanded cases all named alike, and values
echoed in forms the user never wrote.

Each test performs the attack and checks the promise. Signals, closed streams, a dead parent and file
size limits need the real CLI process (a subprocess, with a scratch directory as its working
directory); the rest call :func:`btgen_pytrees.cli.main` in this process, which is cheaper.
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import resource
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from typing import Any

import py_trees
import pytest
from helpers import case, crit, entry, run_case

import btgen_pytrees
from btgen_pytrees import cli
from btgen_pytrees.falsify.sampler import available
from btgen_pytrees.render import iter_text_tree
from btgen_pytrees.run import plot
from btgen_pytrees.supervise import STOP_GRACE

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1 = ROOT / "examples" / "fig1.json"
FAILING = ROOT / "examples" / "fig1_failing.json"
SWEEP = ROOT / "examples" / "fig1_sweep.json"

PLUGINS = '''
import os, signal, sys, time
import py_trees
from py_trees.common import Status

if os.environ.get("ATTACK_MOVE"):  # change directory at import
    os.chdir(os.environ["ATTACK_MOVE"])


class Leaf(py_trees.behaviour.Behaviour):
    def __init__(self, entry, env):
        super().__init__(name=entry.name)
        self.how = entry.action

    def update(self):
        if self.how == "deaf":  # ignore SIGTERM and SIGINT, say it is running, run forever
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            with open(os.environ["ATTACK_READY"], "w") as fh:
                fh.write(str(os.getpid()))
            time.sleep(0.05)
            return Status.RUNNING
        if self.how == "slow":  # say it is running (signals as they come), run forever
            with open(os.environ["ATTACK_READY"], "w") as fh:
                fh.write(str(os.getpid()))
            time.sleep(0.05)
            return Status.RUNNING
        if self.how == "close":  # close every standard stream, then fail
            sys.stdout.close()
            sys.stderr.close()
            os.close(1)
            return Status.FAILURE
        if self.how == "parricide":  # kill the CLI's process, then carry on a little
            os.kill(os.getppid(), signal.SIGKILL)
            time.sleep(1)
            return Status.FAILURE
        if self.how == "move":  # change directory while running
            os.chdir(os.environ["ATTACK_MOVE_AGAIN"])
        return Status.SUCCESS


def register(registry):
    for action in ("deaf", "slow", "close", "parricide", "move"):
        registry.register(action, lambda e, env: Leaf(e, env), kind="behavior")
'''


def cli_process(cwd: pathlib.Path, *args: str, **kw: Any) -> subprocess.CompletedProcess[str]:
    kw.setdefault("capture_output", "stdout" not in kw)
    if "stdout" in kw:
        kw.setdefault("stderr", subprocess.PIPE)
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], text=True, timeout=120, cwd=cwd, **kw)


def write(path: pathlib.Path, data: Any) -> pathlib.Path:
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


@pytest.fixture
def work(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> pathlib.Path:
    """A scratch folder (the working directory) with the plugin, a case per attack and fig1's cases."""
    write(tmp_path / "attack.py", PLUGINS)
    for action in ("deaf", "slow", "close", "parricide", "move"):
        write(tmp_path / f"{action}.json", case(entry("A", action=action), name=action, timeout=100000, tick=0.1))
    for source in (FIG1, FAILING, SWEEP):
        write(tmp_path / source.name, source.read_text())
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "again").mkdir()
    monkeypatch.chdir(tmp_path)
    return tmp_path


def files(folder: pathlib.Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


# -- 35.6: a supervised run whose plugin ignores SIGTERM and SIGINT is stopped ------------------------


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_plugin_deaf_to_signals_is_killed_after_the_grace_period(work: pathlib.Path, signum: int) -> None:
    ready = work / "ready"
    process = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", "deaf.json", "--plugin", "attack.py",
                                "--max-work", "1e12"], cwd=work, env=dict(os.environ, ATTACK_READY=str(ready)),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    deadline = time.monotonic() + 60
    while not (ready.exists() and ready.read_text()) and time.monotonic() < deadline:
        time.sleep(0.05)
    child = int(ready.read_text())
    time.sleep(0.2)
    began = time.monotonic()
    process.send_signal(signum)  # to the CLI's process alone: it passes it on, the plugin ignores it
    out, err = process.communicate(timeout=60)
    took = time.monotonic() - began
    assert process.returncode == 128 + signum, err
    assert f"interrupted by {signal.Signals(signum).name}" in err and "killed" in err and "Traceback" not in err
    assert STOP_GRACE - 0.5 < took < STOP_GRACE + 20  # escalated after the grace period, not 13 minutes later
    with pytest.raises(ProcessLookupError):
        os.kill(child, 0)  # the command's process is gone, not left running


# -- 35.8: user code that closes the streams, kills the CLI's process, changes directory --------------


def test_a_plugin_closing_stdout_and_stderr_does_not_turn_a_failing_run_into_exit_3(work: pathlib.Path) -> None:
    result = cli_process(work, "run", "close.json", "--plugin", "attack.py")
    assert result.returncode == 1, result.stderr
    assert "close: FAIL" in result.stdout and "internal error" not in result.stdout + result.stderr
    document = cli_process(work, "run", "close.json", "--plugin", "attack.py", "--json", "-")
    assert document.returncode == 1 and json.loads(document.stdout)["verdict"] == "fail"


def test_a_plugin_replacing_the_streams_at_import_does_not_stop_a_sweep(work: pathlib.Path) -> None:
    write(work / "nulls.py", "import sys\nsys.stdout = sys.stderr = None\n\ndef register(registry):\n    pass\n")
    result = cli_process(work, "run", "fig1_sweep.json", "--plugin", "nulls.py", "--jobs", "1")
    assert result.returncode == 1 and "28 variations of top_speed x limit" in result.stdout, result.stderr
    assert "internal error" not in result.stderr


def test_a_plugin_killing_the_cli_leaves_no_orphan_printing_a_traceback(work: pathlib.Path) -> None:
    # run() returns once every process holding the pipes has ended: the orphan too
    result = cli_process(work, "run", "parricide.json", "--plugin", "attack.py", "--json", "/dev/stdout")
    assert result.returncode == -signal.SIGKILL
    assert "Traceback" not in result.stderr and "BrokenPipeError" not in result.stderr, result.stderr


def test_outputs_land_where_they_were_checked_whatever_directory_user_code_moves_to(work: pathlib.Path) -> None:
    env = dict(os.environ, ATTACK_MOVE=str(work / "elsewhere"), ATTACK_MOVE_AGAIN=str(work / "again"))
    one = cli_process(work, "run", "move.json", "--plugin", "attack.py", "--json", "m.json", "--junit", "m.xml", env=env)
    assert one.returncode == 0, one.stderr
    batch = cli_process(work, "run", "move.json", "fig1.json", "move.json", "--plugin", "attack.py", "--out-dir", "out",
                        "--junit", "all.xml", "--jobs", "1", env=env)  # fmt: skip
    assert batch.returncode == 0, batch.stdout + batch.stderr
    assert files(work / "elsewhere") == files(work / "again") == []
    assert {"m.json", "m.xml", "all.xml", "out/move.report.json", "out/fig1.report.json", "out/move-2.report.json"} <= set(files(work))


# -- 35.7: an output on a full device, or a target that refuses its data when written ------------------


@pytest.mark.parametrize(("command", "code"), [
    (("run", "fig1_failing.json", "--json", "/dev/full"), 1),
    (("run", "fig1.json", "--junit", "/dev/full", "--json", "r.json"), 0),
    (("run", "fig1_failing.json", "--json", "/proc/self/oom_score_adj"), 1),  # procfs: takes a number, not JSON
    (("run", "fig1_sweep.json", "--json", "/dev/full"), 1),
    (("run", "fig1.json", "fig1_failing.json", "--out-dir", "out", "--junit", "/dev/full", "--jobs", "1"), 1),
])  # fmt: skip
def test_an_output_that_fails_when_written_keeps_the_verdict(work: pathlib.Path, capsys: pytest.CaptureFixture[str],
                                                             command: tuple[str, ...], code: int) -> None:  # fmt: skip
    target = command[command.index("/dev/full") if "/dev/full" in command else -1]
    assert cli.main(list(command)) == code
    out, err = capsys.readouterr()
    assert re.search(r"FAIL|PASS|variations of|2 files", out), out  # the verdict, printed all the same
    assert f"btgen_pytrees: {target}: cannot write: " in err and "internal error" not in err, err
    assert not [name for name in files(work) if ".tmp" in name]


def test_a_batch_row_says_which_outputs_were_not_written(work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    (work / "out").mkdir()
    (work / "out" / "fig1_failing.report.json").symlink_to("/dev/full")  # a regular-looking target on a full device
    assert cli.main(["run", "fig1.json", "fig1_failing.json", "--out-dir", "out", "--jobs", "1"]) == 1
    out = capsys.readouterr().out
    assert re.search(r"fig1_failing\.json +FAIL .*not written: .*cannot write: No space left on device", out), out


def test_a_command_that_ran_nothing_exits_2_when_its_output_fails(work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["show", "fig1.json", "-o", "/dev/full", "-f", "json"]) == 2
    assert capsys.readouterr().err == "btgen_pytrees: /dev/full: cannot write: No space left on device\n"


def test_stdout_on_a_full_device_is_reported_and_the_verdict_is_the_exit_code(work: pathlib.Path) -> None:
    with open("/dev/full", "w") as full:
        failing = cli_process(work, "run", "fig1_failing.json", stdout=full)
        passing = cli_process(work, "run", "fig1.json", "--json", "-", stdout=full)
    for result, code in ((failing, 1), (passing, 0)):
        assert result.returncode == code, result.stderr
        assert result.stderr.strip().splitlines()[-1] == "btgen_pytrees: standard output: cannot write: No space left on device"
        assert "Traceback" not in result.stderr and "Exception ignored" not in result.stderr


def test_an_interrupted_batch_on_a_full_device_still_exits_130(work: pathlib.Path) -> None:
    # the summary of an interrupted batch cannot be printed: that is said, and the exit is the signal's, not 2
    ready = work / "ready"
    with open("/dev/full", "w") as full:
        process = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", "fig1.json", "slow.json", "--jobs", "1",
                                    "--plugin", "attack.py", "--max-work", "1e12"], cwd=work, stdout=full,
                                   stderr=subprocess.PIPE, env=dict(os.environ, ATTACK_READY=str(ready)), text=True)  # fmt: skip
        deadline = time.monotonic() + 60
        while not (ready.exists() and ready.read_text()) and time.monotonic() < deadline:
            time.sleep(0.05)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "btgen_pytrees: standard output: cannot write: No space left on device" in err
    assert err.rstrip().endswith("interrupted by SIGINT; files not run are marked NOT RUN") and "Traceback" not in err


def test_a_full_disk_leaves_no_file_and_keeps_the_verdict(work: pathlib.Path) -> None:
    def small_files() -> None:  # 2 KB per file: the report does not fit, as on a full disk (EFBIG, not a signal)
        resource.setrlimit(resource.RLIMIT_FSIZE, (2048, 2048))

    result = cli_process(work, "run", "fig1_failing.json", "--json", "r.json", "--junit", "r.xml", preexec_fn=small_files)
    assert result.returncode == 1 and "fig1_failing: FAIL" in result.stdout, result.stderr
    assert "btgen_pytrees: r.json: cannot write: File too large" in result.stderr and "internal error" not in result.stderr
    assert not [name for name in files(work) if name.startswith("r.")]  # all or nothing: no r.xml, no r.json.tmpPID


# -- 35.9: an executor the command would ignore ------------------------------------------------------


@pytest.mark.parametrize("options", [
    ("fig1.json", "--executor", "dask"),
    ("fig1.json", "--executor", "dask", "--scheduler", "garbage"),
    ("fig1.json", "--executor", "dask", "--scheduler", "tcp://127.0.0.1:1"),
    ("fig1_sweep.json", "--set", "top_speed=30", "--executor", "dask", "--scheduler", "tcp://127.0.0.1:1"),
])  # fmt: skip
def test_one_case_on_dask_is_a_usage_error(work: pathlib.Path, capsys: pytest.CaptureFixture[str], options: tuple[str, ...]) -> None:
    assert cli.main(["run", *options, "--json", "r.json"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and not (work / "r.json").exists()
    assert err.startswith("btgen_pytrees: --") and "dask" in err and len(err.splitlines()) == 1, err


# -- 35.10: the one-line reason names only criteria that counted -------------------------------------

OR_GROUP = case(
    entry("A", action="set", signal="x", value=5), name="or", timeout=3, signals={"x": 0},
    criteria=[crit("R1", "record", "x < 10"), crit("R2", "record", "x < 2"), crit("F1", "final", "x == 7")],
    relation={"record": "||", "others": "&&"},
)


def test_the_reason_leaves_out_a_criterion_whose_or_group_passed(work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = run_case(OR_GROUP)
    assert [o.verdict for o in report.oracles] == ["pass", "fail", "fail"]  # R2 failed, but its || group passed
    assert report.message == "F1 failed"
    assert not any("R2" in line for line in report.explanation)  # as the explanation already said
    write(work / "or.json", OR_GROUP)
    assert cli.main(["run", "or.json", "--json", "r.json", "--plot", "r.svg"]) == 1
    assert json.loads((work / "r.json").read_text())["message"] == "F1 failed"
    assert "or: FAIL after 0 s (1 tick) - F1 failed\n" in capsys.readouterr().out
    svg = (work / "r.svg").read_text()
    assert "F1 failed" in svg and "R2 failed" not in svg


def test_a_sweep_row_leaves_out_a_criterion_whose_or_group_passed(work: pathlib.Path) -> None:
    data = {**OR_GROUP, "parameters": {"v": 5}, "variations": {"v": [5, 7]}}
    data["execute"] = [entry("A", action="set", signal="x", value="$v")]
    write(work / "or_sweep.json", data)
    assert cli.main(["run", "or_sweep.json", "--json", "s.json", "--jobs", "1"]) == 1
    rows = json.loads((work / "s.json").read_text())["rows"]
    failing = [r for r in rows if r["verdict"] == "fail"]
    assert failing and all("R2" not in r["message"] and "F1" in r["message"] for r in failing), failing


# -- 35.11: expanded cases and counterexamples carry their label in their name ------------------------


def test_expanded_cases_are_named_after_their_variation(work: pathlib.Path) -> None:
    data = json.loads(SWEEP.read_text())
    data["variations"] = {"top_speed": [20, 40], "limit": [25, 35]}
    write(work / "small.json", data)
    assert cli.main(["expand", "small.json", "--out-dir", "cases"]) == 0
    written = sorted((work / "cases").iterdir())
    names = [json.loads(p.read_text())["name"] for p in written]
    assert names == [p.stem for p in written] and len(set(names)) == 4
    assert all(re.fullmatch(r"fig1_sweep\[top_speed=\d+,limit=\d+\]", n) for n in names), names
    assert cli.main(["run", "cases", "--out-dir", "reports", "--junit", "all.xml", "--jobs", "1"]) == 1
    suites = [s.get("name") for s in ET.parse(work / "all.xml").getroot().iter("testsuite")]
    assert sorted(suites) == sorted(names)  # a suite per case, each told apart


@pytest.mark.skipif(not available() and not os.environ.get("CI"),
                    reason="the 'search' extra is not installed (pip install -e '.[search]'; CI installs it)")  # fmt: skip
def test_counterexample_files_are_named_after_their_point_and_a_budget_of_1e1_is_10(
        work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    data = json.loads(SWEEP.read_text())
    data["variations"] = {"top_speed": {"from": 10, "to": 40, "step": 5}}
    data["search"] = {"budget": 1e1, "method": "sobol"}
    write(work / "search.json", data)
    assert cli.main(["falsify", "search.json", "--jobs", "1", "--out-dir", "found"]) == 1
    out = capsys.readouterr().out
    assert "budget 10," in out and "(10 runs)" in out and "10.0" not in out, out
    cases = sorted((work / "found").glob("*.json"))
    assert cases and all(json.loads(p.read_text())["name"] == p.stem for p in cases), [p.name for p in cases]
    assert all(p.stem.startswith("fig1_sweep[top_speed=") for p in cases)


@pytest.mark.parametrize(("args", "said"), [
    (["falsify", "fig1_sweep.json", "--budget", "2.5"], "argument --budget: '2.5' is not a whole number"),
    (["falsify", "fig1_sweep.json", "--seed", "1e400"], "argument --seed: '1e400' is not a whole number"),
    (["run", "fig1.json", "--max-work", "2.5e0"], "argument --max-work: '2.5e0' is not a whole number"),
    (["run", "fig1.json", "--jobs", "nan"], "argument --jobs/-j: 'nan' is not a whole number"),
    (["validate", "fig1_sweep.json", "--max-variations", "1.5"], "argument --max-variations: '1.5' is not a whole number"),
])  # fmt: skip
def test_a_count_on_the_command_line_is_a_whole_number_as_in_a_case_file(
        work: pathlib.Path, capsys: pytest.CaptureFixture[str], args: list[str], said: str) -> None:  # fmt: skip
    # a search block's "budget": 1e1 is 10 (above); so is --budget 1e1, and 2.5 is refused, never cut to 2
    assert cli.main(args) == 2
    assert f"btgen_pytrees: error: {said}" in capsys.readouterr().err


@pytest.mark.skipif(not available() and not os.environ.get("CI"),
                    reason="the 'search' extra is not installed (pip install -e '.[search]'; CI installs it)")  # fmt: skip
def test_a_budget_of_1e1_on_the_command_line_is_10(work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["falsify", "fig1_sweep.json", "--budget", "1e1", "--seed", "0e0", "--method", "sobol",
                     "--jobs", "1"]) in (0, 1)  # fmt: skip
    out = capsys.readouterr().out
    assert "budget 10," in out and "10.0" not in out, out
    assert cli.main(["validate", "fig1_sweep.json", "--max-variations", "1e1"]) == 2  # 28 variations > 10
    assert "10" in capsys.readouterr().err


# -- 35.14: values echoed as they were written --------------------------------------------------------


@pytest.mark.parametrize(("value", "said"), [
    ("1e400", "--set top_speed=1e400: parameter 'top_speed': number too large (beyond float range"),
    ("1e301", "--set top_speed=1e301: parameter 'top_speed': number too large (1e+301; the limit is ±1e+300)"),
    ("-" + "9" * 400, "--set top_speed=-9999999999999999999…9999999999999999999: parameter 'top_speed': number too large"),
    ("1" * 5000, "--set top_speed=11111111111111111111…1111111111111111111: parameter 'top_speed': number too large"),
    ("x" * 5000, "--set top_speed=xxxxxxxxxxxxxxxxxxxx…xxxxxxxxxxxxxxxxxxx: 'xxxxxxxxxxxxxxxxxxxx…xxxxxxxxxxxxxxxxxxx' is not a number"),
])  # fmt: skip
def test_set_values_are_echoed_as_typed_and_shortened(work: pathlib.Path, capsys: pytest.CaptureFixture[str],
                                                      value: str, said: str) -> None:  # fmt: skip
    assert cli.main(["run", "fig1_sweep.json", "--set", f"top_speed={value}"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"btgen_pytrees: {said}") and len(err.splitlines()) == 1, err
    assert "Infinity" not in err and "/parameters/" not in err and len(err) < 250


def test_a_params_file_out_of_range_is_reported_in_that_file(work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(work / "p.json", '{"top_speed": 1e301}')
    assert cli.main(["run", "fig1_sweep.json", "--params", "p.json"]) == 2
    assert capsys.readouterr().err == ("btgen_pytrees: p.json: /top_speed: parameter 'top_speed': number too large "
                                       "(1e+301; the limit is ±1e+300)\n")  # fmt: skip


def test_schema_messages_show_json_values(work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    write(work / "null.json", "null")
    write(work / "odd.json", {"name": True, "execute": [{"id": None, "kind": "behavior", "action": "hold"}],
                              "oracle": {"criteria": [{"id": "R", "type": None, "expect": "x > 0"}]}})  # fmt: skip
    assert cli.main(["validate", "null.json", "odd.json"]) == 2
    err = capsys.readouterr().err
    assert "null.json: /: null is not of type 'object'" in err
    assert "odd.json: /name: true is not of type 'string'" in err and "/execute/0/id: null is not of type 'string'" in err
    assert not re.search(r"\b(None|True|False)\b", err), err


def test_the_sweep_summary_rounds_its_margins(work: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = case(entry("A", action="set", signal="x", value="$v"), name="round", timeout=1, signals={"x": 0},
                criteria=[crit("R", "record", "x <= 1.1")], parameters={"v": 3.3}, variations={"v": [3.3, 0.1]})  # fmt: skip
    write(work / "round.json", data)
    assert cli.main(["run", "round.json", "--json", "s.json", "--jobs", "1"]) == 1
    out = capsys.readouterr().out
    assert "(margin -2.2)" in out and "2.1999999999999997" not in out, out
    margins = [r["margin"] for r in json.loads((work / "s.json").read_text())["rows"]]
    assert -2.1999999999999997 in margins  # the report keeps the exact value


def test_one_hidden_node_is_one_more_node() -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(str(FIG1)))
    counts = []
    for depth in range(10):
        text = "".join(iter_text_tree(root, max_depth=depth))
        assert not re.search(r"\b1 more nodes\b", text)
        counts += [int(n) for n in re.findall(r"(\d+) more nodes?\b", text)]
        for n, word in re.findall(r"(\d+) more (nodes?)\b", text):
            assert word == ("node" if n == "1" else "nodes")
    assert 1 in counts and any(n > 1 for n in counts)  # both forms were seen


def test_the_documented_blackboard_keys_are_the_keys_a_run_writes() -> None:
    data = case(entry("A", action="set", signal="x", value=5), name="keys", timeout=1, signals={"x": 0},
                criteria=[crit("R1", "record", "x < 2"), crit("R2", "record", "x < 3")], relation={"record": "||"})  # fmt: skip
    root = btgen_pytrees.generate(btgen_pytrees.load(data))
    namespace = root.btgen_env.namespace
    tree = py_trees.trees.BehaviourTree(root)
    for _ in range(12):
        tree.tick()
        if root.status != py_trees.common.Status.RUNNING:
            break
    kinds = {key[len(namespace) + 1:].split("/")[0] for key in py_trees.blackboard.Blackboard.storage if key.startswith(namespace + "/")}
    root.btgen_env.release()
    root.btgen_env.clear()
    assert "failed_count" in kinds, kinds
    semantics = (ROOT / "docs" / "semantics.md").read_text()
    embedding = (ROOT / "docs" / "embedding.md").read_text()
    for kind in kinds:
        assert f"<ns>/{kind}" in semantics and f"`{kind}" in embedding, kind


def test_limits_md_states_the_plots_limits_as_the_code_has_them() -> None:
    limits = (ROOT / "docs" / "limits.md").read_text()
    assert "MAX_SIGNALS" not in limits  # no such limit: signals are drawn in panels
    assert f"at most {plot.MAX_PANELS} panels of signals (`plot.MAX_PANELS`) of {plot.MAX_PER_PANEL}" in limits
    assert f"{plot.MAX_ROWS} timeline rows (`plot.MAX_ROWS`" in limits
