"""Temporal (STL) criteria: the monitor's robustness equals rtamt's, its verdict and `decided` are right,
the loader's words, and runs that tick the tree.

rtamt is the reference: its discrete-time offline interpreter evaluates the same formula, built as rtamt's
own syntax nodes (its text parser costs about 0.2 s a formula; the nodes are what that parser makes), on
the same trace. `decided` is compared with a brute force: for every prefix of the trace, the formula's
interval when every later sample may be anything, worked out by the definitions (recursively, no stream).
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
from pathlib import Path

import jsonschema
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from btgen_pytrees import load
from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.formulas import FormulaError, parse
from btgen_pytrees.monitor import Monitor, bound_at, bound_streamed, decided, holds
from btgen_pytrees.run import run

rtamt = pytest.importorskip("rtamt")
from rtamt.semantics.enumerations.comp_oper import StlComparisonOperator as Op  # noqa: E402
from rtamt.semantics.interval.interval import Interval  # noqa: E402
from rtamt.syntax.node.ltl.always import Always  # noqa: E402
from rtamt.syntax.node.ltl.conjunction import Conjunction  # noqa: E402
from rtamt.syntax.node.ltl.constant import Constant  # noqa: E402
from rtamt.syntax.node.ltl.disjunction import Disjunction  # noqa: E402
from rtamt.syntax.node.ltl.historically import Historically  # noqa: E402
from rtamt.syntax.node.ltl.implies import Implies  # noqa: E402
from rtamt.syntax.node.ltl.neg import Neg  # noqa: E402
from rtamt.syntax.node.ltl.once import Once  # noqa: E402
from rtamt.syntax.node.ltl.predicate import Predicate  # noqa: E402
from rtamt.syntax.node.ltl.since import Since  # noqa: E402
from rtamt.syntax.node.ltl.variable import Variable  # noqa: E402
from rtamt.syntax.node.stl.timed_always import TimedAlways  # noqa: E402
from rtamt.syntax.node.stl.timed_eventually import TimedEventually  # noqa: E402
from rtamt.syntax.node.stl.timed_historically import TimedHistorically  # noqa: E402
from rtamt.syntax.node.stl.timed_once import TimedOnce  # noqa: E402
from rtamt.syntax.node.stl.timed_since import TimedSince  # noqa: E402
from rtamt.syntax.node.stl.timed_until import TimedUntil  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
INF = math.inf
TICK = 0.5  # the formulas' windows are in seconds, multiples of it; rtamt's in samples
COMPARE = {"<": Op.LESS, "<=": Op.LEQ, ">": Op.GREATER, ">=": Op.GEQ}
OPS = ["not", "and", "or", "implies", "always", "eventually", "until", "once", "historically", "since",
       "always*", "once*", "historically*", "since*"]  # fmt: skip  (* : without a window)


# -- random formulas as trees: (op, window, children) or ("atom", (signal, comparison, constant)) ---------

@st.composite
def formulas(draw, depth=4):
    if depth == 0 or draw(st.integers(0, 4)) == 0:
        return ("atom", (draw(st.sampled_from("xy")), draw(st.sampled_from(sorted(COMPARE))), draw(st.integers(-2, 2))))
    op = draw(st.sampled_from(OPS))
    low = draw(st.integers(0, 2))
    timed = op in ("always", "eventually", "until", "once", "historically", "since")
    window = (low, low + draw(st.integers(0, 2))) if timed else None
    arity = 2 if op.rstrip("*") in ("and", "or", "implies", "until", "since") else 1
    return (op.rstrip("*"), window, tuple(draw(formulas(depth=depth - 1)) for _ in range(arity)))


def text(f) -> str:
    op = f[0]
    if op == "atom":
        signal, comparison, constant = f[1]
        return f"{signal} {comparison} {constant}"
    _, window, kids = f
    w = "" if window is None else f"[{window[0] * TICK:g}, {window[1] * TICK:g}]"
    parts = [f"({text(k)})" for k in kids]
    if op == "not":
        return f"!{parts[0]}"
    if op in ("and", "or", "implies"):
        return f" {dict(And='&&', Or='||')[op.title()] if op != 'implies' else '->'} ".join(parts)
    if op in ("until", "since"):
        return f"{parts[0]} {op}{w} {parts[1]}"
    return f"{op}{w}{parts[0]}"


def rtamt_node(f):
    op = f[0]
    if op == "atom":
        signal, comparison, constant = f[1]
        return Predicate(Variable(signal), Constant(float(constant)), COMPARE[comparison])
    _, window, kids = f
    nodes = [rtamt_node(k) for k in kids]
    interval = Interval(window[0], window[1], "", "") if window else None
    simple = {"not": Neg, "always": Always, "once": Once, "historically": Historically}
    timed = {"always": TimedAlways, "eventually": TimedEventually, "once": TimedOnce, "historically": TimedHistorically}
    if op in ("and", "or", "implies"):
        return {"and": Conjunction, "or": Disjunction, "implies": Implies}[op](*nodes)
    if op in ("until", "since"):
        return (TimedUntil if op == "until" else TimedSince)(*nodes, interval) if window else Since(*nodes)
    return timed[op](nodes[0], interval) if window else simple[op](nodes[0])


def span(f) -> float:
    if f[0] == "atom":
        return 0
    _, window, kids = f
    inner = max(span(k) for k in kids)
    if f[0] in ("always", "eventually", "until"):
        return INF if window is None else inner + window[1]
    return inner


# -- the brute force: the definitions, recursively --------------------------------------------------------

def atom_value(f, trace, t):
    signal, comparison, constant = f[1]
    v = trace[signal][t]
    return constant - v if comparison in ("<", "<=") else v - constant


def interval(f, trace, t, k, end):
    """The robustness of *f* at *t* when samples after *k* are unknown (the trace ends at *end*, if not None)."""
    op = f[0]
    if op == "atom":
        if t <= k or end is not None:
            v = atom_value(f, trace, t)
            return v, v
        return -INF, INF
    _, window, kids = f
    sub = [lambda u, c=c: interval(c, trace, u, k, end) for c in kids]
    if op == "not":
        lo, hi = sub[0](t)
        return -hi, -lo
    if op in ("and", "or", "implies"):
        a, b = sub[0](t), sub[1](t)
        if op == "implies":
            a = (-a[1], -a[0])
        pick = min if op == "and" else max
        return pick(a[0], b[0]), pick(a[1], b[1])
    last = end if end is not None else INF
    if op in ("always", "eventually"):
        larger = op == "eventually"
        unknown_rest = window is None and end is None
        first = t + (window[0] if window else 0)
        top = int(min(t + window[1], last)) if window else (k if unknown_rest else end)
        vals = [sub[0](u) for u in range(first, max(top, first - 1) + 1)]
        if unknown_rest:
            vals.append((-INF, INF))
        pick = max if larger else min
        empty = -INF if larger else INF
        return pick([v[0] for v in vals], default=empty), pick([v[1] for v in vals], default=empty)
    if op in ("once", "historically"):
        first = 0 if window is None else max(t - window[1], 0)
        vals = [sub[0](u) for u in range(first, t - (window[0] if window else 0) + 1)]
        pick = max if op == "once" else min
        empty = -INF if op == "once" else INF
        return pick([v[0] for v in vals], default=empty), pick([v[1] for v in vals], default=empty)
    if op == "until":
        best = (-INF, -INF)
        for u in range(t + window[0], int(min(t + window[1], last)) + 1):
            left = [sub[0](w) for w in range(t, u)]
            right = sub[1](u)
            lo = min([right[0], *(v[0] for v in left)])
            hi = min([right[1], *(v[1] for v in left)])
            best = (max(best[0], lo), max(best[1], hi))
        return best
    first = 0 if window is None else max(t - window[1], 0)
    best = (-INF, -INF)
    for u in range(first, t - (window[0] if window else 0) + 1):
        left = [sub[0](w) for w in range(u + 1, t + 1)]
        right = sub[1](u)
        best = (max(best[0], min([right[0], *(v[0] for v in left)])), max(best[1], min([right[1], *(v[1] for v in left)])))
    return best


def truth(f, trace, t, end):
    """Boolean semantics (strict comparisons strict), by the definitions."""
    op = f[0]
    if op == "atom":
        signal, comparison, constant = f[1]
        v = trace[signal][t]
        return {"<": v < constant, "<=": v <= constant, ">": v > constant, ">=": v >= constant}[comparison]
    _, window, kids = f
    if op == "not":
        return not truth(kids[0], trace, t, end)
    if op in ("and", "or", "implies"):
        a, b = truth(kids[0], trace, t, end), truth(kids[1], trace, t, end)
        return a and b if op == "and" else a or b if op == "or" else (not a) or b
    a = window[0] if window else 0
    if op in ("always", "eventually"):
        top = min(t + window[1], end) if window else end
        test = all if op == "always" else any
        return test(truth(kids[0], trace, u, end) for u in range(t + a, top + 1))
    if op in ("once", "historically"):
        first = 0 if window is None else max(t - window[1], 0)
        test = any if op == "once" else all
        return test(truth(kids[0], trace, u, end) for u in range(first, t - a + 1))
    if op == "until":
        return any(truth(kids[1], trace, u, end) and all(truth(kids[0], trace, w, end) for w in range(t, u))
                   for u in range(t + a, min(t + window[1], end) + 1))  # fmt: skip
    first = 0 if window is None else max(t - window[1], 0)
    return any(truth(kids[1], trace, u, end) and all(truth(kids[0], trace, w, end) for w in range(u + 1, t + 1))
               for u in range(first, t - a + 1))  # fmt: skip


@pytest.fixture(scope="module")
def interpreter():
    spec = rtamt.StlDiscreteTimeOfflineSpecification()
    spec.declare_var("x", "float")
    spec.declare_var("y", "float")
    spec.spec = "x >= 0"
    spec.parse()
    spec.evaluate({"time": [0, 1], "x": [0.0, 0.0], "y": [0.0, 0.0]})  # gives the interpreter its tree
    return spec.offline_interpreter


VALUES = st.sampled_from([-2.5, -2.0, -1.0, -0.5, 0.0, 0.0, 1.0, 1.5, 2.0, 3.25])


@st.composite
def cases(draw):
    f = draw(formulas())
    anchor = draw(st.integers(0, 3))
    reach = span(f)
    length = (anchor + reach + 1 + draw(st.integers(0, 2))) if reach != INF else anchor + 1 + draw(st.integers(0, 6))
    length = max(int(length), 2)
    trace = {s: draw(st.lists(VALUES, min_size=length, max_size=length)) for s in "xy"}
    return f, anchor, trace


@settings(max_examples=2000, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])
@given(cases())
def test_margin_equals_rtamt_verdict_and_decided(interpreter, case):
    f, anchor, trace = case
    n = len(trace["x"])
    formula = parse(text(f))
    monitor = Monitor(formula, TICK)
    for t in range(n):
        margins = []
        for expression in monitor.expressions:
            ok, margin = expression.judge({"x": trace["x"][t], "y": trace["y"][t]})
            margins.append(margin if margin else (0.0 if ok else -0.0))
        monitor.step(margins)
    bounded = span(f) != INF
    if not bounded:
        monitor.finish()
    ours = monitor.root.values
    # rtamt on the same trace
    interpreter.ast.var_object_dict["x"] = trace["x"]
    interpreter.ast.var_object_dict["y"] = trace["y"]
    interpreter.ast.offline_results = {}
    reference = interpreter.visit(rtamt_node(f), n)
    margin, expected = ours[anchor], reference[anchor]
    assert margin == expected or abs(margin - expected) <= 1e-9 * max(1.0, abs(expected)), (text(f), margin, expected)
    for t, value in enumerate(ours):  # every value emitted (each once its window was known), not just the anchor's
        assert value == reference[t] or abs(value - reference[t]) <= 1e-9 * max(1.0, abs(reference[t])), (text(f), t)
    # the verdict: the margin's sign; on 0, the formula's truth
    verdict = margin > 0 or margin == 0 and holds(monitor.root, anchor)
    assert verdict == truth(f, trace, anchor, n - 1), text(f)
    # decided: the first prefix after which the interval excludes 0 (or where the value became known)
    last = anchor + int(span(f)) if bounded else n - 1
    end = None if bounded else n - 1
    brute = last
    for k in range(0, last + 1):
        lo, hi = interval(f, trace, anchor, k, end if k >= last else None)
        if lo > 0 or hi < 0:
            brute = k
            break
    assert decided(monitor, anchor, 0, last, not bounded) == brute, text(f)
    k = last // 2  # the two ways of working out an end of the interval agree (decided picks the cheaper)
    if k < last:
        lo, hi = interval(f, trace, anchor, k, None)
        assert (bound_at(monitor, anchor, k, True), bound_at(monitor, anchor, k, False)) == (lo, hi), text(f)
        assert (bound_streamed(monitor, anchor, k, True), bound_streamed(monitor, anchor, k, False)) == (lo, hi), text(f)


@st.composite
def wide_cases(draw):
    """until/since with windows up to 16 samples, nested one in the other, over traces of 24-72 samples: the
    sliding aggregates' two stacks flip many times (the formulas above have windows of at most 5 samples)."""

    def operand(depth):
        if depth == 0 or draw(st.booleans()):
            return ("atom", (draw(st.sampled_from("xy")), draw(st.sampled_from(sorted(COMPARE))), draw(st.integers(-2, 2))))
        return wide(depth - 1)

    def wide(depth):
        op = draw(st.sampled_from(["until", "since"]))
        low = draw(st.integers(0, 6))
        return (op, (low, low + draw(st.integers(0, 10))), (operand(depth), operand(depth)))

    f = wide(2)
    length = draw(st.integers(24, 72))
    values = st.lists(VALUES, min_size=length, max_size=length)
    return f, {"x": draw(values), "y": draw(values)}


