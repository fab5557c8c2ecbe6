"""Outputs are always well-formed and safe to print (issue 13 class 4).

Any text a test case carries - its name, description, entry and criterion
names - may hold control characters, bidi overrides, characters XML forbids or
``$``. Whatever it holds: nothing printed contains a character a terminal acts
on, the JSON report parses as strict JSON, and JUnit, BT.CPP XML and the plot's
SVG are well-formed. Numbers beyond ±1e300 (``1e999`` is infinity) are refused
at load time, so no report can hold ``Infinity`` or ``NaN``.
"""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from helpers import case, crit, entry
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import btgen_pytrees
from btgen_pytrees import cli
from btgen_pytrees.errors import UNSAFE, XML_FORBIDDEN

ROOT = pathlib.Path(__file__).resolve().parent.parent

NASTY = "\x00\x07\x08\x0b\x0c\x1b\x7f\x85\x9b\u061c\u200e\u202a\u202e\u2066\u2069\u2028\u2029\ufeff\ufffe$\\<&\"'"
texts = st.text(alphabet=st.sampled_from(NASTY) | st.characters(blacklist_categories=("Cs",)), min_size=1, max_size=40)


def strict_json(text: str) -> object:
    def refuse(name: str) -> None:
        raise ValueError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)


def visible(text: str) -> None:
    """Nothing in *text* a terminal would act on (newlines between lines are fine)."""
    bad = [ch for ch in text.replace("\n", "") if UNSAFE.match(ch)]
    assert not bad, bad[:5]


def nasty_case(name: str, label: str, description: str) -> dict[str, object]:
    data = case(entry("A", action="set", signal="speed", value=3), entry("B", ["A"]),
                criteria=[crit("R", "record", "speed <= 2", name=label), crit("F", "final", "speed == 3")],
                name=name, description=description, signals={"speed": 0})  # fmt: skip
    data["execute"][0]["name"] = label  # type: ignore[index]
    return data


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=texts, label=texts, description=texts)
def test_whatever_a_name_holds_outputs_stay_well_formed_and_printing_safe(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], name: str, label: str, description: str
) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps(nasty_case(name, label, description)), encoding="utf-8")
    report, junit, tree = tmp_path / "r.json", tmp_path / "j.xml", tmp_path / "t.xml"
    assert cli.main(["run", str(path), "--json", str(report), "--junit", str(junit), "--trace"]) == 1
    assert cli.main(["show", str(path), "-f", "btcpp", "-o", str(tree)]) == 0
    for fmt in ("unicode", "ascii", "json", "btcpp", "dot", "matrix"):
        assert cli.main(["show", str(path), "-f", fmt]) == 0
        out = capsys.readouterr().out
        visible(out)
        if fmt == "json":
            assert strict_json(out)["name"] == name  # type: ignore[index]
        if fmt == "btcpp":
            ET.fromstring(out.split("\n", 1)[1])
    captured = capsys.readouterr()
    visible(captured.out)
    visible(captured.err)
    assert strict_json(report.read_text(encoding="utf-8"))["verdict"] == "fail"  # type: ignore[index]
    ET.parse(junit)
    ET.parse(tree)


@pytest.mark.parametrize("name", ["cost $5 and $6", "$\\frac{1}{0}$", "t\x1b[8m: PASS", "a\x00b\ufffe"])
def test_plots_take_names_literally(tmp_path: pathlib.Path, name: str) -> None:
    pytest.importorskip("matplotlib")
    from btgen_pytrees.run import run
    from btgen_pytrees.run.plot import plot_bytes

    data = nasty_case(name, name, name)
    loaded = btgen_pytrees.load(data)
    report = run(loaded)
    svg = plot_bytes(report, loaded, "svg").decode("utf-8")
    ET.fromstring(svg)
    if "$" in name:
        assert name.replace("\\", "\\\\") in svg or name in svg  # drawn as text, not as math
    page = plot_bytes(report, loaded, "html").decode("utf-8")
    assert not XML_FORBIDDEN.search(page) and not UNSAFE.search(page.split("<svg", 1)[0].replace("\n", ""))
    assert plot_bytes(report, loaded, "png").startswith(b"\x89PNG")


