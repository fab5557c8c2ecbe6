"""Sweeps: parameters, variations, every variation checked, run, reported and mapped (issue 12)."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys
from typing import Any

import pytest
from helpers import DYING_PLUGIN, case, crit, entry, run_case

import btgen_pytrees
from btgen_pytrees import InvalidTestCase, load
from btgen_pytrees.load import variations
from btgen_pytrees.sweep import Variations, label, load_sweep
from btgen_pytrees.load.template import count_problem

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1_SWEEP = ROOT / "examples" / "fig1_sweep.json"


def cli(*args: str, cwd: pathlib.Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True, timeout=300, cwd=cwd)


def problems(data: dict[str, Any], **kw: Any) -> list[tuple[str, str]]:
    with pytest.raises(InvalidTestCase) as info:
        load_sweep(data, **kw)
    return [(p.pointer, p.message) for p in info.value.problems]


def swept(params: dict[str, Any], variations: dict[str, Any] | None = None, *entries: dict[str, Any], **top: Any) -> dict[str, Any]:
    data = case(*entries, **top)
    data["parameters"] = params
    if variations is not None:
        data["variations"] = variations
    return data


# ---------------------------------------------------------------------------
# expansion: order, count, determinism


def test_lists_and_ranges_form_a_product_in_file_order() -> None:
    v = Variations.parse({"a": [1, 2], "b": {"from": 0, "to": 0.3, "step": 0.1}, "c": [True, False]})
    points = list(v.points())
    assert v.count == len(points) == 2 * 4 * 2
    assert [label(p) for p in points[:3]] == ["a=1,b=0,c=true", "a=1,b=0,c=false", "a=1,b=0.1,c=true"]
    assert [p[1][1] for p in points[::2][:4]] == [0, 0.1, 0.2, 0.3]  # no 0.30000000000000004, 'to' included
    assert label(points[-1]) == "a=2,b=0.3,c=false"


def test_random_draws_are_drawn_once_seeded_and_reproducible() -> None:
    block = {"gap": [5, 10, 20], "mu": {"uniform": [10, 30]}, "noise": {"normal": [0, 2]}, "samples": 50, "seed": 3}
    v = Variations.parse(block)
    points = list(v.points())
    assert v.count == len(points) == 150
    assert points == list(Variations.parse(block).points())  # same file, same variations, same order
    by_gap = {}
    for p in points:
        by_gap.setdefault(p[0][1], []).append(p[1:])
    assert by_gap[5] == by_gap[10] == by_gap[20]  # the same 50 draws for every grid point
    assert all(10 <= p[2][1] <= 30 for p in points)
    assert len({label(p) for p in points}) == 150
    other = list(Variations.parse({**block, "seed": 4}).points())
    assert [p[2] for p in other] != [p[2] for p in points]
    # pinned values: random.Random(seed) is stable across Python versions; a change here breaks reproducibility
    assert points[0] == (("gap", 5), ("sample", 0), ("mu", 14.7593), ("noise", -1.84867))


def test_a_billion_variations_are_refused_by_arithmetic_before_anything_is_built(monkeypatch: pytest.MonkeyPatch) -> None:
    data = swept({"a": 0, "b": 0, "c": 0}, {n: {"from": 0, "to": 999, "step": 1} for n in "abc"},
                 entry("A", duration="$a"), entry("B", duration="$b"), entry("C", duration="$c"))  # fmt: skip

    def enumerated(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("a variation was enumerated")

    with monkeypatch.context() as patched:  # every way to a variation or one of its values raises
        for name in ("points", "draws"):
            patched.setattr(variations.Variations, name, enumerated)
        patched.setattr(variations.Axis, "value", enumerated)
        with pytest.raises(AssertionError, match="enumerated"):  # the spies are on the path load_sweep takes
            load_sweep(swept({"a": 0}, {"a": [1, 2]}, entry("A", duration="$a")))
        assert problems(data) == [("/variations", "1,000,000,000 variations; the limit is 10,000 (raise it with --max-variations)")]
    data["variations"]["c"] = {"from": 0, "to": 1, "step": 1e-300}  # uncountably many
    message = count_problem(data, 10).message
    assert message.startswith("about 1e+") and message.endswith("variations; the limit is 10 (raise it with --max-variations)")
    data["variations"] = {"a": [0, 1], "b": [0, 1]}
    assert problems(data, max_variations=3) == [("/variations", "4 variations; the limit is 3 (raise it with --max-variations)")]
    assert load_sweep(data, max_variations=4).count == 4


# ---------------------------------------------------------------------------
# substitution: every place, checked by running


def test_parameters_reach_every_place_and_change_the_run() -> None:
    data = swept(
        {"dt": 0.5, "end": 10, "top": 20, "limit": 25, "d": 2, "t0": 1, "stop": 1.5, "on": True},
        None,
        entry("R", action="ramp", signal="speed", to="$top", duration="$d"),
        entry("S", action="set", signal="flag", value="$on"),
        criteria=[crit("R1", "record", "speed <= $limit && flag == $on"),
                  crit("P1", "period", "speed <= $limit - 10", **{"from": "$t0", "to": "$stop"})],
        tick="$dt", timeout="$end", signals={"speed": 0, "flag": "$on"},
    )  # fmt: skip
    report = run_case(data)
    assert (report.verdict, report.duration, report.ticks) == ("pass", 1.5, 4)  # tick 0.5; P1's window ends at 1.5
    assert [o.verdict for o in report.oracles] == ["pass", "pass"]
    assert report.oracles[0].expect == "speed <= 25 && flag == true"
    assert report.execute[0].status == "stopped" and report.oracles[1].at == 1.5
    data["parameters"]["stop"] = 2  # the ramp (20 in 2 s) reaches 20 > 25 - 10 inside the window: P1 fails
    assert run_case(data).verdict == "fail"
    data["parameters"].update(stop=1.5, end=1)  # the run stops before the ramp ends
    assert run_case(data).verdict == "timeout"


def test_each_variation_runs_its_own_values() -> None:
    data = swept({"d": 1}, {"d": [0.5, 2, 1]}, entry("A", duration="$d"))
    sweep = load_sweep(data)
    durations = [btgen_pytrees.run.run(load(v.document)).duration for v in sweep]  # type: ignore[attr-defined]
    assert durations == [0.5, 2.0, 1.0]
    assert "parameters" not in sweep.template.get("variations", {}) and all("$" not in json.dumps(v.document) for v in sweep)


def test_negative_values_and_literal_dollars_in_expressions() -> None:
    data = swept({"x": -5}, None, entry("A", action="set", signal="v", value=1),
                 criteria=[crit("F", "final", "v - $x == 6")])  # fmt: skip
    report = run_case(data)
    assert report.oracles[0].expect == "v - (-5) == 6" and report.verdict == "pass"
    sweep = load_sweep(swept({"x": 1}, None, entry("A", action="set", signal="v", value="$x")))
    assert next(iter(sweep)).document["execute"][0]["params"]["value"] == 1


def test_a_case_without_parameters_keeps_its_dollars_and_its_loader() -> None:
    plain = case(entry("U", action="until", expect="$x > 1"))
    with pytest.raises(InvalidTestCase) as info:
        load(plain)
    assert info.value.problems[0].cause == "expression"  # as before: '$' is not expression syntax
    code = ("import sys, btgen_pytrees; btgen_pytrees.load('examples/fig1.json'); "
            "print('btgen_pytrees.sweep' in sys.modules)")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out.strip() == "False"  # the fast path never imports the sweep package


# ---------------------------------------------------------------------------
# validation: JSON paths, every variation, each distinct problem once


def test_undeclared_references_are_reported_once_with_their_paths() -> None:
    data = swept({"limit": 1, "gap": 2}, {"gap": [1, 2, 3]},
                 entry("A", duration="$gap"), entry("B", duration="$gpa"),
                 criteria=[crit("F", "final", "x < $limt && x < $limt")])  # fmt: skip
    assert problems(data) == [
        ("/execute/1/params/duration", "undeclared parameter '$gpa' (did you mean '$gap'?)"),
        ("/oracle/criteria/0/expect", "undeclared parameter '$limt' (did you mean '$limit'?)"),
    ]


def test_wrong_types_after_substitution_are_reported_per_distinct_problem() -> None:
    data = swept({"d": 1, "on": True}, {"d": [1, -1, -2, 3, -1.5]},
                 entry("A", duration="$d"), entry("B", duration="$on"))  # fmt: skip
    found = problems(data)
    assert ("/execute/1/params/duration", "true is not of type 'number': expected seconds, >= 0") in found  # every variation: said once
    negative = [m for p, m in found if p == "/execute/0/params/duration"]
    assert negative == [
        "must not be negative (got -1) (in variation: [d=-1])",
        "must not be negative (got -1.5) (in variation: [d=-1.5])",
        "must not be negative (got -2) (in variation: [d=-2])",
    ]


def test_a_problem_shared_by_some_variations_says_how_many() -> None:
    data = swept({"t": 1, "u": 0}, {"t": [1, 2], "u": [5, 0]},
                 entry("A", duration="$t"), criteria=[crit("P", "period", "true", **{"from": "$u", "to": 3})])  # fmt: skip
    assert problems(data) == [
        ("/oracle/criteria/0/from", "'from' (5) must be less than 'to' (3) (in 2 of 4 variations: [t=1,u=5], ...)")]


def test_block_problems() -> None:
    base = [entry("A", duration="$d")]
    assert problems(swept({"d": 1, "samples": 2}, None, *base))[0] == (
        "/parameters/samples", "'samples' is not valid: expected a parameter name (a letter or '_', then letters, digits or '_'; not 'samples', 'seed' or 'sample')")
    assert problems(swept({"d": 1}, {"e": [1]}, *base)) == [
        ("/variations/e", "'e' is not a declared parameter; declare it with its default under 'parameters'")]
    assert problems(swept({"d": 1, "e": 2}, {"e": [1]}, *base)) == [
        ("/variations/e", "'$e' is used nowhere, so varying it changes nothing")]
    assert problems(swept({"d": 1}, {"d": [1, 2, 1, True]}, *base)) == [
        ("/variations/d/2", "1 is listed twice"), ("/variations/d/3", "True is not a number like the default of 'd'")]
    assert problems(swept({"d": 1}, {"d": {"from": 3, "to": 1, "step": 1}}, *base)) == [
        ("/variations/d/to", "'to' (1) is less than 'from' (3)")]
    assert problems(swept({"d": 1}, {"d": {"uniform": [0, 1]}}, *base)) == [
        ("/variations", "random parameters (d) need \"samples\": N")]
    assert problems(swept({"d": 1}, {"d": [1], "seed": 1}, *base)) == [
        ("/variations/seed", "'seed' applies to random parameters (uniform/normal) only; there are none")]
    assert problems(swept({"d": 1}, {"d": {"from": 1, "to": 2}}, *base))[0][0] == "/variations/d"
    assert problems(swept({"d": 1}, {}, *base)) == [("/variations", "names no parameter to vary")]


def test_the_defaults_are_a_case_of_their_own() -> None:
    data = swept({"d": 1}, {"d": [1, 2]}, entry("A", duration="$d"))
    assert load(data).entries[0].params["duration"] == 1  # load/show: the defaults
    data["parameters"]["d"] = -1
    with pytest.raises(InvalidTestCase) as info:
        load(data)
    assert info.value.problems[0].pointer == "/execute/0/params/duration"


# ---------------------------------------------------------------------------
# the commands


def test_expand_writes_concrete_cases_that_run_like_the_sweep(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "cases"
    result = cli("expand", str(FIG1_SWEEP), "--out-dir", str(out))
    assert result.returncode == 0, result.stderr
    names = sorted(p.name for p in out.iterdir())
    assert len(names) == 28 and "fig1_sweep[top_speed=25,limit=20].json" in names
    doc = json.loads((out / "fig1_sweep[top_speed=25,limit=20].json").read_text())
    assert "parameters" not in doc and "variations" not in doc and doc["oracle"]["criteria"][0]["expect"] == "speed <= 20"
    assert "variation top_speed=25,limit=20 of fig1_sweep.json" in doc["description"]
    assert run_case(doc).verdict == "fail"
    assert cli("run", str(out / "fig1_sweep[top_speed=10,limit=20].json")).returncode == 0
    # invalid: exit 2, nothing written
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(swept({"d": 1}, {"d": [1, -1]}, entry("A", duration="$d"))))
    result = cli("expand", str(bad), "--out-dir", str(tmp_path / "none"))
    assert result.returncode == 2 and not (tmp_path / "none").exists()
    assert f"{bad}: /execute/0/params/duration: must not be negative (got -1) (in variation: [d=-1])" in result.stderr


def test_file_names_are_filesystem_safe() -> None:
    from btgen_pytrees.sweep.runs import file_name

    assert file_name("cut in/out: v2", "gap=5,speed=-1.5", 0) == "cut_in_out__v2[gap=5,speed=-1.5].json"
    long = file_name("n", ",".join(f"p{i}=1" for i in range(60)), 7)
    assert len(long) <= 200 and long.startswith("n[7-")
    assert file_name("..", "a=1", 0) == "case[a=1].json"


def test_run_sweep_reports_every_variation(tmp_path: pathlib.Path) -> None:
    j1, j2, junit = tmp_path / "1.json", tmp_path / "2.json", tmp_path / "j.xml"
    one = cli("run", str(FIG1_SWEEP), "--jobs", "1", "--json", str(j1), "--junit", str(junit))
    two = cli("run", str(FIG1_SWEEP), "--jobs", "2", "--json", str(j2))
    assert one.returncode == two.returncode == 1
    assert j1.read_bytes() == j2.read_bytes()  # byte-identical whatever the number of workers
    assert one.stdout == two.stdout
    report = json.loads(j1.read_text())
    assert report["counts"] == {"pass": 18, "fail": 10} and report["variations"] == len(report["rows"]) == 28
    fails = {r["label"] for r in report["rows"] if r["verdict"] == "fail"}
    assert fails == {f"top_speed={s},limit={lim}" for s in (25, 30, 35, 40) for lim in (20, 25, 30, 35) if s > lim}
    lines = one.stdout.splitlines()
    assert lines[0] == "fig1_sweep: 28 variations of top_speed x limit: 18 pass, 10 fail"
    assert lines[3].split()[:2] == ["top_speed=40,limit=20", "FAIL"]  # failed earliest: worst first
    assert "R1: speed <= 20 false by 2 at 1.1 s" in lines[3]
    xml = junit.read_text()
    assert xml.count("<testcase ") == 28 and xml.count("<failure ") == 10
    assert 'name="fig1_sweep[top_speed=40,limit=35]"' in xml


def test_run_sweep_exit_codes_and_refusals(tmp_path: pathlib.Path) -> None:
    ok = tmp_path / "ok.json"
    ok.write_text(json.dumps(swept({"d": 1}, {"d": [1, 2]}, entry("A", duration="$d"))))
    assert cli("run", str(ok), "--jobs", "1").returncode == 0
    over = cli("run", str(FIG1_SWEEP), "--max-variations", "10", "--json", str(tmp_path / "r.json"))
    assert over.returncode == 2 and "28 variations; the limit is 10" in over.stderr
    assert not (tmp_path / "r.json").exists()
    zero = cli("run", str(FIG1_SWEEP), "--max-variations", "0")
    assert zero.returncode == 2 and "--max-variations 0: must be at least 1" in zero.stderr
    for extra, message in ((["--trace"], "--trace"), (["--plot", str(tmp_path / "m.pdf")], ".svg, .png or .html"),
                           (["--executor", "dask"], "--scheduler")):  # fmt: skip
        result = cli("run", str(ok), *extra)
        assert result.returncode == 2 and message in result.stderr and "Traceback" not in result.stderr


# ---------------------------------------------------------------------------
# the verdict map


def _report(varied: dict[str, Any], verdict: Any, margin: Any = None) -> Any:
    from btgen_pytrees.sweep.report import SweepReport

    sweep = Variations.parse(varied)
    names = [a.name for a in sweep.axes]
    rows = []
    for i, point in enumerate(sweep.points()):
        values = dict(point)
        rows.append({"index": i, "label": label(point), "parameters": values, "verdict": verdict(values),
                     "message": "", "duration": 1.0, "ticks": 1, "margin": margin(values) if margin else None, "oracles": []})  # fmt: skip
    return SweepReport("m", "m.json", {}, tuple(names + (["sample"] if sweep.randoms else [])), rows)


def test_map_grid_colours_each_cell_by_its_verdict() -> None:
    pytest.importorskip("matplotlib")
    from matplotlib.colors import to_hex

    from btgen_pytrees.sweep.plot import VERDICT_COLOURS, map_bytes, map_figure

    report = _report({"gap": [5, 10, 20], "speed": [10, 20]}, lambda v: "fail" if v["gap"] < v["speed"] else "pass")
    ax = map_figure(report).axes[0]
    cells = {(round(p.get_x() + 0.5), round(p.get_y() + 0.5)): to_hex(p.get_facecolor()) for p in ax.patches}
    assert len(cells) == 6
    assert cells[(0, 0)] == VERDICT_COLOURS["fail"]  # gap 5 < speed 10
    assert cells[(2, 1)] == VERDICT_COLOURS["pass"]  # gap 20 >= speed 20
    assert [t.get_text() for t in ax.get_xticklabels()] == ["5", "10", "20"]
    assert map_bytes(report, "svg") == map_bytes(report, "svg")


def test_map_uses_margins_strips_scatter_and_parallel_coordinates() -> None:
    pytest.importorskip("matplotlib")
    from btgen_pytrees.sweep.plot import map_figure

    margins = _report({"gap": [5, 10, 20], "speed": [10, 20]}, lambda v: "fail" if v["gap"] < v["speed"] else "pass",
                      lambda v: v["gap"] - v["speed"])  # fmt: skip
    figure = map_figure(margins)
    assert len(figure.axes) == 2 and "margin" in figure.axes[1].get_ylabel()  # the colour bar
    colours = {round(p.get_x() + 0.5): p.get_facecolor() for p in figure.axes[0].patches if round(p.get_y() + 0.5) == 0}
    assert colours[0][0] > colours[0][1] and colours[2][1] > colours[2][0]  # margin -5 reddish, +10 greenish
    strip = map_figure(_report({"gap": [1, 2, 3, 4]}, lambda v: "pass"))
    assert len(strip.axes[0].patches) == 4
    scatter = map_figure(_report({"a": {"uniform": [0, 1]}, "b": {"uniform": [0, 1]}, "samples": 20}, lambda v: "pass"))
    assert len(scatter.axes[0].collections) == 20
    many = map_figure(_report({"a": [1, 2], "b": [1, 2], "c": [1, 2]}, lambda v: "timeout" if v["c"] == 2 else "pass"))
    assert len(many.axes[0].lines) == 8 + 3  # a line per variation, an axis per parameter


needs_sumo = pytest.mark.skipif(
    __import__("importlib").util.find_spec("libsumo") is None and not __import__("os").environ.get("CI"),
    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)",
)


@needs_sumo
def test_the_sumo_cut_in_sweep_fails_where_the_gap_is_small_and_the_speed_high(tmp_path: pathlib.Path) -> None:
    data = json.loads((ROOT / "examples" / "sumo" / "cut_in_sweep.json").read_text())
    data["variations"] = {"gap": [1, 8], "ego_speed": [21, 25]}
    for name in ("cut_in.sumocfg", "cut_in.rou.xml", "road.net.xml"):  # the scenario files, beside the case
        (tmp_path / name).write_bytes((ROOT / "examples" / "sumo" / name).read_bytes())
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(data))
    result = cli("run", str(path), "--jobs", "2", "--json", str(tmp_path / "r.json"))
    assert result.returncode == 1, result.stderr
    rows = {r["label"]: r["verdict"] for r in json.loads((tmp_path / "r.json").read_text())["rows"]}
    assert rows == {"gap=1,ego_speed=21": "fail", "gap=1,ego_speed=25": "fail",
                    "gap=8,ego_speed=21": "pass", "gap=8,ego_speed=25": "pass"}  # fmt: skip


def test_every_variation_is_validated_as_a_stream() -> None:
    """Issue 20 item 13: validating a sweep holds one variation's document at a time (was: every one of them)."""
    import tracemalloc

    chain = [entry(f"A{i}", [f"A{i - 1}"] if i else [], duration="$d") for i in range(20)]
    data = swept({"d": 1}, {"d": {"from": 1, "to": 1500, "step": 1}}, *chain, timeout=1e6, tick=1)
    load_sweep(swept({"d": 1}, {"d": [1, 2]}, *chain, timeout=1e6, tick=1))  # caches filled before measuring
    tracemalloc.start()
    try:
        assert load_sweep(data).count == 1500
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 3_000_000, peak  # 1,500 documents of ~8 kB held at once took 12 MB