@settings(max_examples=300, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(wide_cases())
def test_wide_until_and_since_equal_rtamt_at_every_sample(interpreter, case):
    """until/since in amortised O(1) (a monotone deque for φ before the window, a two-stack sliding aggregate
    for the window): every sample's value equals rtamt's, those emitted tick by tick and those the end of the
    trace cuts (:meth:`Monitor.finish`)."""
    f, trace = case
    n = len(trace["x"])
    monitor = Monitor(parse(text(f)), TICK)
    emitted = []
    for t in range(n):
        monitor.step([e.judge({"x": trace["x"][t], "y": trace["y"][t]})[1] for e in monitor.expressions])
        emitted.append(len(monitor.root.values))
    assert emitted[-1] == max(n - int(span(f)), 0)  # each value as soon as its window is known
    monitor.finish()
    interpreter.ast.var_object_dict["x"] = trace["x"]
    interpreter.ast.var_object_dict["y"] = trace["y"]
    interpreter.ast.offline_results = {}
    reference = interpreter.visit(rtamt_node(f), n)
    assert monitor.root.values == pytest.approx(reference, rel=1e-9), text(f)


def test_rtamt_text_parser_agrees_on_a_requirement():
    """One formula through rtamt's own text parser, with a sampling period: the windows in seconds."""
    spec = rtamt.StlDiscreteTimeOfflineSpecification()
    spec.declare_var("gap", "float")
    spec.declare_var("accel", "float")
    spec.set_sampling_period(500, "ms", 0.1)
    spec.spec = "always[0:2]((gap <= 10) -> (eventually[0:1.5](accel < -1)))"
    spec.parse()
    gap = [12.0, 11.0, 9.5, 9.0, 8.0, 9.0, 11.0, 12.0, 12.0, 12.0, 12.0]
    accel = [0.0, 0.0, 0.0, -0.5, -2.0, -3.0, -1.0, 0.0, 0.0, 0.0, 0.0]
    reference = spec.evaluate({"time": [0.5 * i for i in range(len(gap))], "gap": gap, "accel": accel})
    monitor = Monitor(parse("always[0, 2](gap <= 10 -> eventually[0, 1.5](accel < -1))"), 0.5)
    for g, a in zip(gap, accel):
        monitor.step([e.judge({"gap": g, "accel": a})[1] for e in monitor.expressions])
    assert monitor.root.values[0] == pytest.approx(reference[0][1], rel=1e-12)
    assert len(monitor.root.values) == len(gap) - 7  # each value once its window [t, t+3.5 s] is known


# -- the parser's words -----------------------------------------------------------------------------------

@pytest.mark.parametrize(("formula", "words"), [
    ("alway[0, 1](x > 0)", "unknown operator 'alway' at column 1 (did you mean 'always'?)"),
    ("eventually(x > 0)", "'eventually' needs a window"),
    ("x > 0 until y > 0", "'until' needs a window"),
    ("always[2, 1](x > 0)", "the start is after the end"),
    ("always[0, 1](x >)", "bad atom 'x >' at column 14"),
    ("x > 0 ->", "expected a sub-formula at the end"),
    ("always[0, 1](x > 0", "expected ')' at the end"),
    ("x > 0 && import", "bad atom"),
    ("always[0, 1](once > 0)", "expected '(' after once at column 19, found '>'"),
])
def test_parse_errors_say_where(formula, words):
    with pytest.raises(FormulaError) as info:
        parse(formula)
    assert words in str(info.value)


def test_parse_keeps_arithmetic_groups_in_atoms():
    f = parse("(x + y) / 2 <= 3 && !(x > 1) -> eventually[0, 1](abs(y - x) < 2)")
    assert f.op == "implies"
    assert [c.source for c in f.children[0].children] == ["(x + y) / 2 <= 3", "!(x > 1)"]
    assert f.span == 1.0 and f.names == {"x", "y"}


def case(criteria, execute=None, **extra):
    return {"name": "t", "tick": 0.1, "timeout": 10, "signals": {"x": 0.0, "y": 0.0},
            "execute": execute or [{"id": "Up", "kind": "behavior", "action": "ramp",
                                    "params": {"signal": "x", "to": 5.0, "duration": 2.0}}],
            "oracle": {"criteria": criteria}, **extra}  # fmt: skip


def problems(data):
    with pytest.raises(InvalidTestCase) as info:
        load(data)
    return {p.pointer: p.message for p in info.value.problems}


def test_loader_words_at_the_criterion_pointer():
    found = problems(case([
        {"id": "T1", "type": "temporal", "expect": "evntually[0, 1](x > 0)"},
        {"id": "T2", "type": "temporal", "expect": "always[0, 1](xx > 0)"},
        {"id": "T3", "type": "temporal", "expect": "always[0, 0.15](x > 0)"},
        {"id": "T4", "type": "temporal", "expect": "x > 0", "from": "Upp.start"},
    ]))
    assert "did you mean 'eventually'?" in found["/oracle/criteria/0/expect"]
    assert "unknown signal 'xx'" in found["/oracle/criteria/1/expect"] and "did you mean 'x'?" in found["/oracle/criteria/1/expect"]
    assert "0.15 s is not a multiple of the tick (0.1 s)" in found["/oracle/criteria/2/expect"]
    assert "unknown entry 'Upp'" in found["/oracle/criteria/3/from"] and "did you mean 'Up'?" in found["/oracle/criteria/3/from"]
    shape = problems(case([
        {"id": "T5", "type": "temporal", "expect": "x > 0", "to": 3},
        {"id": "P1", "type": "period", "expect": "x > 0", "from": "Up.start"},
        {"id": "R1", "type": "record", "expect": "x > 0", "from": 1},
    ]))
    assert shape["/oracle/criteria/0/to"] == "'to' is only allowed on period criteria"
    assert shape["/oracle/criteria/1/from"] == "'Up.start' is not of type 'number': expected period only: window start (default 0)."
    assert shape["/oracle/criteria/2/from"] == "'from' is only allowed on period and temporal criteria"


def test_cli_exit_code_2_for_a_bad_formula(tmp_path, capsys):
    from btgen_pytrees.cli import main

    path = tmp_path / "bad.json"
    path.write_text(json.dumps(case([{"id": "T1", "type": "temporal", "expect": "always[0, 1](x > 0"}])))
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err
    assert "/oracle/criteria/0/expect" in err and "expected ')' at the end" in err


# -- runs that tick the tree --------------------------------------------------------------------------------

def reference_at(report, formula_text, names, anchor_index):
    """rtamt's robustness of the formula on the run's own trace (sampled every tick), at *anchor_index*."""
    spec = rtamt.StlDiscreteTimeOfflineSpecification()
    for name in names:
        spec.declare_var(name, "float")
    spec.set_sampling_period(100, "ms", 0.1)
    spec.spec = formula_text
    spec.parse()
    trace = report.trace
    data = {"time": [round(t, 9) for t in trace.times]}
    for name in names:
        data[name] = [float(trace.value_at(name, k)) for k in range(len(trace.times))]
    return spec.evaluate(data)[anchor_index][1]


def test_run_margin_equals_rtamt_on_the_runs_trace():
    data = case([{"id": "T1", "type": "temporal", "from": 0.5,
                  "expect": "always[0, 1](x <= 3) && eventually[0.5, 1](x > 2)"}])
    report = run(load(data))
    oracle = report.oracles[0]
    expected = reference_at(report, "(always[0:1](x <= 3)) and (eventually[0.5:1](x > 2))", ["x"], 5)
    assert oracle.margin == pytest.approx(expected, rel=1e-9)
    assert oracle.verdict == ("pass" if expected > 0 else "fail")
    assert oracle.at == pytest.approx(1.5)  # the run went on to the horizon: 0.5 + 1
    assert report.ticks == 16


def test_response_anchored_at_an_entry_start_and_decided():
    execute = [
        {"id": "Wait", "kind": "constraint", "action": "wait", "params": {"duration": 1.0}},
        {"id": "LeadBrakes", "kind": "behavior", "action": "set", "params": {"signal": "y", "value": -5.0, "duration": 0.5}, "after": ["Wait"]},
        {"id": "EgoBrakes", "kind": "behavior", "action": "set", "params": {"signal": "x", "value": -3.0, "duration": 1.0},
         "after": ["LeadBrakes"]},
    ]  # fmt: skip
    data = case([{"id": "R", "type": "temporal", "from": "LeadBrakes.start",
                  "expect": "y < -2 -> eventually[0, 1.5](x < -1)"}], execute)
    report = run(load(data))
    oracle = report.oracles[0]
    assert oracle.verdict == "pass" and oracle.margin == pytest.approx(2.0)
    assert oracle.at == pytest.approx(2.5)  # anchor 1.0 s + 1.5 s
    assert oracle.decided == pytest.approx(1.5)  # the ego braked at 1.5 s: certain then
    assert json.loads(report.to_json())["oracles"][0]["decided"] == pytest.approx(1.5)


def test_slow_response_fails_with_its_margin():
    execute = [
        {"id": "LeadBrakes", "kind": "behavior", "action": "set", "params": {"signal": "y", "value": -5.0, "duration": 0.5}},
        {"id": "Late", "kind": "constraint", "action": "wait", "params": {"duration": 2.0}},
        {"id": "EgoBrakes", "kind": "behavior", "action": "set", "params": {"signal": "x", "value": -3.0}, "after": ["Late"]},
    ]  # fmt: skip
    data = case([{"id": "R", "type": "temporal", "from": "LeadBrakes.start",
                  "expect": "y < -2 -> eventually[0, 1.5](x < -1)"}], execute)
    report = run(load(data))
    oracle = report.oracles[0]
    assert report.verdict == "fail" and oracle.verdict == "fail"
    assert oracle.margin == pytest.approx(-1.0)  # x stayed 0: 1 short of x < -1
    assert oracle.decided == pytest.approx(1.5) and oracle.at == pytest.approx(1.5)


def test_run_ending_before_the_horizon_is_inconclusive():
    data = case([{"id": "T", "type": "temporal", "expect": "always[0, 5](x <= 10)"}], timeout=2)
    report = run(load(data))
    assert report.verdict == "timeout" and report.oracles[0].verdict == "inconclusive"
    assert report.oracles[0].margin is None
    assert "T (temporal: always[0, 5](x <= 10)) its horizon (5 s past its anchor) had not passed" in "\n".join(report.explanation)


def test_always_without_window_reads_to_the_end_of_the_execute_subtree():
    data = case([{"id": "T", "type": "temporal", "expect": "always(x <= 4)"}])
    report = run(load(data))
    oracle = report.oracles[0]
    assert oracle.verdict == "fail" and oracle.margin == pytest.approx(-1.0)  # x ramps to 5
    assert oracle.at == pytest.approx(2.0) and report.duration == pytest.approx(2.0)


def test_report_json_fits_the_schema_and_other_types_are_unchanged():
    data = case([{"id": "T", "type": "temporal", "expect": "eventually[0, 1](x > 1)"},
                 {"id": "R", "type": "record", "expect": "x <= 5"}])  # fmt: skip
    document = json.loads(run(load(data)).to_json())
    schema = json.loads((ROOT / "schemas" / "report.schema.json").read_text())
    jsonschema.validate(document, schema)
    assert "decided" in document["oracles"][0] and "decided" not in document["oracles"][1]


# -- the examples ----------------------------------------------------------------------------------------

EXAMPLES = ROOT / "examples" / "temporal"
ARCH = {"at1": "pass", "at2": "fail", "at51": "pass", "at52": "pass", "at53": "pass", "at54": "pass",
        "at6a": "pass", "at6b": "pass", "at6c": "pass", "cc1": "pass", "cc2": "fail", "cc3": "fail",
        "cc4": "fail", "cc5": "fail", "afc27": "pass", "afc29": "fail"}  # fmt: skip


def test_arch_comp_requirements_run_on_the_example_plants():
    """Every ARCH-COMP requirement of examples/temporal/ runs to its horizon with the verdict README.md gives;
    its margin's sign is the verdict's (0 only for the gear requirements' == atoms), and decided <= at."""
    from btgen_pytrees.leaves import default_registry

    registry = default_registry([str(EXAMPLES / "arch.py")])
    for name, verdict in ARCH.items():
        report = run(load(str(EXAMPLES / f"{name}.json"), registry=registry), registry=registry, record=False)
        oracle = report.oracles[0]
        assert (report.verdict, oracle.verdict) == (verdict, verdict), name
        assert oracle.margin is not None and (oracle.margin > 0 if verdict == "pass" else oracle.margin < 0) or \
            oracle.margin == 0 and name.startswith("at5"), name  # fmt: skip
        assert oracle.decided is not None and oracle.decided <= oracle.at + 1e-9, name
        assert oracle.name.startswith(("G[", "(G[")), name  # the source formula, as ARCH-COMP writes it


needs_sumo = pytest.mark.skipif(
    importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)",
)


