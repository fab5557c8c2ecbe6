"""The replay page (``run --replay``): one self-contained file, its data is the trace, it works in a real browser.

The page is checked as text (self-contained, everything escaped, its data the
run's trace), and in headless Chromium (Debian's ``chromium`` +
``chromium-driver``, driven by selenium): the slider and the arrow keys move
through the ticks, and the status of a node and the value of a signal on the
page change exactly as the trace says; a screenshot is not blank. The page
needs no Graphviz (the tests hide ``dot``). Chromium tests skip only outside
CI (``.ci/run`` installs it). Zoom, collapse, search and the SUMO scene:
tests/test_replay_views.py.
"""

from __future__ import annotations

import io
import json
import os
import pathlib
import re
import shutil
from typing import Any

import py_trees
import pytest
from browser import chromium, chromium_present
from helpers import case, entry

import btgen_pytrees
from btgen_pytrees.cli import main
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.render.nodes import walk
from btgen_pytrees.run import run
from btgen_pytrees.run.replay import MAX_NODES, auto_depth, replay_html

ROOT = pathlib.Path(__file__).resolve().parent.parent
FAILING = str(ROOT / "examples" / "fig1_failing.json")
needs_chromium = pytest.mark.skipif(not chromium_present() and not os.environ.get("CI"),
                                    reason="chromium, chromium-driver or selenium missing (CI installs them)")  # fmt: skip
HOSTILE = "</script><script>window.pwned=1</script>\x01<!--"


def page_of(data: Any, registry: Any = None) -> tuple[str, Any, Any]:
    loaded = btgen_pytrees.load(data, registry=registry)
    report = run(loaded, registry=registry)
    return replay_html(report, loaded, btgen_pytrees.generate(loaded, registry=registry)).decode("utf-8"), report, loaded


def embedded(page: str) -> dict[str, Any]:
    match = re.search(r'<script type="application/json" id="run-data">(.*?)</script>', page, re.S)
    assert match
    return json.loads(match.group(1))  # type: ignore[no-any-return]


def test_page_is_self_contained_and_its_data_is_the_trace() -> None:
    page, report, _ = page_of(FAILING)
    assert page.startswith("<!DOCTYPE html>")
    assert not re.search(r"<script[^>]*\bsrc=|<link\b|@import|url\(|<iframe|<img\b", page)
    assert not re.search(r"""(?:href|src)=["']?(?:https?:|//)""", page)  # nothing to fetch (xmlns are names)
    data = embedded(page)
    trace = report.trace
    assert data["transitions"] == trace.to_data()["transitions"] and data["times"] == trace.times
    assert data["signals"]["speed"] == [[k, v] for k, v in zip(*trace.signals["speed"])]
    assert data["verdict"] == "fail" and data["oracles"][0]["message"] == report.oracles[0].message
    assert data["message"] == report.message and data["explanation"] == list(getattr(report, "explanation", []))
    assert len(data["nodes"]) == len(trace.nodes) and data["collapsedBelow"] is None
    assert [row[4] for row in data["nodes"]] == [n.id for n in trace.nodes]  # node i of the page is node i of the trace


class Shout(py_trees.behaviour.Behaviour):
    """A user leaf that writes a hostile string into a signal and fails with it."""

    def __init__(self, entry_: Any, env: Any):
        super().__init__(name=entry_.name)
        self.env = env

    def update(self) -> py_trees.common.Status:
        self.env.write("x", HOSTILE)
        self.feedback_message = HOSTILE
        return py_trees.common.Status.FAILURE


