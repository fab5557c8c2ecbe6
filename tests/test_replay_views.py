"""The replay page at real size (issue 23, items 6-9), in headless Chromium, without Graphviz.

On fig1, the SUMO cut-in (real SUMO through libsumo) and a generated
500-entry case: the tree is laid out by the page (``dot`` is hidden from
PATH), it zooms (buttons, wheel), pans (drag), fits and goes back to 100 %;
a click collapses and expands a subtree; a search finds a node deep in a
collapsed subtree and shows it readable; the bird's-eye scene draws the lanes
of the case's network and every vehicle where the trace says, oriented,
coloured, with a hover that shows its signals; the tick count is the same in
the headline and at the slider. Chromium and libsumo tests skip only outside CI.
"""

from __future__ import annotations

import importlib.util
import json
import os
import pathlib
import shutil
import sys
from typing import Any

import pytest
from browser import chromium, chromium_present
from helpers import case, crit

import btgen_pytrees
from btgen_pytrees.run import run
from btgen_pytrees.run.replay import MAX_NODES, replay_html
from btgen_pytrees.run.scene import Scene
from btgen_pytrees.systems import SystemInfo, SystemSpec

ROOT = pathlib.Path(__file__).resolve().parent.parent
CUT_IN = str(ROOT / "examples" / "sumo" / "cut_in.json")
FAILING = str(ROOT / "examples" / "fig1_failing.json")
sys.path.insert(0, str(ROOT / "docs"))
from pictures import timeline_case  # noqa: E402

needs_chromium = pytest.mark.skipif(not chromium_present() and not os.environ.get("CI"),
                                    reason="chromium, chromium-driver or selenium missing (CI installs them)")  # fmt: skip
needs_sumo = pytest.mark.skipif(importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
                                reason="libsumo is not installed (CI installs it)")  # fmt: skip


@pytest.fixture
def no_dot(tmp_path: pathlib.Path, monkeypatch: Any) -> None:
    """Graphviz hidden: PATH has only an empty directory (the browser and its driver are found by absolute paths)."""
    empty = tmp_path / "bin"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    assert shutil.which("dot") is None


def write_page(tmp_path: pathlib.Path, source: Any, name: str, **kw: Any) -> tuple[pathlib.Path, Any, Any]:
    loaded = btgen_pytrees.load(source)
    report = run(loaded)
    path = tmp_path / f"{name}.html"
    path.write_bytes(replay_html(report, loaded, btgen_pytrees.generate(loaded), **kw))
    return path, report, loaded


def js(driver: Any, script: str) -> Any:
    return driver.execute_script("return " + script)


def node_box(driver: Any, selector: str) -> dict[str, float]:
    return js(driver, f"(() => {{ const r = document.querySelector({json.dumps(selector)}).getBoundingClientRect(); "
                      "return {x: r.left, y: r.top, w: r.width, h: r.height}; })()")  # fmt: skip


def tree_box(driver: Any) -> dict[str, float]:
    return node_box(driver, "#tree")


def inside(inner: dict[str, float], outer: dict[str, float]) -> bool:
    return (outer["x"] <= inner["x"] and inner["x"] + inner["w"] <= outer["x"] + outer["w"] + 0.5
            and outer["y"] <= inner["y"] and inner["y"] + inner["h"] <= outer["y"] + outer["h"] + 0.5)  # fmt: skip


def label_px(driver: Any, selector: str) -> float:
    """The height on screen of a node's name (its font size times the zoom)."""
    return js(driver, f"document.querySelector({json.dumps(selector + ' text')}).getBoundingClientRect().height")  # type: ignore[no-any-return]


# -- 9. one tick count ---------------------------------------------------------------------------------