def test_svg_tree_view_is_well_formed(tmp_path: pathlib.Path) -> None:
    if not shutil.which("dot") and not os.environ.get("CI"):
        pytest.skip("needs Graphviz")
    path = tmp_path / "c.json"
    path.write_text(json.dumps(nasty_case("t\x1b\x00", "x\x0b\u202e", "d")))
    out = tmp_path / "t.svg"
    assert cli.main(["show", str(path), "-o", str(out)]) == 0
    ET.parse(out)


@pytest.mark.parametrize("where, text", [
    ("/signals/speed", '"speed": 1e999'),
    ("/signals/speed", '"speed": -1e999'),
    ("/signals/speed", '"speed": -1.7e308'),
    ("/signals/speed", '"speed": ' + str(135 * 10**306)),
    ("/execute/0/params/value", '"value": 1e999'),
    ("/execute/1/params/duration", '"duration": 1e301'),
])  # fmt: skip
def test_numbers_beyond_the_limit_are_refused_at_load_time(tmp_path: pathlib.Path, where: str, text: str) -> None:
    raw = json.dumps(case(entry("A", action="set", signal="speed", value=1), entry("B", ["A"], duration=1),
                          signals={"speed": 0}))  # fmt: skip
    key = text.split(":")[0]
    raw = raw.replace({'"speed"': '"speed": 0', '"value"': '"value": 1', '"duration"': '"duration": 1'}[key], text, 1)
    path = tmp_path / "c.json"
    path.write_text(raw)
    with pytest.raises(btgen_pytrees.InvalidTestCase) as info:
        btgen_pytrees.load(path)
    [problem] = info.value.problems
    assert problem.pointer == where and "number too large" in problem.message


def test_a_ramp_at_the_limit_stays_finite(tmp_path: pathlib.Path) -> None:
    from btgen_pytrees.run import run

    data = case(entry("A", action="ramp", signal="x", to=1e300, duration=1), signals={"x": -1e300},
                criteria=[crit("F", "final", "x == 1e300")])  # fmt: skip
    report = run(btgen_pytrees.load(data))
    text = report.to_json()
    strict_json(text)
    assert report.verdict == "pass"


def test_non_utf8_file_names_in_a_batch(tmp_path: pathlib.Path) -> None:
    (tmp_path / "in").mkdir()
    folder = os.fsencode(tmp_path / "in")
    for raw in (b"caf\xe9.json", b"ok.json", b"\x1b[8m.json"):
        with open(os.path.join(folder, raw), "wb") as fh:
            fh.write((ROOT / "examples" / "fig1.json").read_bytes())
    out = tmp_path / "out"
    env = dict(os.environ, LC_ALL="C", PYTHONIOENCODING="")
    result = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", str(tmp_path / "in"), "--out-dir", str(out)],
                            capture_output=True, timeout=120, cwd=ROOT, env=env)  # fmt: skip
    assert result.returncode == 0, result.stderr
    text = result.stdout.decode("utf-8", "replace")
    assert "caf\\xe9.json" in text and "\\x1b[8m.json" in text and "3 files: 3 ok" in text
    assert b"\x1b" not in result.stdout and b"\xe9" not in result.stdout
    assert len(list(out.iterdir())) == 6


def test_reports_to_stdout_are_escaped_and_still_parse(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps(nasty_case("t\u202e\x85x", "n\u2028", "d")))
    for option, parse in (("--json", strict_json), ("--junit", ET.fromstring)):
        result = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", str(path), option, "-"],
                                capture_output=True, text=True, timeout=60, cwd=ROOT)  # fmt: skip
        assert result.returncode == 1
        document = result.stdout  # the document only: the table went to stderr
        assert "criterion" in result.stderr
        visible(result.stdout)
        visible(result.stderr)
        parse(document.split("\n", 1)[1] if option == "--junit" else document)
