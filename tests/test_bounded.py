"""Bounded work and memory for any valid input (issue 13 class 2)."""

from __future__ import annotations

import difflib
import json
import os
import pathlib
import shutil
import subprocess
import sys

import pytest
from helpers import case, crit, entry, run_case

import btgen_pytrees
from btgen_pytrees.errors import MAX_LINE
from btgen_pytrees.contracts.environment import Environment
from btgen_pytrees.leaves.oracles import MAX_SAMPLES
from btgen_pytrees.load import MAX_SUGGESTIONS, MAX_WORK, work

ROOT = pathlib.Path(__file__).resolve().parent.parent


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)  # fmt: skip


def write(tmp_path: pathlib.Path, data: dict[str, object], name: str = "c") -> str:
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(data))
    return str(path)


def test_the_work_budget_charges_the_work_done(tmp_path: pathlib.Path) -> None:
    """Issue 19 item 11: refuse up front only what is certain to exceed; stop a run when its budget is spent."""
    tiny = write(tmp_path, case(entry("A", duration=100), tick=1e-6, timeout=10), "tiny")  # 10M ticks of a 1-entry tree
    result = cli("run", tiny, "--max-work", "100000", "--json", str(tmp_path / "r.json"))
    assert result.returncode == 1, result.stderr
    assert "t: ERROR after 0.009089 s (9090 ticks) - stopped: the work budget of 1e+05 units is spent after 9090 ticks x 11" in result.stdout
    report = json.loads((tmp_path / "r.json").read_text())  # the partial report is kept
    assert report["verdict"] == "error" and report["ticks"] == 9090 and report["execute"][0]["status"] != "success"
    small = case(entry("A"), tick=0.1, timeout=10)
    assert work(btgen_pytrees.load(small)) == 101 * 11 < MAX_WORK  # the most a run can do
    path = write(tmp_path, small)
    refused = cli("run", path, "--max-work", "10")  # one tick is 11 units: certain to exceed, nothing runs
    assert refused.returncode == 2 and refused.stdout == ""
    assert "/execute: one tick of this tree is 11 units of work (entries + criteria + 10), more than the whole budget" in refused.stderr
    assert cli("run", path, "--max-work", "120").returncode == 1  # 10 ticks of the 11 it needs
    assert cli("run", path, "--max-work", "121").returncode == 0  # ends at 1 s: 11 ticks, 121 units, not 1111
    batch = cli("run", path, tiny, "--max-work", "100000")
    assert batch.returncode == 1 and "2 files: 1 ok, 1 error" in batch.stdout
    # a 200-step chain with a generous timeout: 1e7 ticks x 210 charged up front before, 20,001 ticks run
    comb = write(tmp_path, case(*[entry(f"S{i}", [f"S{i - 1}"] if i else [], duration=1) for i in range(200)],
                                tick=0.01, timeout=100000), "comb")  # fmt: skip
    assert cli("run", comb).returncode == 0


def test_a_tick_too_small_to_advance_the_clock_is_refused() -> None:
    with pytest.raises(btgen_pytrees.InvalidTestCase) as info:
        btgen_pytrees.load(case(entry("A"), tick=4e-10, timeout=1e-6))
    assert [p.pointer for p in info.value.problems] == ["/tick"]


def test_an_or_group_costs_o_n_per_tick(monkeypatch: pytest.MonkeyPatch) -> None:
    """1,000 members, all but one failing at once: no member rescans the group."""
    n = 1000
    criteria = [crit(f"R{i}", "record", "x < 0") for i in range(n - 1)] + [crit("OK", "record", "x >= 0")]
    data = case(entry("A", duration=10), criteria=criteria, relation={"record": "||", "others": "&&"},
                signals={"x": 1}, timeout=10)  # fmt: skip
    calls = {"is_failed": 0}
    real = Environment.is_failed

    def counted(self: Environment, criterion_id: str) -> bool:
        calls["is_failed"] += 1
        return real(self, criterion_id)

    monkeypatch.setattr(Environment, "is_failed", counted)
    report = run_case(data)
    assert report.verdict == "pass" and report.ticks == 101
    assert calls["is_failed"] <= 2 * n  # was ~n * n per tick


