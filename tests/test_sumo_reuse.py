"""A SUMO simulation kept open between the runs of a worker and set back to time 0 (docs/sumo.md,
"One process, many runs"): every run gives the report of a fresh process, whatever ran before it.

Real SUMO throughout (libsumo): these tests skip without it, except under CI (``CI`` set).
"""

from __future__ import annotations

import importlib.util
import json
import multiprocessing
import os
import pathlib
import random
import re
import subprocess
import sys
from typing import Any

import pytest

from btgen_pytrees.errors import ExitCode
from btgen_pytrees.falsify.jobs import job_probe
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.load import validate
from btgen_pytrees.parallel import Outcome, Workers, process
from btgen_pytrees.run import run
from btgen_pytrees.sweep import load_sweep
from btgen_pytrees.sweep.jobs import RunOptions, job_chunk
from btgen_pytrees.systems.sumo import keep_simulations, kept_simulation, reuse_simulations
from btgen_pytrees.systems.sumo.scenario import RESTORE_DEPART, read_scenario

from helpers import crit, entry

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples" / "sumo"
NET = (EXAMPLES / "road.net.xml").read_text(encoding="utf-8")
CONFIG = ('<configuration><input><net-file value="road.net.xml"/><route-files value="r.rou.xml"/>'
          '{additional}</input></configuration>')  # fmt: skip

needs_sumo = pytest.mark.skipif(
    importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)",
)

# Drivers that dawdle (sigma), drawn speed factors (speedDev), random departure places, lanes and speeds:
# SUMO draws random numbers on every step and at every insertion.
RANDOM = """<routes>
    <vType id="car" length="5" minGap="2.5" maxSpeed="20" accel="2.6" decel="4.5" sigma="0.6" speedDev="0.3"/>
    <route id="east" edges="A0B0 B0C0"/>
    <vehicle id="ego" type="car" route="east" depart="0" departPos="20" departLane="0" departSpeed="random"/>
    <vehicle id="lead" type="car" route="east" depart="0" departPos="random" departLane="random" departSpeed="random"/>
    <vehicle id="late" type="car" route="east" depart="2" departPos="random" departLane="random" departSpeed="random"/>
</routes>
"""


def scenario(where: pathlib.Path, routes: str, additional: str = "", **files: str) -> pathlib.Path:
    where.mkdir(parents=True, exist_ok=True)
    (where / "road.net.xml").write_text(files.pop("net", NET), encoding="utf-8")
    (where / "r.rou.xml").write_text(routes, encoding="utf-8")
    for name, text in files.items():
        (where / name.replace("__", ".")).write_text(text, encoding="utf-8")
    cfg = where / "s.sumocfg"
    add = f'<additional-files value="{additional}"/>' if additional else ""
    cfg.write_text(CONFIG.format(additional=add), encoding="utf-8")
    return cfg


def case(config: pathlib.Path, *entries: dict[str, Any], criteria: list[dict[str, Any]], options: list[str] = (),  # type: ignore[assignment]
         timeout: float = 20, name: str = "t") -> dict[str, Any]:  # fmt: skip
    return {"name": name, "tick": 0.1, "timeout": timeout,
            "system": {"type": "sumo", "config": str(config), "options": list(options)},
            "execute": list(entries), "oracle": {"criteria": criteria}}  # fmt: skip


def randomised(tmp_path: pathlib.Path) -> list[dict[str, Any]]:
    """Cases whose every value depends on SUMO's random numbers, with two seeds and SUMO's default."""
    cfg = scenario(tmp_path / "random", RANDOM)
    watch = [crit("R1", "record", "ego.speed < 15"), crit("R2", "record", "ego.gap > 3 || lead.gap > 3"),
             crit("F1", "final", "late.present && late.x > 0 && ego.x > 50")]  # fmt: skip
    cases = [case(cfg, entry("C1", action="wait", duration=6), criteria=watch, options=opts, name=f"random{k}")
             for k, opts in enumerate((["--seed", "1"], ["--seed", "7"], []))]  # fmt: skip
    # a vehicle added by the test draws its speed factor; a take-over, then the driver model again
    cases.append(case(cfg, entry("B1", action="sumo.spawn", vehicle="new", route="east", lane=1, speed=5),
                      entry("B2", ["B1"], action="sumo.speed", vehicle="ego", to=0, duration=1, safe=False),
                      entry("B3", ["B2"], action="sumo.release", vehicle="ego"),
                      entry("C1", ["B3"], action="wait", duration=3), criteria=watch, options=["--seed", "3"],
                      name="spawn"))  # fmt: skip
    return cases