@needs_sumo
def test_response_requirement_on_sumo():
    report = run(load(str(EXAMPLES / "response_sumo.json")))
    by_id = {o.id: o for o in report.oracles}
    assert report.verdict == "pass"
    response = by_id["T1"]
    assert response.verdict == "pass" and response.margin > 0
    assert 2.0 <= response.decided <= 3.5 and response.at == pytest.approx(3.5)  # the lead braked at 2 s


def test_the_benchmark_cases_load():
    """benchmarks/temporal.py's cases are valid (its timings are measured there, not here)."""
    import sys

    sys.path.insert(0, str(ROOT))
    from benchmarks import temporal as bench

    cases = {kind: load(bench.case(kind)) for kind in ("record", "temporal", "nested", "until")}
    assert [len(c.criteria) for c in cases.values()] == [bench.N] * 4
    assert cases["until"].criteria[1].expect.span == pytest.approx(999.9)  # a window of 10,000 ticks
    assert cases["temporal"].criteria[1].expect.span == pytest.approx(999.9)


def test_falsify_finds_a_late_response_within_50_runs(tmp_path):
    """falsify's objective is the temporal criterion's margin: it finds a reaction too late for the
    response requirement on the built-in simulator within 50 runs, and every run's margin is the report's."""
    from btgen_pytrees.cli import main
    from btgen_pytrees.falsify.sampler import available

    if not available() and not os.environ.get("CI"):
        pytest.skip("the 'search' extra is not installed")
    out = tmp_path / "f.json"
    assert main(["falsify", str(EXAMPLES / "response_falsify.json"), "--budget", "50", "--jobs", "1", "--json", str(out)]) == 1
    data = json.loads(out.read_text())
    assert data["verdict"] == "falsified" and data["first_failure"] <= 50
    failing = data["runs"][data["first_failure"] - 1]
    assert failing["parameters"]["delay"] > 1.3 and failing["margins"]["Response"] == failing["margin"] < 0
    assert all(r["margin"] == r["margins"]["Response"] for r in data["runs"])
    assert all((r["verdict"] == "pass") == (r["margin"] > 0) for r in data["runs"])