def test_a_range_whose_values_collide_is_refused(tmp_path: pathlib.Path) -> None:
    """Issue 19 item 10: six labels, one value - refused (exit 2, the step's JSON path), nothing run or written."""
    data = swept({"x": 0}, {"x": {"from": 0, "to": 5e-13, "step": 1e-13}}, entry("A", duration="$x"))
    assert problems(data) == [("/variations/x/step", "step 1e-13 is finer than the range's values keep: values 1 and 2 "
                               "are both 0 (values are rounded to 12 decimal places); use a larger step")]  # fmt: skip
    big = swept({"x": 0}, {"x": {"from": 1e16, "to": 1e16 + 8, "step": 1}}, entry("A", duration="$x"), timeout=1e17)
    assert [p for p, _ in problems(big)] == ["/variations/x/step"]  # floats 2 apart there: 1e16 + 1 == 1e16
    fine = swept({"x": 0}, {"x": {"from": 0, "to": 5e-11, "step": 1e-11}}, entry("A", duration="$x"))
    assert [v.label for v in load_sweep(fine)] == ["x=0", "x=1e-11", "x=2e-11", "x=3e-11", "x=4e-11", "x=5e-11"]
    path = tmp_path / "s.json"
    path.write_text(json.dumps(data))
    for command in (["run", str(path), "--json", str(tmp_path / "r.json")], ["expand", str(path), "--out-dir", str(tmp_path / "x")],
                    ["validate", str(path)]):  # fmt: skip
        result = cli(*command)
        assert result.returncode == 2 and "/variations/x/step: step 1e-13 is finer" in result.stderr, command
    assert not (tmp_path / "r.json").exists() and not (tmp_path / "x").exists()