def settings(n: int, seed: int) -> list[dict[str, Any]]:
    """*n* settings of the benchmark's cut-in search case (benchmarks/falsify_cases/cut_in_3d.json)."""
    sweep = load_sweep(str(ROOT / "benchmarks" / "falsify_cases" / "cut_in_3d.json"), check_all=False,
                       max_variations=10**18)  # fmt: skip
    rng = random.Random(seed)
    out = []
    for _ in range(n):
        values = {"gap": rng.uniform(1.5, 40), "ego_speed": rng.uniform(21, 23.5), "cutter_speed": rng.uniform(18, 20)}
        doc = sweep.document({**sweep.defaults, **values})
        doc["system"]["config"] = str((EXAMPLES / "cut_in.sumocfg").resolve())
        out.append(doc)
    return out


SOURCE = str(ROOT / "case.json")

_FRESH = ("import json, sys\nfrom btgen_pytrees.leaves import default_registry\nfrom btgen_pytrees.load import validate\n"
          "from btgen_pytrees.run import run\n"
          "out = []\nfor doc in json.load(open(sys.argv[1])):\n"
          "    r = run(validate(doc, sys.argv[2], default_registry()))\n"
          "    out.append(r.to_json() + json.dumps(r.trace.to_data()))\n"
          "print(json.dumps(out))\n")  # fmt: skip


def fresh(docs: list[dict[str, Any]], tmp_path: pathlib.Path) -> list[str]:
    """Each case's JSON report and trace from another process, each run starting SUMO afresh."""
    data = tmp_path / "docs.json"
    data.write_text(json.dumps(docs), encoding="utf-8")
    done = subprocess.run([sys.executable, "-c", _FRESH, str(data), SOURCE], capture_output=True, text=True,
                          cwd=ROOT, timeout=600, check=True)  # fmt: skip
    return json.loads(done.stdout.splitlines()[-1])  # type: ignore[no-any-return]  # libsumo may warn first


def here(doc: dict[str, Any]) -> str:
    r = run(validate(doc, SOURCE, default_registry()))
    return r.to_json() + json.dumps(r.trace.to_data())


@needs_sumo
@pytest.mark.usefixtures("pythons_ctrl_c")  # its KeyboardInterrupt is the host's Ctrl-C: goes on
def test_every_run_on_a_kept_simulation_gives_the_report_of_a_fresh_process(tmp_path: pathlib.Path) -> None:
    """Twelve settings of the cut-in search, cases that draw random numbers everywhere (three seeds, a spawned
    vehicle), the example cases (a collision; a take-over), in a shuffled order, three times each, with runs
    interrupted half-way and a scenario SUMO refuses in between: each run's JSON report and trace are the bytes
    of the same case run in another process that starts SUMO for every run."""
    docs = settings(12, seed=5) + randomised(tmp_path)
    for name in ("cut_in", "acc_hard_brake"):
        doc = json.loads((EXAMPLES / f"{name}.json").read_text(encoding="utf-8"))
        doc["system"]["config"] = str((EXAMPLES / doc["system"]["config"]).resolve())
        docs.append(doc)
    broken = case(scenario(tmp_path / "broken", RANDOM.replace('accel="2.6"', 'accel="fast"')),
                  entry("C1", action="wait"), criteria=[crit("R1", "record", "ego.speed >= 0")])  # fmt: skip
    expected = fresh(docs, tmp_path)
    assert len(set(expected)) == len(docs)  # every case runs differently
    order = list(range(len(docs))) * 3
    random.Random(2).shuffle(order)

    def interrupt(ticks: int, _now: float) -> None:
        if ticks == 15:
            raise KeyboardInterrupt

    kept = 0
    with reuse_simulations():
        for k, i in enumerate(order):
            assert here(docs[i]) == expected[i], (k, docs[i]["name"])
            kept += kept_simulation() is not None  # left open for the next run
            if k % 9 == 4:
                with pytest.raises(KeyboardInterrupt):
                    run(validate(docs[i], SOURCE, default_registry()), progress=interrupt)
            if k % 11 == 6:
                assert run(validate(broken, SOURCE, default_registry())).verdict == "error"
    assert kept_simulation() is None  # the block's end closed it
    assert kept > len(order) // 2  # the first run of a key learns which generators to hold: not kept