def test_views_carry_temporal_criteria(tmp_path):
    """JUnit properties (margin and decided), the replay page (the sub-formulas' robustness as series),
    --plot (the window and the atoms' bounds), and a sweep row's decided."""
    from btgen_pytrees.cli import main
    from btgen_pytrees.sweep.jobs import row_of

    path = tmp_path / "t.json"
    path.write_text(json.dumps(case([{"id": "T", "type": "temporal", "from": 0.5, "expect": "always[0, 1](x <= 3)"}])))
    assert main(["run", str(path), "--junit", str(tmp_path / "j.xml"), "--replay", str(tmp_path / "r.html"),
                 "--plot", str(tmp_path / "p.svg")]) == 1  # fmt: skip  (x passes 3 at 1.2 s)
    junit = (tmp_path / "j.xml").read_text()
    assert '<property name="margin" value="-0.75" />' in junit and '<property name="decided" value="1.3" />' in junit
    page = (tmp_path / "r.html").read_text()
    assert "T robustness: always[0, 1](x \\u003c= 3)" in page
    svg = (tmp_path / "p.svg").read_text()
    assert "T: x &lt;= 3" in svg  # the atom's bound, as record criteria's are drawn
    report = run(load(json.loads(path.read_text())))
    assert row_of(report)["oracles"][0]["decided"] == pytest.approx(1.3)
    row = next(line for line in report.table().splitlines() if line.startswith("T "))  # the text table's row
    assert row.split()[1:5] == ["temporal", "always[0,", "1](x", "<="] and " fail " in row and "1.5" in row
    assert any(line.startswith("criterion T (temporal) failed: always[0, 1](x <= 3) violated at 0.5 s (margin -0.75)")
               for line in report.explanation)  # fmt: skip
    assert [source for source, _ in report.oracles[0].terms] == ["always[0, 1](x <= 3)", "x <= 3"]