@needs_sumo
def test_every_expanded_sumo_case_runs_where_it_was_written_and_gives_its_rows_verdict(tmp_path: pathlib.Path) -> None:
    """Issue 19 item 9: the config of an expanded case is rewritten relative to --out-dir."""
    data = json.loads((ROOT / "examples" / "sumo" / "cut_in_sweep.json").read_text())
    data["variations"] = {"gap": [1, 8], "ego_speed": [25]}
    cases = tmp_path / "cases"
    cases.mkdir()
    for name in ("cut_in.sumocfg", "cut_in.rou.xml", "road.net.xml"):
        (cases / name).write_bytes((ROOT / "examples" / "sumo" / name).read_bytes())
    (cases / "sweep.json").write_text(json.dumps(data))
    assert cli("run", "sweep.json", "--json", str(tmp_path / "r.json"), cwd=cases).returncode == 1
    rows = {r["label"]: r["verdict"] for r in json.loads((tmp_path / "r.json").read_text())["rows"]}
    assert rows == {"gap=1,ego_speed=25": "fail", "gap=8,ego_speed=25": "pass"}
    out = tmp_path / "expanded" / "deeper"
    assert cli("expand", "sweep.json", "--out-dir", str(out), cwd=cases).returncode == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    for label, verdict in rows.items():
        written = out / f"cut_in_sweep[{label}].json"
        assert json.loads(written.read_text())["system"]["config"] == "../../cases/cut_in.sumocfg"
        result = cli("run", str(written), cwd=elsewhere)
        assert result.returncode == (0 if verdict == "pass" else 1), result.stderr
        assert f"cut_in_sweep[{label}]: {verdict.upper()}" in result.stdout  # named after its variation
    assert cli("expand", "sweep.json", "--out-dir", ".", cwd=cases).returncode == 0  # beside the sweep: as written
    assert json.loads((cases / "cut_in_sweep[gap=1,ego_speed=25].json").read_text())["system"]["config"] == "cut_in.sumocfg"


