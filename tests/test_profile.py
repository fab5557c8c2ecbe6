"""The built-in ``profile`` behaviour: an input signal given by control points, ticked on the virtual clock.

Each test runs the tree and reads what the leaf wrote on every tick (the run's trace), so the timing
rule (the first tick at or after a point's time), the shapes and the end of the entry are checked as
they happen; ``pchip`` is checked against SciPy's own ``PchipInterpolator`` at the ticks' times.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from btgen_pytrees.errors import InvalidTestCase
from btgen_pytrees.load import load, load_sweep
from btgen_pytrees.run import run

from helpers import case, crit


def profile_case(points, shape=None, tick=0.1, signals=None, **top):
    params = {"signal": "u", "points": points}
    if shape is not None:
        params["shape"] = shape
    return case({"id": "B1", "kind": "behavior", "action": "profile", "params": params},
                {"id": "B2", "kind": "behavior", "action": "hold", "after": ["B1"], "params": {"duration": 0.3}},
                criteria=[crit("R1", "record", "u >= -100")], signals=signals or {"u": 0}, tick=tick,
                timeout=top.pop("timeout", 20), **top)


def written(data):
    """({time: value of u at the end of that tick}, the report) of a recorded run of *data*."""
    report = run(load(data))
    trace = report.trace
    return {round(t, 9): trace.value_at("u", k) for k, t in enumerate(trace.times)}, report


def test_step_holds_each_value_until_the_next_point_and_ends_on_the_last_points_tick():
    by_time, report = written(profile_case([[0, 1], [0.5, 4], [1.2, -2]]))
    assert report.verdict == "pass"
    assert [by_time[t] for t in (0.0, 0.4, 0.5, 1.1, 1.2, 1.4)] == [1, 1, 4, 4, -2, -2]
    end = {e.id: e for e in report.execute}["B1"]
    assert end.status == "success" and end.end == pytest.approx(1.2)  # the tick of the last point, not later


def test_linear_interpolates_between_points_and_a_late_first_point_starts_from_the_value_at_start():
    by_time, _ = written(profile_case([[1, 10], [2, 0]], shape="linear", signals={"u": 4}))
    assert by_time[0.0] == pytest.approx(4) and by_time[0.5] == pytest.approx(7)  # (0, 4) -> (1, 10)
    assert by_time[1.0] == pytest.approx(10) and by_time[1.5] == pytest.approx(5) and by_time[2.0] == 0


def test_a_tick_that_is_no_power_of_ten_fraction_meets_each_point_on_its_first_tick_at_or_after_it():
    by_time, _ = written(profile_case([[0, 0], [0.3, 1], [0.9, 2]], tick=0.075))
    # 0.3 = 4 ticks exactly; 0.9 = 12 ticks exactly (within float rounding): each value starts there
    assert by_time[round(3 * 0.075, 9)] == 0 and by_time[round(4 * 0.075, 9)] == 1
    assert by_time[round(11 * 0.075, 9)] == 1 and by_time[round(12 * 0.075, 9)] == 2


def test_pchip_equals_scipys_curve_at_every_tick_and_keeps_the_points_range():
    scipy_interpolate = pytest.importorskip("scipy.interpolate")
    points = [[0, 0], [1, 1], [2, 0.2], [3, 0.9], [4, 0]]
    by_time, _ = written(profile_case(points, shape="pchip"))
    curve = scipy_interpolate.PchipInterpolator([p[0] for p in points], [p[1] for p in points])
    inside = [(t, v) for t, v in by_time.items() if t < 4]
    assert len(inside) == 40
    for t, v in inside:
        assert v == pytest.approx(float(curve(t)), abs=1e-12)
        assert 0 <= v <= 1  # shape-preserving: no overshoot of the points' range


def test_points_from_parameters_make_the_sweeps_box_the_input_space():
    data = profile_case([[0, "$u0"], [5, "$u1"]])
    data["oracle"]["criteria"] = [crit("R1", "record", "u <= 0.5")]
    data["parameters"] = {"u0": 0, "u1": 0}
    data["variations"] = {"u0": [0, 1], "u1": [0.2, 0.8]}
    sweep = load_sweep(data)
    verdicts = {tuple(value for _, value in v.point): run(load(v.document)).verdict for v in sweep}
    assert verdicts == {(0, 0.2): "pass", (0, 0.8): "fail", (1, 0.2): "fail", (1, 0.8): "fail"}


@pytest.mark.parametrize("points, shape, where, words", [
    ([[0, 1], [2, 3], [2, 0]], None, "/execute/0/params/points/2/0", "the times must increase: 2 s follows 2 s"),
    ([[0, True], [1, False]], "linear", "/execute/0/params/points/0/1", "a linear profile interpolates numbers"),
    ([[-1, 1]], None, "/execute/0/params/points/0/0", ""),
    ([], None, "/execute/0/params/points", ""),
    ([[0, 1, 2]], None, "/execute/0/params/points/0", ""),
    ([[0, 1]], "cubic", "/execute/0/params/shape", ""),
])
def test_bad_points_are_refused_at_their_json_pointer(points, shape, where, words):
    with pytest.raises(InvalidTestCase) as caught:
        load(profile_case(points, shape=shape))
    rendered = [p.render("c.json") for p in caught.value.problems]
    assert any(line.startswith(f"c.json: {where}: ") and words in line for line in rendered), rendered


def test_the_cli_refuses_a_bad_profile_with_exit_2_naming_the_file_and_pointer(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(profile_case([[0, 1], [3, 2], [1, 0]])))
    done = subprocess.run([sys.executable, "-m", "btgen_pytrees", "run", str(path)], capture_output=True, text=True)
    assert done.returncode == 2 and done.stdout == ""
    assert f"{path}: /execute/0/params/points/2/0: the times must increase: 1 s follows 3 s" in done.stderr