@pytest.mark.parametrize(("criterion", "why", "where"), [
    ({"expect": "always[0, 2](x <= 3)"}, "always failed at 2 s: x <= 3 false at 2 s (x=5)", (2.0, {"x": 5.0})),
    ({"expect": "eventually[0, 1](x >= 4)"}, "x >= 4 never held in [0, 1] s; its best value -1.5 at 1 s", (1.0, {"x": 2.5})),
    ({"expect": "(x <= 1) until[0, 1] (x >= 2)"}, "x <= 1 gave out at 0.5 s, before x >= 2 held at 0.8 s", (0.5, {"x": 1.25})),
    ({"expect": "(x >= 0) until[0, 0.5] (x >= 4)"}, "x >= 4 never held in [0, 0.5] s (its best value -2.75 at 0.5 s)",
     (0.5, {"x": 1.25})),
    ({"from": 1.0, "expect": "x >= 1 -> eventually[0, 0.5](y >= 1)"},
     "the premise x >= 1 held at 1 s (margin 1.5) and the consequence failed: y >= 1 never held in [1, 1.5] s; "
     "its best value -1 at 1 s", (1.0, {"x": 2.5, "y": 0.0})),
    ({"from": 1.0, "expect": "(x <= 1) since[0, 0.5] (x >= 4)"}, "x >= 4 did not hold in [0.5, 1] s with x <= 1 since",
     (1.0, {"x": 2.5})),
    ({"from": 1.0, "expect": "!(x >= 1) || once[0, 0.3](x >= 3)"},
     "no side held: x >= 1 held at 1 s (margin 1.5); x >= 3 never held in [0.7, 1] s; its best value -0.5 at 1 s",
     (1.0, {"x": 2.5})),
])  # fmt: skip
def test_the_explanation_says_why_per_operator(criterion, why, where):
    """always: the tick and the values; eventually: never held in [t+a, t+b] and its best value; until: which
    side gave out; ->: the premise held and the consequence failed; and the tick it names (--plot's marker).
    x ramps 0 to 5 over 2 s (2.5 per second), y stays 0."""
    report = run(load(case([{"id": "T", "type": "temporal", **criterion}])))
    oracle = report.oracles[0]
    assert oracle.verdict == "fail" and f": {why}; certain after the tick at " in oracle.message, oracle.message
    assert oracle.violation == (pytest.approx(where[0]), pytest.approx(where[1]))