def test_the_sweep_benchmark_runs_and_every_engine_agrees(capsys: pytest.CaptureFixture[str]) -> None:
    sys.path.insert(0, str(ROOT))  # benchmarks/ is beside the package (see test_benchmarks_smoke)
    from benchmarks import sweep as bench

    assert bench.main(["--variations", "30", "--repeats", "1", "--no-dask"]) == 0  # asserts equal verdicts itself
    out = capsys.readouterr().out
    assert "fig1 sweep: 30 variations" in out and "local --jobs 2" in out and "speed-up 1 -> 2" in out


def test_every_variation_runs_within_the_work_budget(tmp_path: pathlib.Path) -> None:
    """--max-work reaches every variation's run (issue 20 item 1): one that spends it is stopped with `error`."""
    path = tmp_path / "work.json"
    path.write_text(json.dumps(swept({"dt": 0.1}, {"dt": [0.1, 0.01]}, entry("A", duration=20), tick="$dt", timeout=100)))
    for jobs in ("1", "2"):
        result = cli("run", str(path), "--max-work", "5000", "--jobs", jobs, "--json", str(tmp_path / "r.json"))
        assert result.returncode == 1, result.stderr
        rows = json.loads((tmp_path / "r.json").read_text())["rows"]
        assert [r["verdict"] for r in rows] == ["pass", "error"]
        assert rows[1]["message"].startswith("stopped: the work budget of 5e+03 units is spent after 454 ticks x 11")
        assert rows[1]["ticks"] == 454 and rows[1]["duration"] == 4.53  # the partial run is kept
    assert cli("run", str(path), "--max-work", "30000").returncode == 0  # 201 x 11 and 2001 x 11: both fit
    assert cli("run", str(path)).returncode == 0  # the default budget: a timeout of 100 s is not charged up front
    refused = cli("run", str(path), "--max-work", "10", "--json", str(tmp_path / "none.json"))
    assert refused.returncode == 2 and not (tmp_path / "none.json").exists()  # one tick is 11 units: certain to exceed
    assert "/execute: one tick of this tree is 11 units of work" in refused.stderr