def test_every_text_is_escaped() -> None:
    """A test, entry, criterion and signal value may hold anything: nothing becomes markup or ends a script."""
    registry = default_registry()
    registry.register("shout", Shout, kind="behavior", params_schema={"type": "object"})
    data = case({"id": "B1", "name": HOSTILE, "kind": "behavior", "action": "shout", "params": {}},
                criteria=[{"id": "F1", "name": HOSTILE, "type": "final", "expect": "true"}], name=HOSTILE)  # fmt: skip
    page, report, _ = page_of(data, registry)
    assert report.verdict == "fail" and HOSTILE in report.message
    assert page.count("<script") == 2 and page.count("</script>") == 2  # the data block and the page's script
    assert "<!--" not in page.replace("\\u003c!--", "")  # no comment opens anywhere (the data escapes every <)
    assert "\x01" not in page  # the raw control character: nowhere (JSON escapes it)
    assert "<title>&lt;/script&gt;&lt;script&gt;window.pwned=1&lt;/script&gt;\\x01&lt;!--: fail" in page
    values = embedded(page)
    assert values["test"] == HOSTILE and values["signals"]["x"] == [[0, HOSTILE]]
    assert values["execute"][0]["message"] == HOSTILE


def test_auto_depth_keeps_the_picture_small() -> None:
    big = case(*[entry(f"E{i}", [f"E{i - 1}"] if i % 4 else [], duration=0.1) for i in range(2000)], timeout=1)
    root = btgen_pytrees.generate(btgen_pytrees.load(big))
    depth = auto_depth(root)
    assert depth is not None
    assert sum(1 for d, _ in walk(root) if d <= depth) <= MAX_NODES < sum(1 for d, _ in walk(root) if d <= depth + 1)
    fig1 = btgen_pytrees.generate(btgen_pytrees.load(str(ROOT / "examples" / "fig1.json")))
    assert auto_depth(fig1) is None


def test_cli_replay_needs_no_graphviz(tmp_path: pathlib.Path, capsys: Any, monkeypatch: Any) -> None:
    """Issue 23 item 6: --replay works after pip install alone; before, it exited 2 without Graphviz's dot."""
    monkeypatch.setenv("PATH", str(tmp_path))  # no dot, nothing else either
    assert shutil.which("dot") is None
    out = tmp_path / "run.html"
    assert main(["run", FAILING, "--replay", str(out)]) == 1  # the verdict's exit code
    page = out.read_text(encoding="utf-8")
    assert "fig1_failing" in page and "<svg" in page and len(embedded(page)["nodes"]) == 27


# -- in the browser -----------------------------------------------------------------------------------


def page_status(driver: Any) -> dict[str, Any]:
    return driver.execute_script("""
        const out = {tick: Number(document.body.dataset.tick), nodes: {}, signals: {}, oracles: {}};
        for (const g of document.querySelectorAll('#tree g.node[data-node]')) out.nodes['n' + g.dataset.node] = g.dataset.status;
        for (const tr of document.querySelectorAll('#signals tr[data-signal]')) out.signals[tr.dataset.signal] = tr.children[1].textContent;
        for (const tr of document.querySelectorAll('#oracles tr[data-criterion]')) out.oracles[tr.dataset.criterion] = tr.children[2].textContent;
        return out;""")  # fmt: skip


def shown(value: Any) -> str:
    return "\u2014" if value is None else f"{value:g}" if isinstance(value, (int, float)) else str(value)


def expected_at(report: Any, k: int) -> dict[str, Any]:
    trace = report.trace
    statuses = trace.statuses_at(k)
    return {"tick": k, "nodes": {f"n{i}": s for i, s in enumerate(statuses)},
            "signals": {name: shown(trace.value_at(name, k)) for name in trace.signals}}  # fmt: skip