@needs_chromium
def test_one_tick_count_everywhere(tmp_path: pathlib.Path, no_dot: None) -> None:
    """The headline said 17 ticks while the slider said "tick 16 of 16"."""
    path, report, _ = write_page(tmp_path, FAILING, "fig1")
    assert report.ticks == len(report.trace.times) == 17
    with chromium() as driver:
        driver.get(path.as_uri())
        assert "(17 ticks)" in driver.find_element("id", "headline").text
        assert driver.find_element("id", "clock").text.endswith("tick 17 of 17")
        driver.find_element("tag name", "body").send_keys("\ue011")  # Home
        assert driver.find_element("id", "clock").text == "t = 0 s · tick 1 of 17"


# -- 7. zoom, pan, fit, 100 %, collapse, search -----------------------------------------------------------


@needs_chromium
def test_zoom_pan_fit_and_collapse_on_fig1(tmp_path: pathlib.Path, no_dot: None) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin

    path, report, _ = write_page(tmp_path, FAILING, "fig1")
    with chromium() as driver:
        driver.get(path.as_uri())
        assert js(driver, "window.btgenReplay.shown()") == len(report.trace.nodes) == 27  # small: all open
        assert label_px(driver, "#tree g.node[data-node='0']") >= 10  # readable when it opens
        start = js(driver, "window.btgenReplay.view()")
        driver.find_element("id", "zoom-in").click()
        assert js(driver, "window.btgenReplay.view()")["s"] == pytest.approx(start["s"] * 1.25)
        driver.find_element("id", "zoom-out").click()
        assert js(driver, "window.btgenReplay.view()")["s"] == pytest.approx(start["s"])
        tree = driver.find_element("id", "tree")
        ActionChains(driver).scroll_from_origin(ScrollOrigin.from_element(tree), 0, -300).perform()  # the wheel
        assert js(driver, "window.btgenReplay.view()")["s"] > start["s"] * 1.2
        driver.find_element("id", "fit").click()
        box = tree_box(driver)
        for i in range(27):  # every node inside the view
            assert inside(node_box(driver, f"#tree g.node[data-node='{i}'] rect"), box), i
        driver.find_element("id", "actual").click()
        assert js(driver, "window.btgenReplay.view()")["s"] == 1
        before = js(driver, "window.btgenReplay.view()")
        ActionChains(driver).move_to_element_with_offset(tree, 0, 150).click_and_hold().move_by_offset(-120, -40)\
            .release().perform()  # fmt: skip
        after = js(driver, "window.btgenReplay.view()")
        assert (after["x"] - before["x"], after["y"] - before["y"]) == (pytest.approx(-120, abs=2), pytest.approx(-40, abs=2))
        # collapse the oracle subtree by a click, then expand it again
        oracle = js(driver, "Array.from(document.querySelectorAll('#tree g.node')).find((g) => g.textContent.startsWith('oracle')).dataset.node")
        driver.find_element("id", "fit").click()
        driver.find_element("css selector", f"#tree g.node[data-node='{oracle}'] rect").click()
        assert js(driver, "window.btgenReplay.collapsed()") == [int(oracle)]
        hidden = js(driver, "window.btgenReplay.shown()")
        assert hidden < 27 and driver.find_element("css selector", f"#tree g.node[data-node='{oracle}'] text.more").text == f"+{27 - hidden}"
        # the collapsed box shows the most telling status inside: R1 failed
        assert driver.find_element("css selector", f"#tree g.node[data-node='{oracle}']").get_attribute("data-status") == "failure"
        driver.find_element("css selector", f"#tree g.node[data-node='{oracle}'] rect").click()
        assert js(driver, "window.btgenReplay.shown()") == 27 and js(driver, "window.btgenReplay.collapsed()") == []
        driver.find_element("tag name", "body").send_keys("+")
        assert js(driver, "window.btgenReplay.view()")["s"] > 0


