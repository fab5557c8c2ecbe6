"""Second round of attacks (issue 20; issue 23 items 12-16): no green by accident, nothing overwritten,
clear errors, outputs that stay valid, a command line that says true things.

Each test is the attack, then the promise checked: the exit code, the files left untouched, the
output still parseable. The CLI runs in a subprocess with a scratch directory as its working
directory, so the code under test is the one on ``PYTHONPATH`` (or installed).
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from typing import Any

import pytest
from helpers import case, entry

from btgen_pytrees import batch as batch_module
from btgen_pytrees import cli as cli_module

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1 = ROOT / "examples" / "fig1.json"
FIG1_SWEEP = ROOT / "examples" / "fig1_sweep.json"

EXITS_AT_IMPORT = "import os\nos._exit(0)\n"

LEAVES = '''
import os, sys
import py_trees
from py_trees.common import Status

print("chatty: at import")
os.write(1, b"chatty: fd 1 at import\\n")


class Leaf(py_trees.behaviour.Behaviour):
    def __init__(self, entry, env):
        super().__init__(name=entry.name)
        self.how = entry.action
        print("chatty: in the factory")

    def update(self):
        print("chatty: in update")
        os.write(1, b"chatty: fd 1 in update\\n")
        if self.how == "exit0":
            os._exit(0)
        if self.how == "ready":
            open(os.environ["ATTACK_READY"], "w").close()
        return Status.SUCCESS


def register(registry):
    print("chatty: in register")
    if os.environ.get("ATTACK_READY") and not os.environ.get("ATTACK_READY_IN_LEAF"):
        open(os.environ["ATTACK_READY"], "w").close()
    for action in ("talk", "exit0", "ready"):
        registry.register(action, lambda e, env: Leaf(e, env), kind="behavior")
'''


def cli(cwd: pathlib.Path, *args: str, env: dict[str, str] | None = None, timeout: float = 180) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd, env=env)  # fmt: skip


def write(path: pathlib.Path, data: Any) -> pathlib.Path:
    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return path


@pytest.fixture
def work(tmp_path: pathlib.Path) -> pathlib.Path:
    """A scratch folder with fig1, its sweep, a plugin that exits 0 at import and a chatty one."""
    write(tmp_path / "fig1.json", FIG1.read_text())
    write(tmp_path / "sweep.json", FIG1_SWEEP.read_text())
    write(tmp_path / "exits.py", EXITS_AT_IMPORT)
    write(tmp_path / "chatty.py", LEAVES)
    write(tmp_path / "talk.json", case(entry("A", action="talk"), name="talk"))
    return tmp_path


def snapshot(folder: pathlib.Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file() and not p.is_symlink()}


# -- 20.2: a run that produced no verdict never exits 0 ------------------------------------------


@pytest.mark.parametrize("command", [
    ("run", "sweep.json"),
    ("run", "fig1.json", "--out-dir", "out"),
    ("validate", "fig1.json"),
    ("validate", "sweep.json"),
    ("run", "fig1.json"),
    ("run", "fig1.json", "--json", "r.json"),
    ("show", "fig1.json", "-f", "json"),
    ("expand", "sweep.json", "--out-dir", "out"),
])  # fmt: skip
def test_a_plugin_exiting_0_at_import_never_gives_exit_0(work: pathlib.Path, command: tuple[str, ...]) -> None:
    before = snapshot(work)
    result = cli(work, *command, "--plugin", "exits.py")
    assert result.returncode == 1, (result.stdout, result.stderr)
    assert "before giving a verdict" in result.stderr and "os._exit" in result.stderr
    assert snapshot(work) == before and not (work / "out").exists()  # nothing written


def test_a_leaf_exiting_0_in_a_single_run_is_an_error_not_a_pass(work: pathlib.Path) -> None:
    write(work / "exit0.json", case(entry("A", action="exit0"), name="exit0"))
    result = cli(work, "run", "exit0.json", "--plugin", "chatty.py", "--json", "r.json")
    assert result.returncode == 1 and "exited with status 0 before giving a verdict" in result.stderr
    assert not (work / "r.json").exists()


def test_a_supervised_command_keeps_its_own_exit_code(work: pathlib.Path) -> None:
    assert cli(work, "run", "talk.json", "--plugin", "chatty.py").returncode == 0
    failing = write(work / "failing.json", json.loads((ROOT / "examples" / "fig1_failing.json").read_text()))
    assert cli(work, "run", failing.name, "--plugin", "chatty.py").returncode == 1
    assert cli(work, "run", "nothing.json", "--plugin", "chatty.py").returncode == 2


# -- 20.5: two outputs on one path ---------------------------------------------------------------


@pytest.mark.parametrize("options", [
    ("--json", "X", "--junit", "X"),
    ("--json", "X", "--junit", "./X"),
    ("--btlog", "x.btlog", "--json", "x.btlog"),
    ("--json", "X", "--junit", "link"),
    ("--json", "-", "--junit", "/dev/stdout"),
])  # fmt: skip
@pytest.mark.parametrize("input_", ["fig1.json", "sweep.json"])
def test_two_outputs_on_one_path_are_refused_before_running(work: pathlib.Path, options: tuple[str, ...], input_: str) -> None:
    if "--btlog" in options and input_ == "sweep.json":
        pytest.skip("--btlog takes one case")
    (work / "X").write_text("mine")
    (work / "x.btlog").write_text("mine too")
    (work / "link").symlink_to("X")
    before = snapshot(work)
    result = cli(work, "run", input_, *options)
    assert result.returncode == 2, result.stderr
    assert "the same file" in result.stderr and "Traceback" not in result.stderr
    assert snapshot(work) == before and result.stdout == ""


def test_a_batch_junit_on_a_per_file_output_is_refused(work: pathlib.Path) -> None:
    (work / "o").mkdir()
    result = cli(work, "run", "fig1.json", "talk.json", "--out-dir", "o", "--junit", "o/fig1.junit.xml")
    assert result.returncode == 2 and "the same file" in result.stderr
    assert not any((work / "o").iterdir())


def test_dev_null_may_take_several_outputs(work: pathlib.Path) -> None:
    assert cli(work, "run", "fig1.json", "--json", "/dev/null", "--junit", "/dev/null").returncode == 0


# -- 20.7: whole numbers written as 1e1 ---------------------------------------------------------


def random_sweep(samples: Any) -> dict[str, Any]:
    data = json.loads(FIG1_SWEEP.read_text())
    data["variations"] = {"top_speed": {"uniform": [10, 40]}, "samples": samples, "seed": 3}
    return data


def test_samples_written_1e1_are_ten(work: pathlib.Path) -> None:
    write(work / "ten.json", random_sweep(10))
    write(work / "e1.json", random_sweep(1e1))
    assert "e1" in (work / "e1.json").read_text() or "10.0" in (work / "e1.json").read_text()
    result = cli(work, "validate", "e1.json")
    assert result.returncode == 0 and "10 variations" in result.stdout, result.stderr
    runs = [cli(work, "run", name, "--json", f"{name}.report") for name in ("ten.json", "e1.json")]
    assert [r.returncode for r in runs][0] == runs[1].returncode in (0, 1), runs[1].stderr
    reports = [json.loads((work / f"{name}.report").read_text()) for name in ("ten.json", "e1.json")]
    assert [r["label"] for r in reports[0]["rows"]] == [r["label"] for r in reports[1]["rows"]]
    assert len(reports[1]["rows"]) == 10
    assert cli(work, "expand", "e1.json", "--out-dir", "cases").returncode == 0
    assert len(list((work / "cases").iterdir())) == 10


def test_samples_that_are_not_whole_are_a_clear_error(work: pathlib.Path) -> None:
    write(work / "half.json", random_sweep(1.5))
    for command in (("validate", "half.json"), ("run", "half.json"), ("expand", "half.json", "--out-dir", "c")):
        result = cli(work, *command)
        assert result.returncode == 2 and "half.json: /variations/samples:" in result.stderr, result.stderr
        assert "Traceback" not in result.stderr


def test_validate_prints_an_internal_error(work: pathlib.Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    def broken(path: str, *args: object) -> Any:
        raise RuntimeError("boom")

    monkeypatch.setattr(batch_module, "job_validate", broken)
    assert cli_module.main(["validate", str(work / "fig1.json")]) == 3
    assert "fig1.json: internal error: RuntimeError: boom" in capsys.readouterr().err


# -- 20.9: a signal while a sweep's variations are checked -----------------------------------------


def wait_for_handlers(pid: int, timeout: float = 60) -> None:
    """Until process *pid* catches SIGTERM: the CLI's handlers are installed (Linux: /proc/PID/status)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            status = pathlib.Path(f"/proc/{pid}/status").read_text()
        except OSError:
            return
        caught = int(next(line for line in status.splitlines() if line.startswith("SigCgt:")).split()[1], 16)
        if caught & (1 << (signal.SIGTERM - 1)):
            return
        time.sleep(0.02)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("supervised", [False, True])
