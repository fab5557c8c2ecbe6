"""Every output agrees on the verdict, and names what it reports (issue 10, defects 1, 2 and 8)."""

from __future__ import annotations

import json
import os
import pathlib
import xml.etree.ElementTree as ET
from typing import Any

import jsonschema
import pytest
from helpers import broken_registry, case, crit, entry, run_case
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from btgen_pytrees.cli import main

ROOT = pathlib.Path(__file__).resolve().parent.parent
REPORT_SCHEMA = json.loads((ROOT / "schemas" / "report.schema.json").read_text())


def junit_counts(xml: str) -> tuple[int, int, int]:
    suite = ET.fromstring(xml).find("testsuite")
    assert suite is not None
    counted = (len(suite.findall("testcase/failure")), len(suite.findall("testcase/error")), len(suite.findall("testcase/skipped")))
    assert counted == (int(suite.get("failures", "0")), int(suite.get("errors", "0")), int(suite.get("skipped", "0")))
    return counted


# -- defect 1: JUnit agrees with the exit code --------------------------------------------------


def or_case(relation: Any = "||") -> dict[str, Any]:
    """x ramps 0 -> 10 over 1 s; B fails at 0.5 s, G passes at 1 s: an || group that passes."""
    return case(entry("A", action="ramp", signal="x", to=10, duration=1), signals={"x": 0}, relation=relation,
                criteria=[crit("B", "period", "x < 5"), crit("G", "final", "x == 10")])  # fmt: skip


def test_a_failed_member_of_a_passing_or_group_is_not_a_junit_failure(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "or.json"
    path.write_text(json.dumps(or_case()))
    junit = tmp_path / "or.xml"
    assert main(["run", str(path), "--junit", str(junit)]) == 0
    xml = junit.read_text()
    assert junit_counts(xml) == (0, 0, 0)
    member = next(tc for tc in ET.fromstring(xml).iter("testcase") if tc.get("name", "").startswith("B "))
    out = member.find("system-out")
    assert out is not None and "fail at 0.5 s" in (out.text or "") and "its || group passed" in (out.text or "")
    # the same member in an && group fails the run, and JUnit says so
    report = run_case(or_case("&&"))
    assert report.verdict == "fail" and junit_counts(report.to_junit())[0] == 1


SIGNAL_EXPECTS = ["x < 3", "x <= 10", "x >= 0", "x == 10", "x > 4", "y == 1", "x + y < 8"]


@st.composite
def random_cases(draw: Any) -> dict[str, Any]:
    entries = [entry("A", action="ramp", signal="x", to=10, duration=draw(st.sampled_from([0.5, 1, 2])))]
    for i in range(draw(st.integers(0, 3))):
        after = draw(st.lists(st.sampled_from(["A", *[f"E{k}" for k in range(i)]]), max_size=2, unique=True))
        action = draw(st.sampled_from(["hold", "set", "until"]))
        params: dict[str, Any] = {"duration": draw(st.sampled_from([0, 0.3, 1, 5]))}
        if action == "set":
            params["signal"], params["value"] = "y", draw(st.sampled_from([0, 1]))
        elif action == "until":
            params = {"expect": draw(st.sampled_from(SIGNAL_EXPECTS)), "timeout": draw(st.sampled_from([0.2, 3]))}
        entries.append(entry(f"E{i}", after, action=action, **params))
    criteria = []
    for i in range(draw(st.integers(0, 4))):
        kind = draw(st.sampled_from(["record", "period", "final"]))
        extra: dict[str, Any] = {}
        if kind == "final" and draw(st.booleans()):
            extra["at"] = draw(st.sampled_from([0.3, 1, 2.5]))
        if kind == "period" and draw(st.booleans()):
            extra["to"] = draw(st.sampled_from([0.4, 1.5, 4]))
        criteria.append(crit(f"O{i}", kind, draw(st.sampled_from(SIGNAL_EXPECTS)), **extra))
    relation = draw(st.sampled_from(["&&", "||", {"record": "||", "others": "&&"}, {"record": "&&", "others": "||"}]))
    return case(*entries, signals={"x": 0, "y": 0}, criteria=criteria, relation=relation,
                timeout=draw(st.sampled_from([1.5, 3, 10])))  # fmt: skip


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=random_cases(), require=st.booleans())
def test_junit_exit_code_and_json_agree_on_random_cases(data: dict[str, Any], require: bool, tmp_path: pathlib.Path) -> None:
    """JUnit ``failures + errors == 0`` ⇔ exit 0 ⇔ the JSON verdict is ``pass``."""
    path = tmp_path / "case.json"
    path.write_text(json.dumps(data))
    out = tmp_path / "out"
    out.mkdir(exist_ok=True)
    argv = ["run", str(path), "--json", str(out / "r.json"), "--junit", str(out / "r.xml")]
    code = main(argv + (["--require-complete"] if require else []))
    report = json.loads((out / "r.json").read_text())
    jsonschema.validate(report, REPORT_SCHEMA)
    failures, errors, _ = junit_counts((out / "r.xml").read_text())
    assert code in (0, 1)
    assert (failures + errors == 0) == (code == 0) == (report["verdict"] == "pass"), report
    if require and code == 0:
        assert report["timeline"]["complete"]