@needs_sumo
def test_the_random_number_generators_are_set_back_too(tmp_path: pathlib.Path) -> None:
    """A restored simulation without its random number generators set back would draw on where the last run
    stopped: the second run of a case that dawdles would differ from the first."""
    docs = randomised(tmp_path)
    docs = [docs[0], docs[3], docs[2], {**docs[0], "timeout": 5}]  # seed 1; spawn, seed 3; SUMO's seed; seed 1
    expected = fresh(docs, tmp_path)
    with reuse_simulations():
        assert here(docs[0]) == expected[0]
        assert kept_simulation() is None  # its first run drew from generators the snapshot did not hold
        for k, i in enumerate((0, 0, 3, 0, 1, 1, 2, 2, 2)):  # the same key again and again (0 and 3 share one)
            assert here(docs[i]) == expected[i], i
            assert (kept_simulation() is None) == (k in (4, 6)), k  # a key's first run is not kept


@needs_sumo
def test_a_forked_worker_closes_its_copy_of_a_kept_simulation(tmp_path: pathlib.Path) -> None:
    """The local pool forks its workers, maybe while this process keeps a simulation: the child never uses
    that copy (it starts its own) and the parent's stays usable."""
    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork on this platform")
    docs = settings(2, seed=9)
    expected = fresh(docs, tmp_path)
    with reuse_simulations():
        assert here(docs[0]) == expected[0] and here(docs[0]) == expected[0] and kept_simulation() is not None
        with multiprocessing.get_context("fork").Pool(1) as pool:
            assert pool.apply(_child, (docs,)) == (None, expected[1], expected[0])
        assert here(docs[1]) == expected[1] and here(docs[0]) == expected[0]


def _child(docs: list[dict[str, Any]]) -> tuple[Any, str, str]:
    before = kept_simulation()
    with reuse_simulations():
        return before, here(docs[1]), here(docs[0])


@needs_sumo
def test_outside_a_block_nothing_is_kept_and_another_key_closes_the_kept_one(tmp_path: pathlib.Path) -> None:
    import libsumo

    docs = settings(1, seed=1) + randomised(tmp_path)[:2]
    run(validate(docs[0], SOURCE, default_registry()))
    assert kept_simulation() is None
    with reuse_simulations():
        with reuse_simulations():
            here(docs[0])
            here(docs[0])
        first = kept_simulation()  # an inner block's end keeps it for the outer one
        assert first is not None and str(EXAMPLES / "cut_in.sumocfg") in first[0]
        here(docs[1])
        here(docs[1])
        second = kept_simulation()
        assert second is not None and second != first
        here(docs[2])  # the same scenario, another seed: another command line
        here(docs[2])
        assert kept_simulation() not in (None, first, second)
    assert kept_simulation() is None
    with pytest.raises(Exception):  # noqa: B017 - libsumo.TraCIException: nothing is loaded
        libsumo.simulation.getTime()