def test_plot_marks_a_temporal_violation_at_the_tick_its_explanation_names():
    """--plot's violation marker (and the red margin line) of a failed temporal criterion sit at the tick the
    explanation names, with the values read there - not at the horizon, where the verdict came. x ramps 0 to 5
    over 2 s; ``x <= 1 || x >= 4`` is worst at x = 2.5 (1 s), the horizon is 2 s (x = 5, where it held)."""
    from btgen_pytrees.run.plot import plot_figure

    loaded = load(case([{"id": "T", "type": "temporal", "expect": "always[0, 2](x <= 1 || x >= 4)"}]))
    report = run(loaded)
    oracle = report.oracles[0]
    assert oracle.verdict == "fail" and oracle.at == pytest.approx(2.0) and oracle.values["x"] == pytest.approx(5.0)
    assert "always failed at 1 s" in oracle.message and oracle.violation == (pytest.approx(1.0), {"x": pytest.approx(2.5)})
    assert "violation" not in report.to_dict()["oracles"][0]  # JSON's at/values are the verdict's
    lines = [line for ax in plot_figure(report, loaded).axes for line in ax.get_lines()]
    marks = [(list(line.get_xdata()), list(line.get_ydata())) for line in lines if line.get_label() == "_violation"]
    assert marks == [([pytest.approx(1.0)], [pytest.approx(2.5)])]
    margins = [(list(line.get_xdata()), list(line.get_ydata())) for line in lines if line.get_label() == "_margin"]
    assert margins == [([pytest.approx(1.0)] * 2, [1.0, pytest.approx(2.5)]), ([pytest.approx(1.0)] * 2, [4.0, pytest.approx(2.5)])]