# -- defect 2: an incomplete timeline is visible everywhere -------------------------------------


def early_exit_case(**top: Any) -> dict[str, Any]:
    """A final at 2 s ends the run; U (which would fail) and H never start, A is stopped."""
    return case(entry("A", duration=3), entry("U", ["A"], action="until", expect="false", timeout=0.1),
                entry("H", ["U"]), criteria=[crit("F", "final", "true", at=2)], **top)  # fmt: skip


def test_a_pass_with_an_unfinished_timeline_says_so_everywhere(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "early.json"
    path.write_text(json.dumps(early_exit_case()))
    report = run_case(early_exit_case())
    assert report.verdict == "pass" and not report.complete
    assert "t: PASS (timeline incomplete: 1 entry stopped, 2 entries did not run) after 2 s" in report.table()
    data = json.loads(report.to_json())
    assert data["timeline"] == {"complete": False, "message": "1 entry stopped, 2 entries did not run"}
    jsonschema.validate(data, REPORT_SCHEMA)
    execute = ET.fromstring(report.to_junit()).find("testsuite/testcase[@name='execute']")
    assert execute is not None and execute.find("skipped") is not None
    assert execute.find("skipped").get("message") == "timeline incomplete: 1 entry stopped, 2 entries did not run"  # type: ignore[union-attr]
    assert junit_counts(report.to_junit()) == (0, 0, 1)
    assert main(["run", str(path)]) == 0
    complete = run_case(case(entry("A"), criteria=[crit("F", "final", "true")]))
    assert complete.complete and json.loads(complete.to_json())["timeline"] == {"complete": True, "message": ""}
    assert "incomplete" not in complete.table()


def test_require_complete_fails_an_unfinished_timeline(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "early.json"
    path.write_text(json.dumps(early_exit_case()))
    assert main(["run", str(path), "--require-complete", "--junit", str(tmp_path / "r.xml")]) == 1
    assert junit_counts((tmp_path / "r.xml").read_text())[0] == 1
    keyed = run_case(early_exit_case(require_complete=True))
    assert keyed.verdict == "fail" and keyed.message.startswith("timeline incomplete: 1 entry stopped")
    path.write_text(json.dumps(early_exit_case(require_complete=True)))
    assert main(["run", str(path)]) == 1
    # a complete timeline still passes under the flag
    path.write_text(json.dumps(case(entry("A"), criteria=[crit("F", "final", "true")], require_complete=True)))
    assert main(["run", str(path), "--require-complete"]) == 0


# -- defect 8: names and provenance --------------------------------------------------------------


def test_names_and_source_in_every_report(tmp_path: pathlib.Path) -> None:
    data = case(dict(entry("A", action="until", expect="x > 1", timeout=0.3), name="wait for speed"),
                signals={"x": 0}, criteria=[dict(crit("R", "record", "x >= 0"), name="never reverse")])  # fmt: skip
    (tmp_path / "named.json").write_text(json.dumps(data))
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(["run", "named.json", "--json", "r.json", "--junit", "r.xml"]) == 1
    finally:
        os.chdir(cwd)
    report = json.loads((tmp_path / "r.json").read_text())
    jsonschema.validate(report, REPORT_SCHEMA)
    assert report["source"] == "named.json"
    assert report["execute"][0]["name"] == "wait for speed" and report["oracles"][0]["name"] == "never reverse"
    names = [tc.get("name") for tc in ET.fromstring((tmp_path / "r.xml").read_text()).iter("testcase")]
    assert names == ["execute", "R (never reverse) (record: x >= 0)"]
    failure = ET.fromstring((tmp_path / "r.xml").read_text()).find(".//testcase[@name='execute']/failure")
    assert failure is not None and failure.get("message", "").startswith("A (wait for speed): x > 1 still false")
    table = run_case(data).table()
    assert "R (never reverse)" in table and "A (wait for speed): x > 1 still false" in table


def test_btcpp_export_carries_the_name_labels() -> None:
    import btgen_pytrees
    from btgen_pytrees.render.btcpp import btcpp_xml

    data = case(dict(entry("A"), name="warm up"), criteria=[dict(crit("F", "final", "true"), name="done")])
    document = ET.fromstring(btcpp_xml(btgen_pytrees.generate(btgen_pytrees.load(data))))
    assert document.find(".//Action[@name='A (warm up)']") is not None
    assert document.find(".//Action[@name='F (done)']") is not None


def test_junit_stays_well_formed_with_control_characters_in_names() -> None:
    data = case(dict(entry("U", action="until", expect="false", timeout=0.1), name="bad\x1bname\x01"), name="t\x02")
    report = run_case(data)
    suite = ET.fromstring(report.to_junit()).find("testsuite")
    assert suite is not None and suite.get("failures") == "1" and "\\x1b" in ET.tostring(suite, encoding="unicode")


def test_require_complete_applies_to_a_batch(tmp_path: pathlib.Path) -> None:
    for name in ("a", "b"):
        (tmp_path / f"{name}.json").write_text(json.dumps(early_exit_case()))
    assert main(["run", str(tmp_path / "a.json"), str(tmp_path / "b.json"), "-j", "1"]) == 0
    assert main(["run", str(tmp_path / "a.json"), str(tmp_path / "b.json"), "-j", "1", "--require-complete"]) == 1


# -- an error is an error everywhere (issue 19, item 13) ----------------------------------------


def test_a_run_that_erred_is_an_error_in_junit_the_table_json_and_the_trace(tmp_path: pathlib.Path) -> None:
    """A leaf that raises: JUnit <error> (never <failure>), the table's execute row and the entry say error."""
    import btgen_pytrees
    from btgen_pytrees.run import run

    registry = broken_registry()
    data = case(entry("A", duration=0.5), entry("B", ["A"], action="broken"), entry("C", duration=2),
                criteria=[crit("R1", "record", "x <= 1")], signals={"x": 0})  # fmt: skip
    lines: list[str] = []
    loaded = btgen_pytrees.load(data, registry=registry)
    report = run(loaded, registry=registry, trace=lines.append)
    assert (report.verdict, report.message) == ("error", "B raised RuntimeError: motor driver offline")
    assert [(e.id, e.status) for e in report.execute] == [("A", "success"), ("B", "error"), ("C", "stopped")]
    failures, errors, _ = junit_counts(report.to_junit())
    assert (failures, errors) == (0, 1)
    execute = ET.fromstring(report.to_junit()).find("testsuite/testcase[@name='execute']")
    assert execute is not None and execute.find("failure") is None
    assert execute.find("error").get("message") == "B: RuntimeError: motor driver offline"  # type: ignore[union-attr]
    row = next(line for line in report.table().splitlines() if line.startswith("execute"))
    assert row.split()[4:6] == ["error", "0.5"] and "fail" not in row.split()
    assert "ERROR after 0.5 s" in report.table()
    jsonschema.validate(report.to_dict(), REPORT_SCHEMA)
    assert report.to_dict()["execute"][1]["status"] == "error"
    assert "         0.5  error    B  RuntimeError: motor driver offline" in lines
    assert lines[-1].split() == ["0.5", "end", "error"]
    pytest.importorskip("matplotlib")  # the dev extra's: the run plot notes the error in red
    from btgen_pytrees.run.plot import plot_bytes

    texts = " ".join(t.text or "" for t in ET.fromstring(plot_bytes(report, loaded, "svg")).iter("{http://www.w3.org/2000/svg}text"))
    assert "error: RuntimeError: motor driver offline" in texts and "failed:" not in texts


def test_a_system_that_fails_outside_any_leaf_is_an_error_row_too() -> None:
    """No entry raised (the system failed between ticks): the execute row still says error, with the run's message."""
    import btgen_pytrees
    from test_systems import Counter, registry

    from btgen_pytrees.run import run_tree
    from btgen_pytrees.systems import SystemSpec

    reg = registry()
    loaded = btgen_pytrees.load(case(entry("H", duration=1)), registry=reg, system=SystemSpec("counter"))
    report = run_tree(btgen_pytrees.generate(loaded, registry=reg), loaded, system=Counter(loaded.tick, fail_at="tick", fail_tick=2))
    assert report.verdict == "error"
    row = next(line for line in report.table().splitlines() if line.startswith("execute"))
    assert row.split()[4] == "error" and "the simulator ended early" in row
    assert junit_counts(report.to_junit())[:2] == (0, 1)