def test_an_or_group_still_fails_at_its_last_members_failure() -> None:
    data = case(entry("A", action="ramp", signal="x", to=10, duration=1), signals={"x": 0}, timeout=3,
                criteria=[crit(f"R{i}", "record", f"x < {i + 1}") for i in range(5)], relation="||")  # fmt: skip
    report = run_case(data)
    assert report.verdict == "fail" and report.duration == pytest.approx(0.5)


def test_oracles_keep_a_bounded_history() -> None:
    data = case(entry("A", action="ramp", signal="x", to=1e6, duration=1e4), signals={"x": 0},
                criteria=[crit("R", "record", "x >= 0"), crit("F", "final", "x < 0", at=999)], timeout=1000)  # fmt: skip
    report = run_case(data)
    [record, final] = report.oracles
    assert report.ticks == 9991 and record.verdict == "pass"
    assert len(record.samples) == MAX_SAMPLES  # 9,991 changes seen, the first MAX_SAMPLES kept
    assert final.verdict == "fail" and final.values["x"] == pytest.approx(99900)  # what the report needs is kept


def test_did_you_mean_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    known = [entry(f"K{i}") for i in range(2000)]
    unknown = [entry(f"U{i}", [f"K{i}x"]) for i in range(2000)]
    calls = {"n": 0}
    real = difflib.get_close_matches

    def counted(*args: object, **kw: object) -> object:
        calls["n"] += 1
        return real(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(difflib, "get_close_matches", counted)
    with pytest.raises(btgen_pytrees.InvalidTestCase) as info:
        btgen_pytrees.load(case(*known, *unknown))
    problems = info.value.problems
    assert len(problems) == 2000 and calls["n"] <= MAX_SUGGESTIONS
    assert "did you mean 'K0'" in problems[0].message and "did you mean" not in problems[-1].message


def test_problems_are_capped_and_lines_short(tmp_path: pathlib.Path) -> None:
    data = case(*[entry(f"A{i}", ["Z"]) for i in range(500)])
    data["x" * 50_000] = 1  # a huge unknown key: shape stage reports it alone
    result = cli("validate", write(tmp_path, data))
    lines = result.stderr.splitlines()
    assert result.returncode == 2 and len(lines) == 1 and len(lines[0]) <= MAX_LINE
    del data["x" * 50_000]
    result = cli("validate", write(tmp_path, data))
    lines = result.stderr.splitlines()
    assert len(lines) == 101 and lines[-1].endswith("… and 400 more problems")
    cycle = case(*[entry(f"C{i}", [f"C{(i + 1) % 5000}"]) for i in range(5000)])
    result = cli("validate", write(tmp_path, cycle))
    assert result.returncode == 2 and all(len(line) <= MAX_LINE for line in result.stderr.splitlines())


def test_the_plot_of_a_big_run_is_capped() -> None:
    pytest.importorskip("matplotlib")
    from btgen_pytrees.run import run
    from btgen_pytrees.run.plot import MAX_ROWS, plot_figure

    loaded = btgen_pytrees.load(case(*[entry(f"E{i}", duration=0.1) for i in range(400)],
                                     criteria=[crit("F", "final", "false")], timeout=1))  # fmt: skip
    figure = plot_figure(run(loaded), loaded)
    labels = [t.get_text() for t in figure.axes[0].get_yticklabels()]
    assert len(labels) == MAX_ROWS and any(label.startswith("F  final") for label in labels)  # the failure is kept
    assert "not drawn: 201 of 401 rows" in figure.axes[0].get_title(loc="left")


def test_graphviz_gets_a_timeout_with_a_clear_message() -> None:
    if not shutil.which("dot") and not os.environ.get("CI"):
        pytest.skip("needs Graphviz")
    from btgen_pytrees.render.dot import GraphvizTimeout, dot_source, graphviz_render

    root = btgen_pytrees.generate(btgen_pytrees.load(case(*[entry(f"E{i}") for i in range(2000)])))
    with pytest.raises(GraphvizTimeout, match="did not finish laying out .* nodes within 0.01 s; draw less with --max-depth"):
        graphviz_render(dot_source(root), "svg", timeout=0.01)