def test_plot_draws_the_window_from_the_anchor():
    """--plot's band is the criterion's window: its anchor to its horizon, or to the end of the run for an
    ``always`` without a window (anchored at 1 s here: the band starts there, not at 0)."""
    from btgen_pytrees.run.plot import plot_figure

    loaded = load(case([{"id": "B", "type": "temporal", "from": 0.5, "expect": "always[0, 1](x <= 3)"},
                        {"id": "U", "type": "temporal", "from": 1.0, "expect": "always(x <= 4)"}], tick=0.1))  # fmt: skip
    report = run(loaded)
    assert [o.window for o in report.oracles] == [(0.5, 1.5), (1.0, None)]
    assert "window" not in report.to_dict()["oracles"][0]
    bands = set()
    for ax in plot_figure(report, loaded).axes:
        for patch in ax.patches:
            if patch.get_label() == "_window":
                xs = patch.get_patch_transform().transform(patch.get_path().vertices)[:, 0]
                bands.add((round(float(min(xs)), 6), round(float(max(xs)), 6)))
    assert bands == {(0.5, 1.5), (1.0, round(report.duration, 6))}


@pytest.mark.skipif(not os.environ.get("CI") and importlib.util.find_spec("selenium") is None, reason="selenium missing (CI has it)")
def test_replay_page_draws_the_window_on_the_signal_plot(tmp_path):
    """The replay page draws a temporal criterion's window (anchor to horizon) as a band on the curves of the
    signals its formula reads and of its sub-formulas' robustness - not on other signals - in headless
    Chromium, where --plot draws it."""
    import sys

    sys.path.insert(0, str(ROOT / "tests"))
    from browser import chromium, chromium_present

    from btgen_pytrees import generate
    from btgen_pytrees.run.replay import replay_html

    if not chromium_present() and not os.environ.get("CI"):
        pytest.skip("chromium or chromium-driver missing (CI installs them)")
    data = case([{"id": "T", "type": "temporal", "from": 0.5, "expect": "always[0, 1](x <= 3)"}])
    loaded = load(data)
    report = run(loaded)
    page = replay_html(report, loaded, generate(loaded)).decode("utf-8")
    shown = json.loads(page.split('<script type="application/json" id="run-data">', 1)[1].split("</script>", 1)[0])
    assert shown["oracles"][0]["window"] == [0.5, 1.5] and report.duration == pytest.approx(1.5)
    assert shown["oracles"][0]["reads"] == ["x", "T robustness: always[0, 1](x <= 3)", "T robustness: x <= 3"]
    path = tmp_path / "t.html"
    path.write_text(page, encoding="utf-8")
    with chromium() as driver:
        driver.get(path.as_uri())
        assert driver.execute_script("return document.body.dataset.ready") == "1"
        bands = driver.execute_script(
            "return Array.from(document.querySelectorAll('#signals tr')).map((row) => [row.dataset.signal,"
            " Array.from(row.querySelectorAll('rect.window')).map((r) => [r.dataset.criterion, r.getAttribute('class'),"
            " Number(r.getAttribute('x')), Number(r.getAttribute('width')), r.textContent])])")
    by_signal = dict((name, rects) for name, rects in bands)
    assert by_signal["y"] == []
    x0, x1 = 2 + 236 * (0.5 / 1.5), 2 + 236 * 1.0  # the curve's x axis: 2 px margins, 240 px for the run's 1.5 s
    for name in ("x", "T robustness: always[0, 1](x <= 3)", "T robustness: x <= 3"):
        [(criterion, kind, x, width, title)] = by_signal[name]
        assert criterion == "T" and kind == "window fail" and title == "T window: 0.5 \u2026 1.5 s"
        assert x == pytest.approx(x0) and x + width == pytest.approx(x1)