@needs_chromium
def test_a_500_entry_case_is_usable(tmp_path: pathlib.Path, no_dot: None) -> None:
    path, report, loaded = write_page(tmp_path, timeline_case(), "big")
    assert len(loaded.entries) == 500 and len(report.trace.nodes) > 1000
    target = report.trace.node_index("E99_3")
    with chromium() as driver:
        driver.get(path.as_uri())
        assert js(driver, "document.body.dataset.ready") == "1"
        assert js(driver, "window.btgenReplay.shown()") <= MAX_NODES  # opened breadth first
        assert "large tree" in driver.find_element("id", "note").text
        assert label_px(driver, "#tree g.node[data-node='0']") >= 10  # readable, not an 800 x 20 strip
        assert not driver.find_elements("css selector", f"#tree g.node[data-node='{target}']")  # collapsed away
        search = driver.find_element("id", "search")
        search.send_keys("E99_3\ue007")  # Enter
        found = f"#tree g.node[data-node='{target}']"
        assert driver.find_element("css selector", found).get_attribute("class").split()[:2] == ["node", "found"] or \
            "found" in driver.find_element("css selector", found).get_attribute("class")  # fmt: skip
        assert inside(node_box(driver, found + " rect"), tree_box(driver)) and label_px(driver, found) >= 10
        assert driver.find_element("id", "found").text.startswith("1 of ")
        # its status follows the slider like any node
        driver.find_element("tag name", "body").send_keys("\ue010")  # End
        assert driver.find_element("css selector", found).get_attribute("data-status") == report.trace.status_at(target, report.ticks - 1)
        driver.find_element("id", "expand-all").click()
        assert js(driver, "window.btgenReplay.shown()") == len(report.trace.nodes)


def leaves_in_view(driver: Any) -> list[str]:
    """The ids of the leaves drawn wholly inside the tree's box (a leaf: a node with nothing to expand or collapse)."""
    return js(driver, """(() => { const t = document.getElementById('tree').getBoundingClientRect();
      return Array.from(document.querySelectorAll('#tree g.node')).filter((g) => !g.querySelector('title').textContent.includes('(click'))
        .filter((g) => { const r = g.querySelector('rect').getBoundingClientRect();
          return r.left >= t.left && r.right <= t.right + 0.5 && r.top >= t.top && r.bottom <= t.bottom + 0.5; })
        .map((g) => g.dataset.id || g.dataset.node); })()""")  # fmt: skip


@needs_chromium
@pytest.mark.parametrize("source", [FAILING, CUT_IN, "500 entries"])
def test_the_page_opens_on_the_failing_node_readable(source: str, tmp_path: pathlib.Path, no_dot: None) -> None:
    """At 1400 x 900 the page opened on the root at 100 %, with no leaf in view (the failing criterion off-screen),
    or fitted to an unreadable strip. It opens on the criterion that failed first (else on the first criterion),
    drawn inside the tree's box at a readable zoom, its ancestors open; the jump button shows it again."""
    if source == CUT_IN and importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"):
        pytest.skip("libsumo is not installed (CI installs it)")
    path, report, loaded = write_page(tmp_path, timeline_case() if source == "500 entries" else source, "open")
    failing = [o.id for o in report.oracles if o.verdict == "fail"]
    assert failing == (["R1"] if source != "500 entries" else [])
    focus = report.trace.node_index("R1")  # the failed criterion, or the first one of a passing run
    with chromium() as driver:
        driver.set_window_size(1400, 900)
        driver.get(path.as_uri())
        assert js(driver, "window.btgenReplay.focus()") == focus
        node = f"#tree g.node[data-node='{focus}']"
        assert inside(node_box(driver, node + " rect"), tree_box(driver)) and label_px(driver, node) >= 10
        assert "R1" in leaves_in_view(driver)
        if failing:
            assert driver.find_element("css selector", node).get_attribute("data-status") == "failure"
            driver.find_element("id", "fit").click()
            driver.find_element("id", "jumps").find_element("tag name", "button").click()  # "R1 failed at ..."
            assert inside(node_box(driver, node + " rect"), tree_box(driver)) and label_px(driver, node) >= 10