def test_a_signal_during_a_sweeps_validation_is_130_or_143(work: pathlib.Path, signum: int, supervised: bool) -> None:
    data = json.loads(FIG1_SWEEP.read_text())
    data["variations"] = {"top_speed": {"from": 10, "to": 40, "step": 0.0006}}  # 50,001 variations: checking takes seconds
    write(work / "big.json", data)
    ready = work / "ready"
    env = dict(os.environ, ATTACK_READY=str(ready))
    plugin = ["--plugin", "chatty.py"] if supervised else []
    process = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "validate", "big.json", "--max-variations", "100000", *plugin],
                               cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    if supervised:  # the plugin says when the registry is made: the checks of the variations begin
        deadline = time.monotonic() + 60
        while not ready.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.3)
    else:
        wait_for_handlers(process.pid)
        time.sleep(0.3)
    process.send_signal(signum)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signum, err
    assert f"interrupted by {signal.Signals(signum).name}" in err and "internal error" not in err


# -- 20.14: the sweep summary escapes a name's terminal controls ----------------------------------


def test_the_sweep_summary_escapes_terminal_controls(work: pathlib.Path) -> None:
    data = json.loads(FIG1_SWEEP.read_text())
    data["name"] = "s\x1b]0;owned\x07\u202e\u2028\x9bx"
    write(work / "esc.json", data)
    result = cli(work, "run", "esc.json", "--jobs", "2")
    assert result.returncode == 1
    for bad in ("\x1b", "\x07", "\u202e", "\u2028", "\x9b"):
        assert bad not in result.stdout and bad not in result.stderr
    assert "s\\x1b]0;owned\\x07\\u202e\\u2028\\x9bx" in result.stdout