def test_a_sweeps_verdict_map_and_rows_carry_the_temporal_margin(tmp_path):
    from btgen_pytrees.cli import main

    data = json.loads((EXAMPLES / "response_falsify.json").read_text())
    data["variations"] = {"delay": {"from": 1, "to": 2, "step": 1}, "decel": {"from": 2, "to": 4, "step": 2}}
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(data))
    assert main(["run", str(path), "--jobs", "1", "--json", str(tmp_path / "s.json"), "--plot", str(tmp_path / "map.svg")]) == 1
    rows = json.loads((tmp_path / "s.json").read_text())["rows"]
    by_delay = {r["parameters"]["delay"]: r["oracles"][0] for r in rows}
    assert by_delay[2]["verdict"] == "fail" and by_delay[2]["margin"] == -1.0 and by_delay[2]["decided"] == pytest.approx(2.5)
    assert by_delay[1]["verdict"] == "pass" and by_delay[1]["margin"] > 0
    assert (tmp_path / "map.svg").read_text().startswith("<?xml")
    sweep_json = json.loads((tmp_path / "s.json").read_text())
    jsonschema.validate(sweep_json, json.loads((ROOT / "schemas" / "sweep-report.schema.json").read_text()))
    # the map's colours are the temporal margin's objective (as falsify's): red where it failed, green where it held
    from btgen_pytrees.sweep.plot import map_figure
    from btgen_pytrees.sweep.report import SweepReport

    report = SweepReport("s", str(path), {}, ("delay", "decel"), rows)
    objectives = report.objectives()
    assert [o is not None and (o < 0) == (r["oracles"][0]["margin"] < 0) for o, r in zip(objectives, rows)] == [True] * 4
    figure = map_figure(report)
    assert "objective" in figure.axes[1].get_ylabel()  # the colour bar: margins, not verdicts
    cells = {(round(p.get_x() + 0.5), round(p.get_y() + 0.5)): p.get_facecolor() for p in figure.axes[0].patches}
    assert len(cells) == 4
    for r in rows:  # delay 1, 2 along x; decel 2, 4 along y
        red, green = cells[(r["parameters"]["delay"] - 1, r["parameters"]["decel"] // 2 - 1)][:2]
        assert (red > green) == (r["oracles"][0]["margin"] < 0), r["parameters"]