@needs_sumo
def test_scenarios_sumo_cannot_restore_exactly_start_afresh_every_run(tmp_path: pathlib.Path) -> None:
    """Restored exactly: vehicles and trips read when SUMO starts, fixed-time traffic lights. A vehicle departing
    later than RESTORE_DEPART s (SUMO reads route files 200 s ahead, and a loaded state does not rewind that
    reading), a flow, a person, an actuated traffic light: each run starts SUMO. So does the run after a test
    switched a traffic light (SUMO keeps the program it made for the state)."""
    assert read_scenario(str(EXAMPLES / "cut_in.sumocfg")).restore_problem is None
    late = RANDOM.replace('depart="2"', 'depart="250"')
    flow = RANDOM.replace("</routes>", '<flow id="f" route="east" begin="0" end="50" vehsPerHour="600"/></routes>')
    person = RANDOM.replace("</routes>", '<person id="p" depart="0"><walk edges="A0B0"/></person></routes>')
    actuated = NET.replace('type="static"', 'type="actuated"')
    cases = {
        "late": (scenario(tmp_path / "late", late), f"vehicle 'late' departs at '250' (restored exactly: a number of seconds up to {RESTORE_DEPART:g})"),
        "flow": (scenario(tmp_path / "flow", flow), "<flow> (only route, routeDistribution, trip, vType, vTypeDistribution, vehicle"),
        "person": (scenario(tmp_path / "person", person), "<person>"),
        "actuated": (scenario(tmp_path / "actuated", RANDOM, net=actuated), "traffic light 'B0' is 'actuated'"),
        "add": (scenario(tmp_path / "add", RANDOM, "a.add.xml", a__add__xml='<additional><busStop id="b" lane="A0B0_0" startPos="10" endPos="30"/></additional>'),
                "a.add.xml:1: <busStop>"),
    }  # fmt: skip
    for name, (cfg, why) in cases.items():
        problem = read_scenario(str(cfg)).restore_problem
        assert problem is not None and why in problem, (name, problem)
    watch = [crit("R1", "record", "ego.speed >= 0")]
    docs = [case(cfg, entry("C1", action="wait", duration=3), criteria=watch, name=name) for name, (cfg, _) in cases.items()]
    signal = case(scenario(tmp_path / "signal", RANDOM), entry("B1", action="sumo.signal", tls="B0", state="rrrr"),
                  entry("C1", ["B1"], action="wait", duration=3), criteria=watch, name="signal")  # fmt: skip
    docs.append(signal)
    expected = fresh(docs, tmp_path)
    with reuse_simulations():
        for doc, report in [*zip(docs, expected), *zip(docs, expected)]:
            assert here(doc) == report, doc["name"]
            assert kept_simulation() is None, doc["name"]


@needs_sumo
def test_a_sweep_chunk_keeps_the_simulation_for_its_runs_only(tmp_path: pathlib.Path) -> None:
    docs = settings(4, seed=3)
    expected = fresh(docs, tmp_path)
    seen: list[Any] = []
    outcome = job_chunk("chunk", RunOptions(), SOURCE, [(f"v{k}", d, None) for k, d in enumerate(docs)])
    seen.append(kept_simulation())
    reports = [json.JSONDecoder().raw_decode(r)[0] for r in expected]
    rows = [p.row for p in outcome.parts]  # type: ignore[attr-defined]
    assert [(r["verdict"], r["margin"], r["ticks"]) for r in rows] == [(r["verdict"], r["margin"], r["ticks"]) for r in reports]
    assert seen == [None]


_LEAVE = """
import atexit, json, multiprocessing.util, os, sys
def loaded(name):  # runs after the library's own exit handlers: is a simulation still loaded?
    import libsumo
    try:
        libsumo.simulation.getTime()
        state = "loaded"
    except Exception:
        state = "closed"
    with open(os.path.join(sys.argv[3], name), "w") as fh:
        fh.write(state)
atexit.register(loaded, "parent")  # before the library registers its own: runs after it
from btgen_pytrees.leaves import default_registry
from btgen_pytrees.load import validate
from btgen_pytrees.run import run
from btgen_pytrees.systems.sumo import kept_simulation, reuse_simulations
doc = json.load(open(sys.argv[1]))
blocks = []
def work():
    blocks.append(reuse_simulations())
    blocks[-1].__enter__()  # never left
    run(validate(doc, sys.argv[2], default_registry()))
    run(validate(doc, sys.argv[2], default_registry()))  # the first learns the generators to hold
    assert kept_simulation() is not None
def child():
    multiprocessing.util.Finalize(None, loaded, ("child",), exitpriority=-1)  # after the library's (priority 0)
    work()
if __name__ == "__main__":
    p = multiprocessing.get_context("fork").Process(target=child)
    p.start()
    p.join()
    assert p.exitcode == 0, p.exitcode
    work()
    print("done")
"""