# -- 20.16: machine-readable stdout carries only the document ---------------------------------------


@pytest.mark.parametrize("command, parse", [
    (("show", "talk.json", "-f", "json"), json.loads),
    (("run", "talk.json", "--json", "-"), json.loads),
    (("run", "talk.json", "--junit", "-"), lambda text: ET.fromstring(text.split("\n", 1)[1])),
    (("run", "sweep.json", "--json", "-", "--jobs", "1"), json.loads),
    (("show", "talk.json", "-f", "btcpp"), lambda text: ET.fromstring(text.split("\n", 1)[1])),
])  # fmt: skip
def test_a_chatty_plugin_never_reaches_a_document_on_stdout(work: pathlib.Path, command: tuple[str, ...], parse: Any) -> None:
    result = cli(work, *command, "--plugin", "chatty.py")
    assert result.returncode in (0, 1), result.stderr
    assert "chatty" not in result.stdout
    parse(result.stdout)
    assert "chatty: at import" in result.stderr and "chatty: fd 1 at import" in result.stderr
    if command[0] == "run" and "sweep.json" not in command:
        assert "chatty: fd 1 in update" in result.stderr
        assert "PASS" in result.stderr  # the verdict table: on stderr when stdout carries the document


# -- 20.4: expand never overwrites its own input --------------------------------------------------


def two_variations(name: str = "s") -> dict[str, Any]:
    data = json.loads(FIG1_SWEEP.read_text())
    data["name"] = name
    data["variations"] = {"top_speed": [10, 20]}
    return data


@pytest.mark.parametrize("attack", ["named_like_a_variation", "plain_case_into_its_folder", "symlink_to_the_input",
                                    "hard_link_to_the_input", "out_dir_is_the_input"])  # fmt: skip