# -- 8. the scene ------------------------------------------------------------------------------------------


@needs_sumo
def test_sumo_trace_records_every_vehicle_where_its_signals_say() -> None:
    loaded = btgen_pytrees.load(CUT_IN)
    report = run(loaded)
    trace, scene = report.trace, report.trace.scene
    assert isinstance(scene, Scene) and len(scene.frames) == len(trace.times) and scene.truncated is None
    assert sorted(scene.vehicles) == ["cutter", "ego"] and scene.map["ego"] == "ego"
    lanes = scene.map["lanes"]
    assert len(lanes) >= 6 and all(len(points) >= 4 for _, points in lanes)  # the network's lanes, with widths
    for k, frame in enumerate(scene.frames):
        places = {scene.vehicles[int(frame[j])]: frame[j + 1:j + 5] for j in range(0, len(frame), 5)}
        for vid, (x, y, heading, collided) in places.items():
            assert (x, y) == (trace.value_at(f"{vid}.x", k), trace.value_at(f"{vid}.y", k))
            assert bool(collided) == trace.value_at(f"{vid}.collided", k)
            assert 0 <= heading < 360
    last = scene.frames[-1]
    assert [last[j + 4] for j in range(0, len(last), 5)] == [1, 1]  # both collided at the end


def cut_in_copy(tmp_path: pathlib.Path, options: list[str], processing: str = "") -> pathlib.Path:
    """The cut-in example in *tmp_path* with more SUMO *options*, and *processing* options in its .sumocfg."""
    for name in ("road.net.xml", "cut_in.rou.xml"):
        shutil.copy(ROOT / "examples" / "sumo" / name, tmp_path / name)
    config = (ROOT / "examples" / "sumo" / "cut_in.sumocfg").read_text(encoding="utf-8")
    (tmp_path / "cut_in.sumocfg").write_text(config.replace("</configuration>", processing + "</configuration>"))
    data = json.loads(pathlib.Path(CUT_IN).read_text(encoding="utf-8"))
    data["system"]["options"] += options
    (tmp_path / "cut_in.json").write_text(json.dumps(data))
    return tmp_path / "cut_in.json"


@needs_sumo
def test_a_collision_is_seen_on_its_tick_where_it_happened() -> None:
    """Issue 35 item 12: with SUMO's default collision action (teleport) the ego was 380 m further on at the
    tick of the collision, so neither the trace nor the scene showed it. A run leaves colliding vehicles where
    they met (collision.action warn, docs/sumo.md): on the tick R1 fails both are in contact, and no vehicle
    moves further in a tick than its speed takes it."""
    report = run(btgen_pytrees.load(CUT_IN))
    trace, scene = report.trace, report.trace.scene
    (r1,) = [o for o in report.oracles if o.id == "R1"]
    assert (report.verdict, r1.verdict, r1.at) == ("fail", "fail", 4.0)  # the example's verdict, kept
    k = trace.times.index(r1.at)
    assert trace.value_at("sim.collisions", k) == 1 and trace.value_at("sim.collisions", k - 1) == 0
    frame = scene.frames[k]
    places = {scene.vehicles[int(frame[j])]: frame[j + 1:j + 5] for j in range(0, len(frame), 5)}
    length = dict(zip(scene.vehicles, scene.sizes))["cutter"][0]
    assert places["ego"][3] == places["cutter"][3] == 1  # both collided, neither teleported
    assert abs((places["cutter"][0] - length) - places["ego"][0]) <= 0.5  # the ego's front at the cutter's rear
    for vid in ("ego", "cutter"):
        for i in range(1, len(trace.times)):
            step = abs(trace.value_at(f"{vid}.x", i) - trace.value_at(f"{vid}.x", i - 1))
            fastest = max(trace.value_at(f"{vid}.speed", i), trace.value_at(f"{vid}.speed", i - 1))
            assert step <= fastest * 0.1 + 0.5, (vid, i, step)
    assert not any(frame[j + 4] & 2 for frame in scene.frames for j in range(0, len(frame), 5))