@needs_sumo
def test_a_process_that_leaves_with_a_simulation_kept_closes_it(tmp_path: pathlib.Path) -> None:
    """A block left open at exit (an embedding that never leaves it; a worker process, which leaves without
    running atexit): the simulation is closed on the way out, and the process exits 0."""
    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork on this platform")
    doc = settings(1, seed=4)[0]
    (tmp_path / "doc.json").write_text(json.dumps(doc), encoding="utf-8")
    done = subprocess.run([sys.executable, "-c", _LEAVE, str(tmp_path / "doc.json"), SOURCE, str(tmp_path)],
                          capture_output=True, text=True, cwd=ROOT, timeout=300, check=False)  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.splitlines()[-1] == "done"
    assert (tmp_path / "parent").read_text() == "closed" and (tmp_path / "child").read_text() == "closed"


@needs_sumo
def test_a_scenario_file_edited_between_two_runs_is_loaded_anew(tmp_path: pathlib.Path) -> None:
    """The key of a kept simulation holds the digest of every scenario file's contents, not only the command
    line: a route file edited between two runs of the same case (same path, same options) gives the report
    of the edited scenario."""
    doc = randomised(tmp_path)[0]
    routes = tmp_path / "random" / "r.rou.xml"
    before = fresh([doc], tmp_path)[0]
    routes.write_text(RANDOM.replace('departPos="20"', 'departPos="40"'), encoding="utf-8")
    after = fresh([doc], tmp_path)[0]
    routes.write_text(RANDOM, encoding="utf-8")
    assert before != after
    with reuse_simulations():
        assert here(doc) == before and here(doc) == before
        key = kept_simulation()
        routes.write_text(RANDOM.replace('departPos="20"', 'departPos="40"'), encoding="utf-8")
        assert here(doc) == after and here(doc) == after
        assert kept_simulation() not in (None, key)


@needs_sumo
@pytest.mark.usefixtures("pythons_ctrl_c")  # its KeyboardInterrupt is the host's Ctrl-C: goes on
def test_nothing_is_left_open_after_a_block(tmp_path: pathlib.Path) -> None:
    """No file descriptor (the state's memory files) outlives the block, whatever its runs did: kept, closed
    for another key, refused by SUMO, interrupted, not restorable."""
    if not os.path.isdir("/proc/self/fd"):
        pytest.skip("no /proc")
    docs = settings(2, seed=6) + randomised(tmp_path)[:2]
    late = case(scenario(tmp_path / "late", RANDOM.replace('depart="2"', 'depart="250"')), entry("C1", action="wait"),
                criteria=[crit("R1", "record", "ego.speed >= 0")])  # fmt: skip
    broken = case(scenario(tmp_path / "broken", RANDOM.replace('accel="2.6"', 'accel="fast"')),
                  entry("C1", action="wait"), criteria=[crit("R1", "record", "ego.speed >= 0")])  # fmt: skip

    def interrupt(ticks: int, _now: float) -> None:
        if ticks == 5:
            raise KeyboardInterrupt

    here(docs[0])  # libsumo imported, its own descriptors open
    before = sorted(os.listdir("/proc/self/fd"))
    for _ in range(2):
        with reuse_simulations():
            for doc in [*docs, late, docs[0], broken, docs[0], docs[2], docs[2]]:
                run(validate(doc, SOURCE, default_registry()))
            with pytest.raises(KeyboardInterrupt):
                run(validate(docs[1], SOURCE, default_registry()), progress=interrupt)
            here(docs[1])
        assert sorted(os.listdir("/proc/self/fd")) == before