def test_expand_never_overwrites_its_input(work: pathlib.Path, attack: str) -> None:
    out = work / "out"
    out.mkdir()
    if attack == "named_like_a_variation":  # the input is where its first variation would be written
        source = write(out / "s[top_speed=10].json", two_variations())
        args = [str(source.relative_to(work)), "--out-dir", "out"]
    elif attack == "plain_case_into_its_folder":
        source = write(out / "fig1.json", FIG1.read_text())
        args = ["out/fig1.json", "--out-dir", "out"]
    elif attack == "out_dir_is_the_input":
        source = write(work / "s.json", two_variations())
        args = ["s.json", "--out-dir", "s.json"]
    else:
        source = write(work / "s.json", two_variations())
        link = out / "s[top_speed=20].json"
        link.symlink_to(source) if attack == "symlink_to_the_input" else os.link(source, link)
        args = ["s.json", "--out-dir", "out"]
    before = snapshot(work)
    result = cli(work, "expand", *args)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr and result.stderr.startswith("btgen_pytrees: --out-dir")
    assert snapshot(work) == before  # nothing written: not the input, not the other variation
    json.loads(source.read_text())


def test_expand_writes_every_variation_and_says_so(work: pathlib.Path) -> None:
    write(work / "s.json", two_variations())
    result = cli(work, "expand", "s.json", "--out-dir", "out")
    assert result.returncode == 0 and result.stdout == "2 cases written to out\n", result.stderr
    assert sorted(p.name for p in (work / "out").iterdir()) == ["s[top_speed=10].json", "s[top_speed=20].json"]


# -- 20.15: the .btlog stays well-formed and never wraps its clock ----------------------------------


def test_btlog_xml_is_well_formed_whatever_the_names(work: pathlib.Path) -> None:
    from btgen_pytrees.run.btlog import parse_btlog

    data = case(entry("A"), entry("B", ["A"]), name="t\x00\x07\ufffe\x1b")
    write(work / "names.json", data)
    result = cli(work, "run", "names.json", "--btlog", "names.btlog")
    assert result.returncode == 0, result.stderr
    log = parse_btlog((work / "names.btlog").read_bytes())
    names = ET.fromstring(log.xml)  # well-formed
    assert any("\\x07" in (e.get("name") or "") for e in names.iter())


def test_btlog_refuses_a_run_past_48_bits_of_microseconds_before_running(work: pathlib.Path) -> None:
    write(work / "long.json", case(entry("A", duration=1), name="long", tick=1e4, timeout=3e8))  # 30,000 ticks, ~9.5 years
    result = cli(work, "run", "long.json", "--btlog", "long.btlog")
    assert result.returncode == 2 and "48-bit microseconds" in result.stderr, result.stderr
    assert not (work / "long.btlog").exists() and "PASS" not in result.stdout  # refused before the run


def test_btlog_bytes_never_wrap_a_time(work: pathlib.Path) -> None:
    import btgen_pytrees
    from btgen_pytrees.run import run
    from btgen_pytrees.run.btlog import BtlogError, btlog_bytes

    loaded = btgen_pytrees.load(case(entry("A", duration=2.9e8), name="long", tick=1e4, timeout=3e8))
    report = run(loaded)
    assert report.trace is not None and max(report.trace.times) > 2**48 / 1e6
    with pytest.raises(BtlogError, match="48-bit"):
        btlog_bytes(report.trace, btgen_pytrees.generate(loaded))


# -- 20.3 / 23.16: a sweep in batch mode ----------------------------------------------------------


def test_a_sweep_given_alone_to_run_out_dir_runs_its_variations(work: pathlib.Path) -> None:
    result = cli(work, "run", "sweep.json", "--out-dir", "o", "--jobs", "2")
    assert result.returncode == 1, result.stderr  # 10 of its 28 variations fail (the defaults pass)
    assert "28 variations of top_speed x limit: 18 pass, 10 fail" in result.stdout
    report = json.loads((work / "o" / "sweep.report.json").read_text())
    assert len(report["rows"]) == 28 and report["verdict"] == "fail"
    suites = ET.fromstring((work / "o" / "sweep.junit.xml").read_text())
    assert len(list(suites.iter("testcase"))) == 28