@needs_chromium
def test_browser_slider_and_keys_follow_the_trace(tmp_path: pathlib.Path) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    page, report, loaded = page_of(FAILING)
    path = tmp_path / "replay.html"
    path.write_text(page, encoding="utf-8")
    trace = report.trace
    b4, r1 = f"n{trace.node_index('B4')}", trace.node_index("R1")
    with chromium() as driver:
        driver.get(path.as_uri())
        assert driver.execute_script("return document.body.dataset.ready") == "1"
        last = len(trace.times) - 1
        state = page_status(driver)
        assert {k: state[k] for k in ("tick", "nodes", "signals")} == expected_at(report, last)
        assert state["oracles"]["R1"] == "failure" == trace.status_at(r1, last)
        why = driver.find_element("id", "why").text
        assert report.message in why and report.oracles[0].message in why  # the explanation heads the page
        # move the slider with the mouse: to its left end, then a little right
        slider = driver.find_element("id", "slider")
        width = slider.size["width"]
        ActionChains(driver).move_to_element_with_offset(slider, -width // 2 + 2, 0).click().perform()
        assert page_status(driver)["tick"] == 0
        ActionChains(driver).click_and_hold(slider).move_by_offset(-int(width * 0.2), 0).release().perform()  # from the middle
        moved = page_status(driver)
        assert 0 < moved["tick"] < last
        assert {k: moved[k] for k in ("tick", "nodes", "signals")} == expected_at(report, moved["tick"])
        # then the keyboard, to tick 14 and over the change at tick 15 (B4 sets target to 25)
        body = driver.find_element("tag name", "body")
        for _ in range(abs(moved["tick"] - 14)):
            body.send_keys(Keys.ARROW_LEFT if moved["tick"] > 14 else Keys.ARROW_RIGHT)
        before = page_status(driver)
        assert before["tick"] == 14 and before["nodes"][b4] == "invalid" and before["signals"]["target"] == "0"
        body.send_keys(Keys.ARROW_RIGHT)
        after = page_status(driver)
        assert after["tick"] == 15 and after["nodes"][b4] == "success" and after["signals"]["target"] == "25"
        assert trace.status_at(trace.node_index("B4"), 15) == "success" and trace.value_at("target", 15) == 25
        changed = {n for n in after["nodes"] if after["nodes"][n] != before["nodes"][n]}
        assert changed == {f"n{i}" for k, i, _ in trace.transitions() if k == 15}
        assert after["signals"]["speed"] == shown(trace.value_at("speed", 15)) != before["signals"]["speed"]
        body.send_keys(Keys.ARROW_LEFT)
        assert page_status(driver) == before
        png = driver.get_screenshot_as_png()
    assert_not_blank(png)


@needs_chromium
def test_browser_opens_a_2000_entry_case(tmp_path: pathlib.Path) -> None:
    big = case(*[entry(f"E{i}", [f"E{i - 1}"] if i % 4 else [], action="ramp", signal=f"s{i % 7}", to=i, duration=0.2)
                 for i in range(2000)], timeout=2)  # fmt: skip
    loaded = btgen_pytrees.load(big)
    report = run(loaded)
    path = tmp_path / "big.html"
    path.write_bytes(replay_html(report, loaded, btgen_pytrees.generate(loaded)))
    assert path.stat().st_size < 4_000_000
    data = embedded(path.read_text(encoding="utf-8"))
    assert data["collapsedBelow"] is None and len(data["nodes"]) == len(report.trace.nodes)
    with chromium() as driver:
        driver.get(path.as_uri())
        assert driver.execute_script("return document.body.dataset.ready") == "1"
        assert driver.execute_script("return window.btgenReplay.shown()") <= MAX_NODES  # opened breadth first
        driver.find_element("tag name", "body").send_keys("\ue012")  # ←
        state = page_status(driver)
        assert state["tick"] == len(report.trace.times) - 2
        assert state["signals"]["s3"] == shown(report.trace.value_at("s3", state["tick"]))
        assert_not_blank(driver.get_screenshot_as_png())


def assert_not_blank(png: bytes) -> None:
    """A real picture: a PNG whose pixels are far from one colour (page text, the tree, the curves)."""
    from matplotlib.image import imread

    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    pixels = imread(io.BytesIO(png))[:, :, :3]
    assert pixels.shape[0] > 300 and pixels.shape[1] > 600
    not_white = (pixels < 0.9).any(axis=2).mean()
    colours = len({tuple(p) for p in (pixels[::7, ::7].reshape(-1, 3) * 255).astype(int).tolist()})
    assert not_white > 0.02 and colours > 20, (not_white, colours)


def test_readme_shows_the_replay_page() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "docs/images/fig1-replay.png" in readme
    png = (ROOT / "docs" / "images" / "fig1-replay.png").read_bytes()
    assert_not_blank(png)


class _Passing:
    """A system owning ``car.speed`` (= the tick) on ticks 2-4 and 7-8 only: a vehicle that leaves and comes back."""

    def __init__(self) -> None:
        self.k = 0

    def start(self, env: Any) -> None:
        self.key = env.namespace + "/signals/car.speed"

    def now(self) -> float:
        return round(self.k * 0.1, 9)

    def publish(self, env: Any) -> None:
        if 2 <= self.k <= 4 or 7 <= self.k <= 8:
            env.publish("car.speed", float(self.k))
        else:
            py_trees.blackboard.Blackboard.storage.pop(self.key, None)

    def tick(self) -> None:
        self.k += 1

    def close(self) -> None:
        pass


class _PassingType:
    name = "passing"
    options = ()

    def describe(self, spec: Any, case_data: Any) -> Any:
        from btgen_pytrees.systems import SystemInfo

        return SystemInfo(signals=("car.speed",))

    def create(self, spec: Any, case: Any) -> _Passing:
        return _Passing()


@needs_chromium
def test_browser_a_signal_that_ended_has_no_value_and_its_curve_a_gap(tmp_path: pathlib.Path) -> None:
    from selenium.webdriver.common.keys import Keys

    registry = default_registry()
    registry.register_system(_PassingType())
    data = case(entry("W", action="wait", duration=1), system={"type": "passing"}, tick=0.1, timeout=2)
    page, report, _ = page_of(data, registry)
    assert embedded(page)["signals"]["car.speed"] == [[2, 2.0], [3, 3.0], [4, 4.0], [5], [7, 7.0], [8, 8.0], [9]]
    path = tmp_path / "ended.html"
    path.write_text(page, encoding="utf-8")
    with chromium() as driver:
        driver.get(path.as_uri())
        assert driver.execute_script("return document.body.dataset.ready") == "1"
        lines = driver.execute_script(
            "return document.querySelectorAll('#signals tr[data-signal=\"car.speed\"] polyline').length")
        assert lines == 2  # two stretches with a value, nothing drawn where the car was gone
        body = driver.find_element("tag name", "body")
        body.send_keys(Keys.HOME)
        shown = []
        for _ in range(10):
            shown.append(page_status(driver)["signals"]["car.speed"])
            body.send_keys(Keys.ARROW_RIGHT)
        assert shown == ["\u2014", "\u2014", "2", "3", "4", "\u2014", "\u2014", "7", "8", "\u2014"]


def test_the_page_is_made_of_package_data_files() -> None:
    """The page's HTML, style and script are files of the package (read with importlib.resources), listed as
    package data so that a wheel carries them; the page is the template with those files put in, unchanged."""
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    from fnmatch import fnmatch

    from btgen_pytrees.run.replay import asset

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["package-data"]
    package = ROOT / "btgen_pytrees"
    data = [p.relative_to(package).as_posix() for p in package.rglob("*")
            if p.is_file() and p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts]  # fmt: skip
    assert {"run/replay.html", "run/replay.css", "run/replay.js"} <= set(data)
    assert [name for name in data if not any(fnmatch(name, glob) for glob in declared["btgen_pytrees"])] == []
    page, _, _ = page_of(FAILING)
    template = asset("replay.html")
    for name, slot in (("replay.css", "@STYLE@"), ("replay.js", "@SCRIPT@")):
        text = (package / "run" / name).read_text(encoding="utf-8")
        assert asset(name) == text and slot in template and text in page
    before, _, after = template.partition("@DATA@")
    assert page.startswith(before.split("@TITLE@")[0]) and page.endswith(after.split("@SCRIPT@")[1])
    assert not re.search(r"@(TITLE|STYLE|SCRIPT|DATA)@", page)