def kept_here(path: str) -> Outcome:
    """A job: whether this worker process has a simulation kept open, and its process id."""
    return Outcome(path, ExitCode.OK, f"{os.getpid()} {kept_simulation() is not None}")


@needs_sumo
def test_a_searchs_workers_keep_their_simulation_from_one_batch_to_the_next(tmp_path: pathlib.Path) -> None:
    """``falsify --jobs 2``: the search's worker processes are kept for all its batches and each keeps its
    SUMO open between its tasks (it was started for every run: each batch forked new workers, which imported
    libsumo again); the search is the one a single process runs with the same batch, byte for byte."""
    docs = settings(6, seed=5)
    expected = fresh(docs, tmp_path)
    with Workers(2, keep_simulations) as pool:
        rows, seen = [], []
        for k in range(3):  # three batches of two runs, as a search at batch 2 asks them
            batch = [(f"v{2 * k + i}", docs[2 * k + i], None) for i in range(2)]
            outcomes = process(job_probe, [(RunOptions(), SOURCE, [item]) for item in batch], [b[0] for b in batch], workers=2, pool=pool)
            rows += [o.parts[0].row for o in outcomes]  # type: ignore[attr-defined]
            seen.append(process(kept_here, [(), ()], ["a", "b"], workers=2, pool=pool))
        pids = pool.pids
    reports = [json.JSONDecoder().raw_decode(r)[0] for r in expected]
    assert [(r["verdict"], r["margin"], r["ticks"]) for r in rows] == [(r["verdict"], r["margin"], r["ticks"]) for r in reports]
    assert {o.summary.split()[0] for batch in seen for o in batch} == {str(p) for p in pids}  # the same two processes
    assert [o.summary.split()[1] for o in seen[-1]] == ["True", "True"]  # each keeps its simulation
    case = ROOT / "benchmarks" / "falsify_cases" / "cut_in_3d.json"
    outs = []
    for jobs in ("2", "1"):
        target = tmp_path / f"{jobs}.json"
        done = subprocess.run([sys.executable, "-m", "btgen_pytrees", "falsify", str(case), "--budget", "30", "--seed", "2",
                               "--batch", "2", "--jobs", jobs, "--json", str(target)], capture_output=True, text=True,
                              cwd=tmp_path, timeout=600, check=False)  # fmt: skip
        assert done.returncode == 1, done.stderr[-2000:]
        data = json.loads(target.read_text())
        for run in data["runs"]:
            run.pop("wall")
        outs.append(json.dumps(data, indent=2))
    assert outs[0] == outs[1]


@needs_sumo
def test_a_snapshot_is_written_only_when_its_text_changes(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Setting a kept simulation back loads the snapshot's text with the generators the last run drew from; when
    that text is the one the snapshot file holds already (the runs of a search draw from the same lanes'
    generators), the file is not written again - and each run still gives the bytes of a fresh start. Each
    generator set back is loaded with its full state, then with a count of 0 (its counter 0 again, the
    generator untouched), so that the save after the next run writes its count, not its full state."""
    from btgen_pytrees.systems.sumo import system as module

    written: list[str] = []
    write = module._File.write
    monkeypatch.setattr(module._File, "write", lambda self, text: (written.append(text), write(self, text))[1])
    docs = settings(4, seed=3)
    expected = fresh(docs, tmp_path)
    with reuse_simulations():
        for _ in range(3):  # (learns the generators the key's runs draw from, if this process has not yet,) starts
            here(docs[0])  # with them held and sets them back: the snapshot file holds the restore's text
        assert kept_simulation() is not None and written
        full, zero = re.findall(r"<rngState>(.*?)</rngState>", written[-1])  # the two lanes' generators the cut-in draws from
        assert re.findall(r'index="(\d+)" state="1\d{6,} ', full) == re.findall(r'index="(\d+)" state="0"', zero) != []
        del written[:]
        for i in (1, 2, 3, 0, 2):
            assert here(docs[i]) == expected[i], i
        assert written == []  # the runs drew from the same generators: the same text every time