def test_a_folder_holding_one_sweep_runs_its_variations_with_a_batch_junit(work: pathlib.Path) -> None:
    (work / "d").mkdir()
    (work / "sweep.json").rename(work / "d" / "sweep.json")
    result = cli(work, "run", "d", "--out-dir", "o", "--junit", "all.xml", "--jobs", "2")
    assert result.returncode == 1 and "18 pass, 10 fail" in result.stdout, result.stderr
    assert len(list(ET.fromstring((work / "all.xml").read_text()).iter("testcase"))) == 28
    assert (work / "o" / "sweep.report.json").exists()


def test_a_sweep_in_a_batch_of_several_says_defaults_only(work: pathlib.Path) -> None:
    result = cli(work, "run", "sweep.json", "fig1.json", "--out-dir", "o", "--jobs", "2")
    assert result.returncode == 0
    row = next(line for line in result.stdout.splitlines() if line.startswith("sweep.json"))
    assert "sweep: defaults only; run it alone or with --variations for its 28 variations" in row


def test_variations_runs_every_sweep_of_a_batch(work: pathlib.Path) -> None:
    result = cli(work, "run", "sweep.json", "fig1.json", "--out-dir", "o", "--jobs", "2", "--variations", "--junit", "all.xml")
    assert result.returncode == 1, result.stderr
    row = next(line for line in result.stdout.splitlines() if line.startswith("sweep.json"))
    assert "FAIL" in row and "28 variations: 18 pass, 10 fail" in row
    assert len(json.loads((work / "o" / "sweep.report.json").read_text())["rows"]) == 28
    assert len(list(ET.fromstring((work / "all.xml").read_text()).iter("testcase"))) == 28 + 4  # fig1: 3 criteria + execute


# -- 20.12: every SUMO input file is bounded in size and nesting ---------------------------------------


def sumo_copy(work: pathlib.Path, extra_routes: str) -> pathlib.Path:
    folder = work / "sumo"
    folder.mkdir()
    for item in (ROOT / "examples" / "sumo").iterdir():
        if item.is_file():
            (folder / item.name).write_bytes(item.read_bytes())
    (folder / "extra.rou.xml").write_text(extra_routes)
    (folder / "acc.sumocfg").write_text('<configuration><input><net-file value="road.net.xml"/>'
                                        '<route-files value="acc.rou.xml,extra.rou.xml"/></input></configuration>')  # fmt: skip
    return folder


def test_a_route_file_nested_200k_deep_is_refused_at_load(work: pathlib.Path) -> None:
    depth = 200_000
    folder = sumo_copy(work, "<routes>" + "<x>" * depth + "</x>" * depth + "</routes>")
    assert (folder / "extra.rou.xml").stat().st_size > 1_000_000
    for command in ("validate", "run"):
        result = cli(folder, command, "acc_hard_brake.json", timeout=60)
        assert result.returncode == 2, result.stderr
        assert "extra.rou.xml:1: elements nested more than 32 levels deep" in result.stderr
    from btgen_pytrees.systems.sumo.scenario import read_scenario

    assert read_scenario(str(folder / "cut_in.sumocfg")).problems == ()  # the other scenario is fine