def test_a_case_or_its_configuration_chooses_the_collision_action(tmp_path: pathlib.Path) -> None:
    """The default is SUMO's `--collision.action warn` only where neither the case nor the .sumocfg sets one."""
    from btgen_pytrees.systems.sumo.scenario import read_scenario
    from btgen_pytrees.systems.sumo.system import SumoSystem

    def actions(name: str, options: dict[str, str], processing: str = "") -> list[str]:
        (tmp_path / name).mkdir()
        config = cut_in_copy(tmp_path / name, [], processing).parent / "cut_in.sumocfg"
        args = SumoSystem(read_scenario(str(config)), options, 0.1, ["ego"]).arguments()
        return [args[i + 1] for i, a in enumerate(args) if a == "--collision.action"]

    assert actions("default", {}) == ["warn"]
    assert actions("case", {"collision.action": "teleport"}) == ["teleport"]
    assert actions("file", {}, "<processing><collision.action value='remove'/></processing>") == []  # the file's own


@needs_sumo
@needs_chromium
def test_a_teleport_is_flagged_and_never_drawn_as_motion(tmp_path: pathlib.Path, no_dot: None) -> None:
    """A case may still ask for SUMO's teleport: the ego then jumps hundreds of metres in one tick. The scene marks
    the teleport on its tick, and the page draws no line across it: ego.x's curve is two lines, the car dashed."""
    path, report, _ = write_page(tmp_path, str(cut_in_copy(tmp_path, ["--collision.action", "teleport"])), "teleport")
    trace, scene = report.trace, report.trace.scene
    k = trace.times.index(4.0)
    assert trace.value_at("ego.x", k) - trace.value_at("ego.x", k - 1) > 300  # SUMO moved it, nobody drove it
    frame = scene.frames[k]
    flags = {scene.vehicles[int(frame[j])]: frame[j + 4] for j in range(0, len(frame), 5)}
    assert flags == {"ego": 3, "cutter": 1}  # the ego collided and was teleported, the cutter collided
    with chromium() as driver:
        driver.get(path.as_uri())
        driver.find_element("tag name", "body").send_keys("\ue010")  # End: the teleport's tick
        assert driver.find_element("css selector", "#scene g.car[data-vehicle='ego']").get_attribute("class") == "car collided teleported"
        lines = {name: js(driver, f"document.querySelectorAll('#signals tr[data-signal=\"{name}\"] polyline').length")
                 for name in ("ego.x", "ego.distance", "cutter.x")}  # fmt: skip
        assert lines == {"ego.x": 2, "ego.distance": 2, "cutter.x": 1}
        driver.find_element("tag name", "body").send_keys("\ue012")  # ←: the tick before, driven there
        assert driver.find_element("css selector", "#scene g.car[data-vehicle='ego']").get_attribute("class") == "car ego"


class Turning:
    """A system with a scene and no simulator: one car driving a circle (heading follows the tick)."""

    def __init__(self, tick: float) -> None:
        self.k, self.step = 0, tick

    def start(self, env: Any) -> None: ...
    def now(self) -> float:
        return round(self.k * self.step, 9)

    def publish(self, env: Any) -> None:
        env.publish("car.heading", self.k * 30 % 360)

    def tick(self) -> None:
        self.k += 1

    def close(self) -> None: ...
    def scene_map(self) -> dict[str, Any]:
        return {"lanes": [[4.0, [0, 0, 50, 0, 50, 50]]], "areas": [[0, 0, 10, 0, 10, 10]], "ego": "car"}

    def scene_vehicles(self) -> list[tuple[str, float, float, float, float, float, bool]]:
        return [("car", 10.0 + self.k, 5.0, self.k * 30 % 360, 4.0, 2.0, False)]


