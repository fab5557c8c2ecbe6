"""ARCH-COMP's "chasing cars" (CC) falsification benchmark: ``python -m benchmarks.arch_cc`` (issue 36, point 8).

**The model** is the competition's Simulink/Stateflow model ``cars.mdl`` (Hoxha, Abbas and Fainekos,
"Benchmarks for temporal logic requirements for automotive systems", ARCH 2014; the file as the
competition ships it, e.g. in MasWag/FalCAuN-ARCH-COMP ``CC/cars.mdl``), ported here from its charts'
equations - position ``y`` and speed ``v`` of five cars on one line:

* car 1, chart "Run": ``v1' = -throttle - brake * v1``, ``y1' = v1``; starts at y1 = 0, v1 = 0;
* cars 2-5 (``i`` follows ``i - 1``; ``d = y_i - y_{i-1}``), three modes, starting in *Keeping* at
  y = 10, 20, 30, 40 m and v = 0:

  ========  ==================  ============================================
  mode      flow                 leaves (in the chart's execution order)
  ========  ==================  ============================================
  Keeping   v' = 0,  y' = v       d >= 15: Chasing; d <= 5: Braking
  Chasing   v' = 1,  y' = -v      d <= 10: Keeping
  Braking   v' = -v, y' = -v      d >= 20: Chasing
  ========  ==================  ============================================

(The signs are the model's own: the cars move towards smaller y, and "Keeping" lets a car drift back
with its speed - the published benchmark is defined by the file, not by physics.) Each flow is solved
in closed form over a sub-step (every mode's ODE is linear with constant inputs within a tick), and the
guards are checked after every sub-step of ``tick / SUBSTEPS`` seconds, one transition per chart per
sub-step as in a Stateflow chart without super-steps. The inputs are held over a tick (zero-order hold,
as the piecewise-constant inputs of instance 2 are).

It is a **system plugin** (:func:`register`; docs/systems.md): the ``arch_cc`` system owns the signals
``y1`` ... ``y5`` and ``v1`` ... ``v5`` and reads the case's ``throttle`` and ``brake`` each tick.

**The inputs** are instance 2: piecewise constant, one value every 5 s per input (20 values each, 40
parameters in [0, 1]), two built-in ``profile`` behaviours (``arch_cc.json`` beside this file).

**The requirements** (ARCH-COMP 2019-2024 falsification reports), as the case's criteria:
``CC1`` and ``CCx`` as record/period criteria, ``CC2`` ... ``CC5`` as ``temporal`` criteria, each with its
source formula as the criterion's name (:data:`REQUIREMENTS`).

**The command** runs ``falsify``'s search (``btgen_pytrees.falsify.Search``, batch 1, in this process,
``stop: failure``) on every requirement for ``--seeds`` seeds and ``--budget`` runs (default 1,500) per
method, and prints the falsification rate and the mean/median runs to the first failure.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Mapping

if __package__ in (None, ""):  # run as a file
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from btgen_pytrees.falsify import Search, Settings, Space  # noqa: E402
from btgen_pytrees.falsify.cases import signals_of  # noqa: E402
from btgen_pytrees.falsify.jobs import timed  # noqa: E402
from btgen_pytrees.falsify.margins import groups_of, row_margins  # noqa: E402
from btgen_pytrees.leaves import default_registry  # noqa: E402
from btgen_pytrees.load import load_sweep, validate  # noqa: E402
from btgen_pytrees.sweep.jobs import RunOptions  # noqa: E402
from btgen_pytrees.systems import SystemInfo  # noqa: E402

CASE = Path(__file__).resolve().parent / "arch_cc.json"
SUBSTEPS = 10
KEEPING, CHASING, BRAKING = "keeping", "chasing", "braking"
SIGNALS = tuple(f"y{i}" for i in range(1, 6)) + tuple(f"v{i}" for i in range(1, 6))

REQUIREMENTS: dict[str, dict[str, Any]] = {
    # G[0,100] (y5 - y4 <= 40)
    "CC1": {"id": "CC1", "type": "record", "name": "G[0,100] (y5 - y4 <= 40)", "expect": "y5 - y4 <= 40"},
    # G[0,70] F[0,30] (y5 - y4 >= 15)
    "CC2": {"id": "CC2", "type": "temporal", "name": "G[0,70] F[0,30] (y5 - y4 >= 15)",
            "expect": "always[0, 70](eventually[0, 30](y5 - y4 >= 15))"},
    # G[0,80] ((G[0,20] y2 - y1 <= 20) or (F[0,20] y5 - y4 >= 40))
    "CC3": {"id": "CC3", "type": "temporal", "name": "G[0,80] ((G[0,20] y2 - y1 <= 20) or (F[0,20] y5 - y4 >= 40))",
            "expect": "always[0, 80](always[0, 20](y2 - y1 <= 20) || eventually[0, 20](y5 - y4 >= 40))"},
    # G[0,65] F[0,30] G[0,5] (y5 - y4 >= 8): CC4 as FalStar's configuration (ERATOMMSD/falstar
    # falstar/resource/configuration/qest2019-journal/instance1/cc.cfg), FalCAuN's 2024 script
    # (MasWag/FalCAuN-ARCH-COMP CC/CC4.main.kts: alw_[0,65] ev_[0,30] alw_[0,5]) and STGEM's 2023 setup state
    # it; a G[0,20] seen elsewhere reaches 115 s, past the competition's 100 s runs
    "CC4": {"id": "CC4", "type": "temporal", "name": "G[0,65] F[0,30] G[0,5] (y5 - y4 >= 8)",
            "expect": "always[0, 65](eventually[0, 30](always[0, 5](y5 - y4 >= 8)))"},
    # G[0,72] F[0,8] ((G[0,5] y2 - y1 >= 9) -> (G[5,20] y5 - y4 >= 9))
    "CC5": {"id": "CC5", "type": "temporal", "name": "G[0,72] F[0,8] ((G[0,5] y2 - y1 >= 9) -> (G[5,20] y5 - y4 >= 9))",
            "expect": "always[0, 72](eventually[0, 8](always[0, 5](y2 - y1 >= 9) -> always[5, 20](y5 - y4 >= 9)))"},
    # G[0,50] (y2 - y1 > 7.5 and y3 - y2 > 7.5 and y4 - y3 > 7.5 and y5 - y4 > 7.5)
    "CCx": {"id": "CCx", "type": "period", "from": 0, "to": 50,
            "name": "G[0,50] (y2 - y1 > 7.5 and y3 - y2 > 7.5 and y4 - y3 > 7.5 and y5 - y4 > 7.5)",
            "expect": "y2 - y1 > 7.5 && y3 - y2 > 7.5 && y4 - y3 > 7.5 && y5 - y4 > 7.5"},
}
HORIZON = {"CC1": 100, "CC2": 100, "CC3": 100, "CC4": 100, "CC5": 100, "CCx": 50}
"""Seconds a run must cover: the competition simulates 100 s (every formula's windows end by then); CCx's
runs stop at 50 s, where its window ends."""


class Cars:
    """One run of the five cars (see the module's docstring for the equations)."""

    def __init__(self, tick: float):
        self.dt = tick
        self.k = 0
        self.y = [0.0, 10.0, 20.0, 30.0, 40.0]
        self.v = [0.0] * 5
        self.mode = [KEEPING] * 5  # car 1's entry is unused
        self.env: Any = None

    def start(self, env: Any) -> None:
        self.env = env

    def now(self) -> float:
        return round(self.k * self.dt, 9)

    def publish(self, env: Any) -> None:
        for i in range(5):
            env.publish(f"y{i + 1}", self.y[i])
            env.publish(f"v{i + 1}", self.v[i])

    def tick(self) -> None:
        inputs = self.env.values(("throttle", "brake"))
        throttle = min(max(float(inputs["throttle"]), 0.0), 1.0)
        brake = min(max(float(inputs["brake"]), 0.0), 1.0)
        h = self.dt / SUBSTEPS
        for _ in range(SUBSTEPS):
            advance(self.y, self.v, self.mode, throttle, brake, h)
            switch(self.y, self.mode)
        self.k += 1

    def close(self) -> None:
        self.env = None


def advance(y: list[float], v: list[float], mode: list[str], throttle: float, brake: float, h: float) -> None:
    """Every car's exact flow over *h* seconds in its current mode, inputs held."""
    if brake > 0:  # v' = -throttle - brake * v: v tends to -throttle / brake at rate brake
        target = -throttle / brake
        decay = math.exp(-brake * h)
        y[0] += target * h + (v[0] - target) * (1.0 - decay) / brake
        v[0] = target + (v[0] - target) * decay
    else:
        y[0] += v[0] * h - throttle * h * h / 2
        v[0] -= throttle * h
    for i in range(1, 5):
        if mode[i] == KEEPING:
            y[i] += v[i] * h
        elif mode[i] == CHASING:
            y[i] -= v[i] * h + h * h / 2
            v[i] += h
        else:  # braking: v' = -v, y' = -v
            decay = math.exp(-h)
            y[i] -= v[i] * (1.0 - decay)
            v[i] *= decay


def switch(y: list[float], mode: list[str]) -> None:
    """The charts' transitions for the distances now (at most one per chart)."""
    for i in range(1, 5):
        d = y[i] - y[i - 1]
        if mode[i] == KEEPING:
            if d >= 15:
                mode[i] = CHASING
            elif d <= 5:
                mode[i] = BRAKING
        elif mode[i] == CHASING:
            if d <= 10:
                mode[i] = KEEPING
        elif d >= 20:
            mode[i] = CHASING


class CarsType:
    """The ``arch_cc`` system type: no configuration, no options."""

    name = "arch_cc"
    options = ()

    def describe(self, spec: Any, case_data: Mapping[str, Any]) -> SystemInfo:
        return SystemInfo(signals=SIGNALS)

    def create(self, spec: Any, case: Any) -> Cars:
        return Cars(case.tick)


def register(registry: Any) -> None:
    """The plugin hook: ``--plugin benchmarks.arch_cc``."""
    registry.register_system(CarsType())


def simulate(throttle: list[float], brake: list[float], duration: float = 100.0, tick: float = 0.1,
             hold: float = 5.0) -> list[list[float]]:  # fmt: skip
    """The model alone (no tree): positions y1..y5 at every tick, inputs piecewise constant per *hold* s."""

    class Inputs:
        def __init__(self) -> None:
            self.t = 0.0

        def values(self, names: Any) -> dict[str, float]:
            k = min(int(self.t / hold + 1e-9), len(throttle) - 1)
            return {"throttle": throttle[k], "brake": brake[k]}

    cars, inputs = Cars(tick), Inputs()
    cars.start(inputs)
    out = [list(cars.y)]
    for _ in range(round(duration / tick)):
        inputs.t = cars.now()
        cars.tick()
        out.append(list(cars.y))
    return out


# -- the benchmark ---------------------------------------------------------------------------------


def case_for(requirement: str) -> dict[str, Any]:
    """The benchmark case with *requirement* as its one criterion and its runs as long as it needs."""
    data = json.loads(CASE.read_text())
    data["name"] = f"arch_{requirement.lower()}"
    data["oracle"] = {"criteria": [dict(REQUIREMENTS[requirement])]}
    horizon = HORIZON[requirement]
    data["timeout"] = horizon
    for entry in data["execute"]:
        points = entry["params"]["points"]
        kept = [p for p in points[:-1] if p[0] < horizon]
        entry["params"]["points"] = kept + [[horizon, kept[-1][1]]]
    used = {p[1][1:] for entry in data["execute"] for p in entry["params"]["points"]}
    data["parameters"] = {k: v for k, v in data["parameters"].items() if k in used}
    data["variations"] = {k: v for k, v in data["variations"].items() if k in used}
    return data


PLUGINS = RunOptions(plugins=("benchmarks.arch_cc",))


def sweep_of(requirement: str) -> Any:
    registry = default_registry()
    register(registry)
    return load_sweep(case_for(requirement), registry=registry, check_all=False, max_variations=10**100)


def row(sweep: Any, values: Mapping[str, Any]) -> dict[str, Any]:
    """One run of the case at *values*, as the search's job runs it (its sweep row and ``margins``)."""
    outcome = timed("x", PLUGINS, sweep.source, sweep.document({**sweep.defaults, **values}), None)
    result = dict(getattr(outcome, "row", {"verdict": "error", "oracles": []}))
    result["margins"] = row_margins(result)
    return result


def search(requirement: str, method: str, seed: int, budget: int) -> Search:
    """One search of *requirement*'s box, batch 1 in this process, stopping at the first failing run."""
    sweep = sweep_of(requirement)
    registry = default_registry()
    register(registry)
    space = Space.of(sweep.variations, signals_of(sweep))
    groups = groups_of(validate(sweep.document(sweep.defaults), sweep.source, registry))

    def evaluate(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [row(sweep, values) for values in points]

    settings = Settings(method=method, seed=seed, budget=budget, stop="failure", batch=1)
    return Search(space, sweep.defaults, settings, evaluate, groups).run()


def psy_taliro(requirement: str, seed: int, budget: int) -> int | None:
    """PSY-TaLiRo 3's dual annealing (its default falsifier) on the same box and the same runs: the cost of a
    sample is the run's margin of the requirement (the same tree, model and criterion); it stops at the
    first cost below 0 (its seeds start at 1: seed + 1). Returns the runs to the first failing one (None: none within *budget*)."""
    import staliro  # the benchmark's own extra (`arch`): imported only when asked for
    from staliro.optimizers import DualAnnealing

    sweep = sweep_of(requirement)
    names = sorted(sweep.defaults)
    seen: list[bool] = []

    @staliro.costfunc
    def cost(inputs: Any) -> float:
        values = {n: round(float(inputs.static[n]), 6) for n in names}
        result = row(sweep, values)
        seen.append(result["verdict"] != "pass")
        margin = result["oracles"][0].get("margin") if result["oracles"] else None
        return -1.0 if margin is None else float(margin) - (1e-9 if seen[-1] else 0.0)

    options = staliro.TestOptions(static_inputs={n: (0.0, 1.0) for n in names}, iterations=budget, runs=1, seed=seed + 1)
    staliro.staliro(cost, DualAnnealing(min_cost=0.0), options)
    return seen.index(True) + 1 if True in seen else None


def summary(firsts: list[int | None], budget: int) -> dict[str, Any]:
    found = [f for f in firsts if f is not None]
    return {"found": len(found), "seeds": len(firsts),
            "mean": statistics.mean(found) if found else None,
            "median": statistics.median(found) if found else None,
            "median_all": statistics.median(f if f is not None else budget + 1 for f in firsts)}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.arch_cc", description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=2, help="searches per requirement and method (default 2)")
    parser.add_argument("--first-seed", type=int, default=0, help="the first seed (default 0): seeds FIRST .. FIRST + SEEDS - 1, so a table can be split over processes")
    parser.add_argument("--budget", type=int, default=1500, help="runs per search (default 1,500)")
    parser.add_argument("--methods", default="auto,random", help="comma-separated falsify methods, and psy-taliro (PSY-TaLiRo's dual annealing; the `arch` extra) (default auto,random)")
    parser.add_argument("--requirements", default=",".join(REQUIREMENTS), help="comma-separated (default all)")
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args(argv)
    results = []
    print(f"{'req':4} {'method':8} {'falsified':>9} {'mean':>8} {'median':>7} {'s/search':>9}  firsts")
    for requirement in args.requirements.split(","):
        for method in args.methods.split(","):
            firsts, began = [], time.perf_counter()
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                if method == "psy-taliro":
                    firsts.append(psy_taliro(requirement, seed, args.budget))
                else:
                    firsts.append(search(requirement, method, seed, args.budget).first_failure)
            s = summary(firsts, args.budget)
            s.update(requirement=requirement, method=method, firsts=firsts, budget=args.budget, first_seed=args.first_seed,
                     seconds=(time.perf_counter() - began) / args.seeds)
            results.append(s)
            mean = "-" if s["mean"] is None else f"{s['mean']:.1f}"
            median = "-" if s["median"] is None else f"{s['median']:g}"
            print(f"{requirement:4} {method:8} {s['found']:>4}/{s['seeds']:<4} {mean:>8} {median:>7} {s['seconds']:>9.1f}  {firsts}",
                  flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