def test_the_files_a_scenario_names_are_bounded_together(work: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from btgen_pytrees.systems.sumo import scenario

    folder = sumo_copy(work, "<routes/>")
    assert read_problems(folder) == ()
    total = sum((folder / name).stat().st_size for name in ("acc.sumocfg", "road.net.xml", "acc.rou.xml", "extra.rou.xml"))
    monkeypatch.setattr(scenario, "MAX_SCENARIO_BYTES", total - 1)
    (problem,) = read_problems(folder)
    assert problem == f"acc.sumocfg: the configuration and the files it names are {total} bytes together; the limit is {total - 1}"


def read_problems(folder: pathlib.Path) -> tuple[str, ...]:
    from btgen_pytrees.systems.sumo.scenario import read_scenario

    return read_scenario(str(folder / "acc.sumocfg")).problems


# -- 23.12: an unknown command is not a file name ---------------------------------------------------


def test_a_mistyped_command_is_an_unknown_command(work: pathlib.Path) -> None:
    result = cli(work, "runn", "fig1.json")
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == "btgen_pytrees: unknown command 'runn' (did you mean 'run'?)\n"
    other = cli(work, "frobnicate")
    assert other.returncode == 2 and "unknown command 'frobnicate'; the commands are show, validate" in other.stderr
    assert "cannot read file" in cli(work, "missing.json").stderr  # named like a file: the loader says why
    (work / "runn").write_text(FIG1.read_text())  # a file of that name is shown
    assert cli(work, "runn").returncode == 0


# -- 23.13: options accepted and then ignored are errors ---------------------------------------------


@pytest.mark.parametrize("command, says", [
    (("run", "fig1.json", "--scheduler", "tcp://127.0.0.1:1"), "--scheduler applies to --executor dask only"),
    (("validate", "fig1.json", "--out-dir", "o"), "unrecognized arguments: --out-dir o"),
    (("show", "fig1.json", "-o", "t.html"), "-o t.html: .html names no format"),
])  # fmt: skip
def test_an_option_that_would_be_ignored_is_an_error(work: pathlib.Path, command: tuple[str, ...], says: str) -> None:
    before = snapshot(work)
    result = cli(work, *command)
    assert result.returncode == 2 and says in result.stderr and result.stdout == ""
    assert snapshot(work) == before and not (work / "o").exists()


# -- 23.14: overlap warnings: one cap everywhere, -q silences them --------------------------------------


def overlapping(n: int) -> dict[str, Any]:
    return case(*[entry(f"S{i}", action="set", signal="x", value=i) for i in range(n)], name="ov")


@pytest.mark.parametrize("command", [("run", "ov.json"), ("run", "ov.json", "fig1.json"), ("validate", "ov.json"),
                                     ("show", "ov.json"), ("show", "ov.json", "fig1.json")])  # fmt: skip
def test_overlap_warnings_are_capped_alike_and_quiet_silences_them(work: pathlib.Path, command: tuple[str, ...]) -> None:
    write(work / "ov.json", overlapping(250))
    lines = [line for line in cli(work, *command).stderr.splitlines() if line.startswith("ov.json")]
    assert len(lines) == 101 and lines[-1] == "ov.json: … and 149 more warnings", lines[-3:]
    assert all(": warning: " in line for line in lines[:100])
    quiet = cli(work, *command, "-q")
    assert quiet.returncode == 0 and "warning" not in quiet.stderr, quiet.stderr


# -- 23.15: messages say true, tidy things -----------------------------------------------------------


def test_values_in_messages_are_rounded_like_the_margin(work: pathlib.Path) -> None:
    data = case(entry("A", action="set", signal="gap", value=1.6350000000000051),
                criteria=[{"id": "R1", "type": "record", "expect": "gap >= 2"}], name="gap", timeout=1)  # fmt: skip
    write(work / "gap.json", data)
    result = cli(work, "run", "gap.json")
    assert result.returncode == 1
    assert "gap=1.635)" in result.stdout and "1.6350000000000051" not in result.stdout, result.stdout
    assert "false by 0.365" in result.stdout


def test_one_tick_one_file_and_an_underlined_last_column(work: pathlib.Path) -> None:
    write(work / "one.json", case(entry("A", action="set", signal="x", value=1), name="one", timeout=1))
    single = cli(work, "run", "one.json")
    assert "(1 tick)" in single.stdout, single.stdout
    header, rule = single.stdout.splitlines()[:2]
    assert header.endswith("message") and rule.endswith("  -------")
    cli(work, "run", "one.json", "--plot", "one.svg", "--replay", "one.html")
    assert "(1 tick)" in (work / "one.svg").read_text() and "(1 tick)" in (work / "one.html").read_text()
    batch = cli(work, "run", "one.json", "--out-dir", "o")
    assert "1 file: 1 ok" in batch.stdout
    assert "ok: 1 entry, 0 criteria" in cli(work, "validate", "one.json").stdout


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("plugin", [(), ("--plugin", "chatty.py")])
def test_sigterm_says_what_sigint_says(work: pathlib.Path, signum: int, plugin: tuple[str, ...]) -> None:
    write(work / "long.json", case(entry("A", duration=4000), name="long", tick=0.001, timeout=5000))
    process = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", "long.json", "--max-work", "1e12", *plugin], cwd=work,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    wait_for_handlers(process.pid)
    time.sleep(0.5)
    process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signum
    said = [line for line in err.splitlines() if not line.startswith("chatty")]
    assert said == [f"btgen_pytrees: interrupted by {signal.Signals(signum).name}"]