class TurningType:
    name = "turning"
    options = ()

    def describe(self, spec: SystemSpec, case_data: Any) -> SystemInfo:
        return SystemInfo(signals=("car.heading",))

    def create(self, spec: SystemSpec, case: Any) -> Turning:
        return Turning(case.tick)


def test_any_system_offers_a_scene_the_same_way() -> None:
    from btgen_pytrees.leaves import default_registry

    registry = default_registry()
    registry.register_system(TurningType())
    data = case(criteria=[crit("F1", "final", "car.heading >= 0", at=0.3)], timeout=1)
    data["execute"] = [{"id": "W", "kind": "constraint", "action": "wait", "params": {"duration": 0.3}}]
    loaded = btgen_pytrees.load(data, registry=registry, system=SystemSpec("turning"))
    report = run(loaded, registry=registry)
    scene = report.trace.scene
    assert report.verdict == "pass" and scene.vehicles == ["car"]
    assert scene.frames[:3] == [[0, 10.0, 5.0, 0.0, 0], [0, 11.0, 5.0, 30.0, 0], [0, 12.0, 5.0, 60.0, 0]]
    page = replay_html(report, loaded, btgen_pytrees.generate(loaded, registry=registry)).decode()
    assert '"scene":{"map":{"lanes":[[4.0,[0,0,50,0,50,50]]]' in page
    without = run(btgen_pytrees.load(FAILING))  # the simulated system offers none
    assert without.trace.scene is None and '"scene":null' in replay_html(
        without, btgen_pytrees.load(FAILING), btgen_pytrees.generate(btgen_pytrees.load(FAILING))).decode()


@needs_sumo
@needs_chromium
def test_scene_follows_the_slider_and_hover_shows_signals(tmp_path: pathlib.Path, no_dot: None) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    path, report, _ = write_page(tmp_path, CUT_IN, "cut_in")
    trace = report.trace
    with chromium() as driver:
        driver.get(path.as_uri())
        assert driver.find_element("id", "scene-box").is_displayed()
        assert len(driver.find_elements("css selector", "#scene-map polyline")) == len(trace.scene.map["lanes"])
        body = driver.find_element("tag name", "body")
        body.send_keys("\ue011")  # Home, then to tick 30
        for _ in range(30):
            body.send_keys("\ue014")
        for vid in ("ego", "cutter"):
            car = driver.find_element("css selector", f"#scene g.car[data-vehicle='{vid}']")
            assert float(car.get_attribute("data-x")) == trace.value_at(f"{vid}.x", 30)
            assert float(car.get_attribute("data-y")) == trace.value_at(f"{vid}.y", 30)
            assert car.get_attribute("class") == ("car ego" if vid == "ego" else "car other")
            box = node_box(driver, f"#scene g.car[data-vehicle='{vid}'] rect")
            assert box["w"] > 2 * box["h"] > 0  # heading 90 (east): a box lying along the road
        ego, cutter = (node_box(driver, f"#scene g.car[data-vehicle='{v}'] rect") for v in ("ego", "cutter"))
        assert ego["x"] < cutter["x"] and inside(ego, node_box(driver, "#scene"))  # the ego behind, followed
        labels = [t.text for t in driver.find_elements("css selector", "#scene-cars text")]
        assert sorted(labels) == ["cutter", "ego"]
        ActionChains(driver).move_to_element(driver.find_element("css selector", "#scene g.car[data-vehicle='ego'] rect")).perform()
        tip = driver.find_element("id", "scene-tip")
        assert tip.is_displayed() and tip.text.startswith("ego")
        assert f"speed = {trace.value_at('ego.speed', 30):g}" in tip.text
        body.send_keys("\ue010")  # End: both collided, red
        assert {c.get_attribute("class") for c in driver.find_elements("css selector", "#scene g.car")} == {"car collided"}
        driver.find_element("id", "scene-fit").click()
        assert driver.find_element("id", "follow").is_selected() is False
