"""Margins: every criterion's signed robustness (signal temporal logic), checked independently.

The values the oracles compute while the tree ticks must be the robustness of the same signal values
computed from STL's definitions - per comparison, through ``&&``/``||``/``!``, and over the ticks
each criterion judged (``always``) - by a reference written here from those definitions, and by
rtamt (https://github.com/nickovic/rtamt, an STL monitor; the ``dev`` extra), which must agree.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import btgen_pytrees
from btgen_pytrees.expressions import ExpressionError, conjunction, disjunction, parse
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.run import run
from btgen_pytrees.load.variations import format_value
from btgen_pytrees.systems import SystemInfo, SystemSpec

from helpers import case, crit, entry, run_case

try:
    import rtamt
except ImportError:  # the dev extra installs it (not on Python 3.13, where it does not import)
    rtamt = None
REPORT_SCHEMA = json.loads((Path(__file__).resolve().parent.parent / "schemas" / "report.schema.json").read_text())

# -- a system that plays a trace back: x[k], y[k] on tick k --------------------------------------


class Playback:
    def __init__(self, tick: float, trace: dict[str, list[float]]):
        self.step, self.trace, self.k = tick, trace, 0

    def start(self, env: Any) -> None:
        self.k = 0

    def now(self) -> float:
        return round(self.k * self.step, 9)

    def publish(self, env: Any) -> None:
        for name, series in self.trace.items():
            env.publish(name, series[min(self.k, len(series) - 1)])

    def tick(self) -> None:
        self.k += 1

    def close(self) -> None:
        pass


class PlaybackType:
    name = "playback"
    options = ()

    def __init__(self, trace: dict[str, list[float]]):
        self.trace = trace

    def describe(self, spec: SystemSpec, case_data: Any) -> SystemInfo:
        return SystemInfo(signals=tuple(self.trace))

    def create(self, spec: SystemSpec, case: Any) -> Playback:
        return Playback(case.tick, self.trace)


def played(data: dict[str, Any], trace: dict[str, list[float]]) -> Any:
    registry = default_registry()
    registry.register_system(PlaybackType(trace))
    data = {**data, "system": {"type": "playback"}}
    return run(btgen_pytrees.load(data, registry=registry), registry=registry)


# -- random formulas: in our language, in rtamt's, and as a reference written from STL's definitions --

OPS = ["<=", "<", ">=", ">", "==", "!="]
RTAMT_OP = {"!=": "!=="}
RHO: dict[str, Any] = {  # the robustness of a comparison l OP r (Donze & Maler; Fainekos & Pappas)
    "<=": lambda l, r: r - l, "<": lambda l, r: r - l, ">=": lambda l, r: l - r, ">": lambda l, r: l - r,
    "==": lambda l, r: -abs(l - r), "!=": lambda l, r: abs(l - r),
}  # fmt: skip
TERMS = [("x", "x", lambda x, y: x), ("y", "y", lambda x, y: y), ("x - y", "(x - y)", lambda x, y: x - y),
         ("abs(x)", "abs(x)", lambda x, y: abs(x)), ("x + y", "(x + y)", lambda x, y: x + y)]  # fmt: skip
CONSTANTS = [(str(c), str(c), lambda x, y, c=c: c) for c in (-1, 0, 0.5, 2)]
Formula = tuple[str, str, Any]  # ours, rtamt's, rho(x, y)


def _link(left: Any, op: str, right: Any) -> Formula:
    rho = RHO[op]
    return (f"{left[0]} {op} {right[0]}", f"({left[1]} {RTAMT_OP.get(op, op)} {right[1]})",
            lambda x, y: rho(left[2](x, y), right[2](x, y)))  # fmt: skip


@st.composite
def comparisons(draw: Any) -> Formula:
    left, op, right = draw(st.sampled_from(TERMS)), draw(st.sampled_from(OPS)), draw(st.sampled_from(TERMS[:2] + CONSTANTS))
    first = _link(left, op, right)
    if not draw(st.booleans()):
        return first
    op2, third = draw(st.sampled_from(OPS)), draw(st.sampled_from(TERMS))  # a chain l < m <= r: both links
    second = _link(right, op2, third)
    return (f"{first[0]} {op2} {third[0]}", f"({first[1]} and {second[1]})",
            lambda x, y: min(first[2](x, y), second[2](x, y)))  # fmt: skip


def formulas() -> st.SearchStrategy[Formula]:
    def extend(inner: st.SearchStrategy[Formula]) -> st.SearchStrategy[Formula]:
        both = st.tuples(inner, inner)
        return st.one_of(
            both.map(lambda p: (f"({p[0][0]}) && ({p[1][0]})", f"({p[0][1]} and {p[1][1]})",
                                lambda x, y: min(p[0][2](x, y), p[1][2](x, y)))),
            both.map(lambda p: (f"({p[0][0]}) || ({p[1][0]})", f"({p[0][1]} or {p[1][1]})",
                                lambda x, y: max(p[0][2](x, y), p[1][2](x, y)))),
            inner.map(lambda f: (f"!({f[0]})", f"(not {f[1]})", lambda x, y: -f[2](x, y))),
        )  # fmt: skip

    return st.recursive(comparisons(), extend, max_leaves=4)


def always(formula: Formula, trace: dict[str, list[float]], first: int, last: int) -> float:
    """The robustness of ``always(formula)`` over ticks first..last of *trace* (which holds its last
    values): the minimum over those ticks; rtamt, where it installs, must compute the same."""
    ticks = list(range(first, last + 1))
    x, y = ([float(trace[name][min(k, len(trace[name]) - 1)]) for k in ticks] for name in ("x", "y"))
    expected = min(formula[2](a, b) for a, b in zip(x, y))
    if rtamt is not None:
        spec = rtamt.StlDiscreteTimeSpecification()
        for name in ("x", "y", "out"):
            spec.declare_var(name, "float")
        spec.spec = f"out = always({formula[1]})"
        spec.parse()
        twice = 2 if len(ticks) == 1 else 1  # rtamt needs two samples: the same one twice
        data = {"time": list(range(len(ticks) * twice)), "x": x * twice, "y": y * twice}
        assert float(spec.evaluate(data)[0][1]) == expected, formula[1]
    return expected


def test_rtamt_checks_the_margins_where_it_runs() -> None:
    """rtamt (the dev extra; it does not import on Python 3.13, so not installed there) is the independent check."""
    if os.environ.get("CI") and sys.version_info < (3, 13):
        assert rtamt is not None, "pip install -e '.[dev]' installs rtamt"


VALUES = st.sampled_from([-2, -1, -0.5, 0, 0.25, 0.5, 1, 1.5, 2, 3])  # exact in binary: no rounding anywhere


@st.composite
def criteria(draw: Any, index: int) -> tuple[dict[str, Any], Formula]:
    formula = draw(formulas())
    kind = draw(st.sampled_from(["record", "period", "final"]))
    extra: dict[str, Any] = {}
    if kind == "period":
        start = draw(st.integers(0, 4))
        extra = {"from": start, "to": start + draw(st.integers(1, 4))}
    elif kind == "final":
        extra = {"at": draw(st.integers(0, 6))}
    return crit(f"{kind[0].upper()}{index}", kind, formula[0], **extra), formula


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    trace=st.integers(2, 10).flatmap(lambda n: st.fixed_dictionaries({"x": st.lists(VALUES, min_size=n, max_size=n),
                                                                      "y": st.lists(VALUES, min_size=n, max_size=n)})),  # fmt: skip
    items=st.integers(1, 3).flatmap(lambda n: st.tuples(*[criteria(i) for i in range(n)])),
    relation=st.sampled_from(["&&", "||", {"record": "&&", "others": "||"}, {"record": "||", "others": "&&"}]),
)
def test_every_criterions_margin_is_stl_robustness_over_the_ticks_it_judged(
    trace: dict[str, list[float]], items: tuple[tuple[dict[str, Any], Formula], ...], relation: Any
) -> None:
    data = case(entry("W", action="wait", duration=len(trace["x"]) - 1),
                criteria=[c for c, _ in items], relation=relation, tick=1, timeout=20)  # fmt: skip
    report = played(data, trace)
    assert report.verdict in ("pass", "fail"), report.message
    last = report.ticks - 1  # tick k is at k s; the run's last tick
    for (criterion, formula), result in zip(items, report.oracles):
        kind = criterion["type"]
        # the ticks it judged: from its start to its verdict (or to the end of the run, undecided)
        first = criterion.get("from", 0) if kind != "final" else criterion["at"]
        end = round(result.at) if result.verdict in ("pass", "fail") else last
        if kind == "final" and result.verdict == "inconclusive" or first > min(end, last):
            assert result.margin is None, result
            continue
        expected = always(formula, trace, first, end)
        assert result.margin == pytest.approx(expected, abs=1e-12), (criterion, result, trace)
        # the sign never contradicts the verdict
        assert not (result.verdict == "fail" and result.margin > 0)
        assert not (result.verdict == "pass" and result.margin < 0)
    # the oracle's margin: each group by its relation (min/max), the groups by &&
    groups: dict[str, list[Any]] = {}
    for o in report.oracles:
        groups.setdefault(o.group, []).append(o)
    combined = conjunction([(disjunction if g[0].relation == "||" else conjunction)([o.margin for o in g]) for g in groups.values()])
    assert report.margin == combined
    if report.margin is not None:  # the oracle decided this run: the signs agree with the verdict
        assert not (report.verdict == "pass" and report.margin < 0)
        assert not (report.verdict == "fail" and report.margin > 0)


# -- the expression's margin: its truth is evaluate()'s, its sign never contradicts it --------------

ATOMS = ["x", "y", "b", "1", "0", "2.5", "true", "false", "x / y", "abs(x)", "max(x, y)", "x % 2"]


def expressions() -> st.SearchStrategy[str]:
    compare = st.tuples(st.sampled_from(ATOMS), st.sampled_from(OPS), st.sampled_from(ATOMS)).map(" ".join)
    chain = st.tuples(st.sampled_from(ATOMS), st.sampled_from(OPS), st.sampled_from(ATOMS), st.sampled_from(OPS),
                      st.sampled_from(ATOMS)).map(" ".join)  # fmt: skip
    leaf = compare | chain | st.sampled_from(ATOMS)

    def extend(inner: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
        return st.one_of(
            st.tuples(inner, inner).map(lambda p: f"({p[0]}) && ({p[1]})"),
            st.tuples(inner, inner).map(lambda p: f"({p[0]}) || ({p[1]})"),
            inner.map(lambda e: f"!({e})"),
        )

    return st.recursive(leaf, extend, max_leaves=5)


ANY_VALUE = st.sampled_from([0, 1, -1, 2, 0.5, -0.0, True, False, math.inf, -math.inf, math.nan, 10**400, 1e308, -1e308])


@settings(max_examples=400, deadline=None)
@given(text=expressions(), x=ANY_VALUE, y=ANY_VALUE, b=ANY_VALUE)
def test_judge_gives_evaluates_truth_and_a_margin_of_the_same_sign(text: str, x: Any, y: Any, b: Any) -> None:
    expression = parse(text)
    values = {"x": x, "y": y, "b": b}
    try:
        truth = bool(expression.evaluate(values))
    except ExpressionError as exc:
        with pytest.raises(ExpressionError) as raised:
            expression.judge(values)
        assert str(raised.value) == str(exc)
        return
    judged, margin = expression.judge(values)
    assert judged == truth
    assert isinstance(margin, float) and not math.isnan(margin)
    assert margin >= 0 if truth else margin <= 0
    assert math.copysign(1, margin) > 0 or margin != 0  # never -0.0 (JSON would show it)


@pytest.mark.parametrize(
    ("text", "values", "expected"),
    [
        ("speed <= 30", {"speed": 32.5}, (False, -2.5)),
        ("speed < 30", {"speed": 30}, (False, 0.0)),  # on the boundary: false, by nothing
        ("speed >= 30", {"speed": 31}, (True, 1.0)),
        ("speed == 30", {"speed": 30}, (True, 0.0)),  # an equality has no room to spare
        ("speed == 30", {"speed": 29}, (False, -1.0)),
        ("speed != 30", {"speed": 29}, (True, 1.0)),
        ("speed != 30", {"speed": 30}, (False, 0.0)),
        ("0 <= x < 5", {"x": 4}, (True, 1.0)),  # a chain: its smallest link
        ("0 <= x < 5", {"x": 7}, (False, -2.0)),
        ("x > 1 && y > 1", {"x": 3, "y": 2}, (True, 1.0)),
        ("x > 1 || y > 1", {"x": 3, "y": 0}, (True, 2.0)),
        ("!(x > 1)", {"x": 3}, (False, -2.0)),
        ("brake", {"brake": True}, (True, math.inf)),  # a boolean: no distance to its boundary
        ("brake", {"brake": False}, (False, -math.inf)),
        ("brake == 1", {"brake": False}, (False, -1.0)),  # booleans count as 0 and 1
        ("x <= 3 && brake", {"x": 1, "brake": True}, (True, 2.0)),
        ("gap >= 10", {"gap": math.inf}, (True, math.inf)),  # SUMO's gap without a leader
        ("gap == gap", {"gap": math.inf}, (True, 0.0)),  # inf - inf: equal sides
        ("gap <= 10", {"gap": math.nan}, (False, -math.inf)),  # a NaN side: a boolean
        ("x > 0 && 1 / x > 2", {"x": 0}, (False, 0.0)),  # the short-circuited operand is left out
        ("x <= 1e308 * 10", {"x": 0}, (True, math.inf)),
    ],
)
def test_margins_of_the_language(text: str, values: dict[str, Any], expected: tuple[bool, float]) -> None:
    assert parse(text).judge(values) == expected


def test_unknown_margins_combine_as_unknown_unless_the_known_ones_decide() -> None:
    assert conjunction([1.0, 2.0]) == 1.0 and disjunction([1.0, -2.0]) == 1.0
    assert conjunction([None, -1.0]) == -1.0 and conjunction([None, 1.0]) is None and conjunction([None, 0.0]) is None
    assert disjunction([None, 1.0]) == 1.0 and disjunction([None, -1.0]) is None
    assert conjunction([]) is None and disjunction([None]) is None


# -- margins in every output -----------------------------------------------------------------------


def fig1_case(limit: float = 15, relation: Any = "&&") -> dict[str, Any]:
    return case(
        entry("B2", action="ramp", signal="speed", to=20, duration=2),
        criteria=[crit("R1", "record", f"speed <= {limit}"), crit("P1", "period", "speed >= -1", **{"from": 0, "to": 1}),
                  crit("F1", "final", "speed == 20")],  # fmt: skip
        relation=relation, signals={"speed": 0}, tick=0.1,
    )


def test_a_report_carries_each_criterions_margin_and_the_oracles_in_json_junit_and_python() -> None:
    report = run_case(fig1_case())
    assert report.verdict == "fail"
    margins = {o.id: o.margin for o in report.oracles}
    assert margins["R1"] == -1.0  # speed <= 15 false by 1 at 1.6 s
    assert margins["P1"] == 1.0 and report.oracles[1].verdict == "pass"  # min over [0, 1] of speed + 1
    assert margins["F1"] is None  # never judged: the run ended first
    assert report.margin == -1.0
    data = report.to_dict()
    assert list(data)[:4] == ["test", "source", "verdict", "margin"] and data["margin"] == -1.0
    assert [list(o)[:6] for o in data["oracles"]][0] == ["id", "name", "type", "expect", "verdict", "margin"]
    assert [o["margin"] for o in data["oracles"]] == [-1.0, 1.0, None]
    jsonschema.validate(json.loads(report.to_json()), REPORT_SCHEMA)
    xml = report.to_junit()
    assert '<property name="margin" value="-1.0" />' in xml.split("<testcase")[0]  # the suite's: the oracle's
    r1 = next(part for part in xml.split("<testcase") if 'name="R1' in part)
    assert '<property name="margin" value="-1.0" />' in r1
    f1 = next(part for part in xml.split("<testcase") if 'name="F1' in part)
    assert "margin" not in f1


def test_an_or_group_takes_its_best_member_and_infinite_margins_are_strings_in_json() -> None:
    data = case(
        entry("B2", action="ramp", signal="speed", to=20, duration=2),
        criteria=[crit("F1", "final", "speed >= 25"), crit("F2", "final", "speed >= 18"), crit("F3", "final", "ok")],
        relation="||", signals={"speed": 0, "ok": True},
    )
    report = run_case(data)
    assert report.verdict == "pass"
    assert [o.margin for o in report.oracles] == [-5.0, 2.0, math.inf]
    assert report.margin == math.inf
    out = json.loads(report.to_json())
    assert out["margin"] == "inf" and [o["margin"] for o in out["oracles"]] == [-5.0, 2.0, "inf"]


def test_an_expression_that_cannot_be_evaluated_leaves_the_margin_unknown() -> None:
    report = run_case(case(entry("W", action="wait", duration=1), criteria=[crit("F1", "final", "1 / speed >= 1")],
                           signals={"speed": 0}))  # fmt: skip
    assert report.verdict == "fail" and report.oracles[0].margin is None and report.margin is None
    assert json.loads(report.to_json())["oracles"][0]["margin"] is None


# -- margins in a sweep: rows, order, summary, map, JUnit -------------------------------------------

ROOT = Path(__file__).resolve().parent.parent


def cli(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True, timeout=300, cwd=cwd)


def test_every_sweep_row_has_its_margin_and_the_worst_come_first(tmp_path: Path) -> None:
    out, junit = tmp_path / "s.json", tmp_path / "s.xml"
    result = cli("run", str(ROOT / "examples" / "fig1_sweep.json"), "--jobs", "1", "--json", str(out), "--junit", str(junit))
    assert result.returncode == 1, result.stderr
    sweep_report = json.loads(out.read_text())
    jsonschema.validate(sweep_report, json.loads((ROOT / "schemas" / "sweep-report.schema.json").read_text()))
    rows = sweep_report["rows"]
    for row in rows:  # R1 (speed <= limit) decides: its margin is the row's
        top, limit = row["parameters"]["top_speed"], row["parameters"]["limit"]
        assert [list(o)[:3] for o in row["oracles"]] == [["id", "verdict", "margin"]]
        assert row["margin"] == row["oracles"][0]["margin"]
        if row["verdict"] == "pass":
            assert row["margin"] == limit - top  # the ramp reaches its top speed: limit - top to spare
        else:
            assert row["margin"] < 0 and f"false by {format_value(-row['margin'])} " in row["message"]
    lines = result.stdout.splitlines()
    shown = [line.split()[0] for line in lines[3:13]]
    by_margin = sorted((r for r in rows if r["verdict"] == "fail"), key=lambda r: (r["margin"], r["duration"], r["index"]))
    assert shown == [r["label"] for r in by_margin]  # the most clearly failed first
    assert lines[3].endswith("(margin -2)")
    assert xml_margins(junit.read_text()) == [format_value(r["margin"]) for r in rows]


def xml_margins(xml: str) -> list[str]:
    import xml.etree.ElementTree as ET

    return [format_value(float(p.get("value"))) for p in ET.fromstring(xml).iter("property") if p.get("name") == "margin"]


def test_a_sweep_that_passes_lists_the_variations_closest_to_failing_and_maps_margins(tmp_path: Path) -> None:
    data = json.loads((ROOT / "examples" / "fig1_sweep.json").read_text())
    data["variations"] = {"top_speed": [10, 20, 30], "limit": [31, 40]}
    path, svg = tmp_path / "close.json", tmp_path / "map.svg"
    plot = ["--plot", str(svg)] if importlib.util.find_spec("matplotlib") else []
    result = cli("run", str(path.write_text(json.dumps(data)) and path), "--jobs", "1", *plot)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[1:] == [
        "",
        "closest to failing (lowest objective, as falsify's):",
        "  top_speed=30,limit=31  PASS     (objective 0.1073, margin 1)",
        "  top_speed=30,limit=40  PASS     (objective 1.073, margin 10)",
        "  top_speed=20,limit=31  PASS     (objective 1.18, margin 11)",
    ]
    if plot:  # coloured by the objective: the colour bar is drawn
        assert "objective (margins scaled, as falsify" in svg.read_text()


def test_a_criterion_without_a_gradient_leaves_the_map_and_closest_to_failing_to_the_others(tmp_path: Path) -> None:
    """A criterion whose margin is 0 on every passing run (as a collision count's is) pinned the oracle's
    margin at 0: the map was one pale colour and "closest to failing" listed arbitrary rows. The map and
    the list use falsify's objective instead: the graded criterion (R1, the speed limit) orders them."""
    from btgen_pytrees.sweep.objective import document_groups
    from btgen_pytrees.sweep.report import SweepReport

    data = json.loads((ROOT / "examples" / "fig1_sweep.json").read_text())
    data["variations"] = {"top_speed": [10, 20, 30], "limit": [31, 40]}
    data["oracle"]["criteria"].append({"id": "F9", "type": "final", "expect": "mode - 1 == 0"})  # 0 on every passing run
    path, svg = tmp_path / "flat.json", tmp_path / "map.svg"
    path.write_text(json.dumps(data))
    plot = ["--plot", str(svg)] if importlib.util.find_spec("matplotlib") else []
    result = cli("run", str(path), "--jobs", "1", "--json", str(tmp_path / "r.json"), *plot)
    assert result.returncode == 0, result.stderr
    rows = json.loads((tmp_path / "r.json").read_text())["rows"]
    assert {r["margin"] for r in rows} == {0}  # the oracle's margin says nothing of how close a run came
    assert [line.split()[0] for line in result.stdout.splitlines()[3:6]] == ["top_speed=30,limit=31", "top_speed=30,limit=40", "top_speed=20,limit=31"]
    report = SweepReport("flat", str(path), {}, ("top_speed", "limit"), rows=rows, groups=document_groups(data))
    scores = report.objectives()
    assert len(set(scores)) == len(rows)  # every passing run its own colour
    if plot:
        assert "objective (margins scaled" in svg.read_text()