def test_require_complete_reaches_every_variation(tmp_path: pathlib.Path) -> None:
    """A final at 2 s passes with the timeline unfinished: --require-complete fails each variation, as alone."""
    data = case(entry("A", duration="$d"), entry("H", ["A"]), criteria=[crit("F", "final", "true", at=2)])
    path = tmp_path / "early.json"
    path.write_text(json.dumps({**data, "parameters": {"d": 3}, "variations": {"d": [1, 3]}}))
    assert cli("run", str(path)).returncode == 0
    result = cli("run", str(path), "--require-complete", "--json", str(tmp_path / "r.json"))
    assert result.returncode == 1, result.stdout
    rows = json.loads((tmp_path / "r.json").read_text())["rows"]
    assert [r["verdict"] for r in rows] == ["pass", "fail"]  # d=1: A and H end by 2 s; d=3: A is stopped
    alone = tmp_path / "alone.json"
    assert cli("expand", str(path), "--out-dir", str(tmp_path / "x")).returncode == 0
    alone = tmp_path / "x" / "t[d=3].json"
    assert cli("run", str(alone), "--require-complete").returncode == 1


def test_a_dying_worker_costs_its_own_variation_and_a_raising_leaf_only_its_variation(tmp_path: pathlib.Path) -> None:
    """A worker that dies takes its chunk's runs with it; they run again one per job, so only the variation that
    kills its worker is an error (the chunk's other two were errors too, and a Dask cluster said otherwise)."""
    (tmp_path / "dying_plugin.py").write_text(DYING_PLUGIN)
    data = swept({"w": 0}, {"w": list(range(1, 41))}, entry("A", action="maybe_die", when="$w"))
    path = tmp_path / "s.json"
    path.write_text(json.dumps(data))
    result = cli("run", str(path), "--plugin", str(tmp_path / "dying_plugin.py"), "--jobs", "2", "--json", str(tmp_path / "r.json"))
    assert result.returncode == 1, result.stderr
    rows = json.loads((tmp_path / "r.json").read_text())["rows"]
    assert len(rows) == 40 and [r["label"] for r in rows] == [f"w={k}" for k in range(1, 41)]  # complete, in order
    verdicts = {r["label"]: r["verdict"] for r in rows}
    # chunks of 3 variations (40 over 2 workers x 8): w=3 kills the worker running w=1..3, then again alone
    assert [verdicts[f"w={k}"] for k in (1, 2, 3)] == ["pass", "pass", "error"]
    assert "worker process exited" in rows[2]["message"]
    assert verdicts["w=5"] == "error" and "SystemExit" in rows[4]["message"]
    assert [k for k, v in verdicts.items() if v != "pass"] == ["w=3", "w=5"]
