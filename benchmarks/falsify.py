"""The falsify benchmark: ``python -m benchmarks.falsify`` (issue 22).

Three cases in ``benchmarks/falsify_cases/``, each failing on a small part of its box:

* ``island_2d`` - built-in simulator, 2 parameters: two ramps end inside an
  ellipse (about 1 % of the box);
* ``island_4d`` - built-in simulator, 4 parameters: the same with the ramps'
  durations (about 1 %);
* ``cut_in_3d`` - SUMO, 3 parameters: the cut-in gap, the ego's and the
  cutter's speeds; fails where the ACC lets the gap fall below 0.5 m or they collide.

**Ground truth** is a dense grid of real runs, computed once (``--truth``, or
when the stored file is missing) and stored beside the case
(``NAME.truth.json``: the grid's axes and one character per point, ``1``
failing, in sweep order): the failing share *p* of the box, uniform random's
expected median runs to a first failure (ln 2 / -ln(1 - p)) and the grid's
first failure in the sweep's order. The built-in cases' criterion has an
equation (:func:`island_margin`); where the real-run grid is coarser than the
declared resolution, *p* and the grid's first failure are counted on the grid
*at* the declared resolution from the equation (40,401 and 1,632,240,801
points), after checking that the equation gives every stored real run's
verdict (:func:`declared_truth`). The SUMO case has no equation: its grid is at
the declared resolution where it fails (``FOCUS``; 75,276 runs, ``--truth-jobs``
forks processes for them) and coarse outside, where it must fail nowhere.

For each case and method, ``--seeds`` searches (default 20; seeds from ``--first-seed``, default 0) with ``--budget``
runs (default 200), ``--batch`` (default 1: the runs run in this process, one
after the other, and ``falsify``'s batch is the number of runs that can run at
once) and ``stop: cluster``: the median runs to the first failure, the seeds that found one, the
search's own time (sampler, model, bookkeeping: everything but the runs) over
the runs' time, wall clock and (in brackets) this process's CPU time, the steadier
figure on a loaded machine - after one untimed search has imported the optimiser
libraries, a cost a process pays once (``import_s`` in ``--json``) - and for the
default method the boundary points' distance to the true boundary in units of
the declared resolution (the built-in cases: from the ellipse's equation; SUMO:
half the width of the pass/fail pair, an upper bound, since the boundary lies
between a real passing and a real failing run).

``--sumo-loop`` compares a SUMO run inside a search (validate + run, exactly as the
search's job does it, in a ``reuse_simulations`` block as a worker's chunk and an in-process
search run it: SUMO started once, set back to time 0 between runs) with the same setting run by
a bare libsumo loop written by hand (:func:`bare_run`: start, set speeds, step, change lane,
read the gap, close - the same SUMO steps, counted and printed), both measured in this process
in blocks of 20 settings taking turns (libsumo runs one simulation per process: a kept one and
the bare loop cannot alternate run by run), medians over 20 settings x 5 rounds (wall clock,
and CPU time of this process: SUMO runs in it); also the search's runs each starting SUMO (as
before the reuse), the bare loop started once and reloaded with ``libsumo.load`` (libsumo's load
is its close plus its start: the two cost the same), and where the search's run spends its time.

``--workers N`` runs each case's search (seed 3, ``--workers-budget`` runs, batch N, ``stop: all``) the
way ``falsify --jobs N`` runs it - its batches through the sweep's local pool - with the N worker
processes kept for the whole search (``parallel.Workers``, each keeping its SUMO open), and with a pool
started and stopped for every batch (as before), taking turns, 2 rounds: wall-clock seconds per search
and their ratio; both must run the same search (every run's verdict and margins compared). Each case is
measured in a new Python process, as the command is: a process that has run SUMO itself (the searches
above) forks workers that have libsumo imported already, which the command's workers never have.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence

if __package__ in (None, ""):  # run as a file
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from btgen_pytrees.leaves import default_registry  # noqa: E402
from btgen_pytrees.load import validate  # noqa: E402
from btgen_pytrees.falsify import Search, Settings, Space  # noqa: E402
from btgen_pytrees.falsify.cases import evaluator  # noqa: E402
from btgen_pytrees.falsify.jobs import timed  # noqa: E402
from btgen_pytrees.falsify.margins import groups_of, row_margins  # noqa: E402
from btgen_pytrees.falsify.sampler import available  # noqa: E402
from btgen_pytrees.sweep.jobs import RunOptions  # noqa: E402
from btgen_pytrees.sweep import load_sweep  # noqa: E402
from btgen_pytrees.parallel import Workers  # noqa: E402
from btgen_pytrees.systems.sumo import keep_simulations, reuse_simulations  # noqa: E402

__all__ = ["main", "CASES", "truth", "declared_truth", "island_margin", "case_path", "search_case", "GOALS"]

ROOT = Path(__file__).resolve().parent
CASES = ("island_2d", "island_4d", "cut_in_3d")
METHODS = ("auto", "cmaes", "tpe", "sobol", "random")
TRUTH_GRID: dict[str, Any] = {"island_2d": 101, "island_4d": 9, "cut_in_3d": (15, 11, 9)}
"""Points per parameter of the truth grid (None: the declared resolution)."""
FOCUS = {"cut_in_3d": ("gap", 1.5, 5.0)}
"""Where the truth grid is dense: (parameter, low, high); there every parameter is at its declared resolution.
Outside it a coarse grid (``outside``, ``TRUTH_GRID`` points) must fail nowhere, and the share is the dense
part's failing points over the declared grid's."""
GOALS = {"median_vs_random": 0.2, "found": 1.0, "boundary_in_resolution": 1.0, "search_cost": 0.05, "sumo_vs_bare": 1.5}


def case_path(name: str) -> Path:
    return ROOT / "falsify_cases" / f"{name}.json"


def _sweep(name: str) -> Any:
    return load_sweep(str(case_path(name)), check_all=False, max_variations=10**18)


def _row(sweep: Any, values: dict[str, Any]) -> dict[str, Any]:
    """One run in this process, as the search's job does it (its sweep row, ``wall``, ``margins``)."""
    outcome = timed("x", RunOptions(), sweep.source, sweep.document({**sweep.defaults, **values}), None)
    row = dict(getattr(outcome, "row", {"verdict": "error", "oracles": []}))
    row["margins"] = row_margins(row)
    return row


def _evaluator(sweep: Any) -> tuple[Callable[[list[dict[str, Any]]], list[dict[str, Any]]], list[float]]:
    spent = [0.0, 0.0]  # wall clock, CPU time of this process

    def evaluate(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
        t0, c0 = time.perf_counter(), time.process_time()
        rows = [_row(sweep, v) for v in points]
        spent[0] += time.perf_counter() - t0
        spent[1] += time.process_time() - c0
        return rows

    return evaluate, spent


# -- ground truth ------------------------------------------------------------------------------------


def _axes(name: str, space: Space, focus: bool = False) -> list[list[float]]:
    """The truth grid's axes: ``TRUTH_GRID`` points per parameter; for a case in ``FOCUS``, its dense part
    (*focus*: every parameter at the declared resolution, the focus parameter within its range) or the
    coarse grid outside it."""
    size = TRUTH_GRID[name]
    axes = []
    for k, d in enumerate(space.dimensions):
        if focus:
            low, high = FOCUS[name][1:] if FOCUS[name][0] == d.name else (-math.inf, math.inf)
            axes.append([round(float(v), 6) for v in _declared_axis(d) if low - 1e-9 <= v <= high + 1e-9])
            continue
        n = d.grid_size() if size is None else (size[k] if isinstance(size, tuple) else size)
        axes.append([d.value((i / (n - 1)) if n > 1 else 0.5) for i in range(n)])
    if not focus and name in FOCUS:  # the coarse grid: only the part outside the focus
        k = [d.name for d in space.dimensions].index(FOCUS[name][0])
        axes[k] = [v for v in axes[k] if v > FOCUS[name][2]]
    return axes


_SWEEP: Any = None
"""The case a forked grid process runs (set before the fork, inherited)."""


def _grid_part(job: tuple[list[str], list[list[float]], int, int]) -> str:
    names, axes, begin, end = job
    bits = []
    for flat in range(begin, end):
        rest, values = flat, {}
        for n, axis in zip(reversed(names), reversed(axes)):
            rest, i = divmod(rest, len(axis))
            values[n] = axis[i]
        row = _row(_SWEEP, values)
        bits.append("1" if row["verdict"] != "pass" else "0")
    return "".join(bits)


def _grid(sweep: Any, names: list[str], axes: list[list[float]], jobs: int = 1) -> str:
    """One character per grid point in sweep order (``1``: the run did not pass); *jobs* forked processes."""
    global _SWEEP
    _SWEEP = sweep
    total = math.prod(len(a) for a in axes)
    if jobs <= 1:
        return _grid_part((names, axes, 0, total))
    import concurrent.futures
    import multiprocessing

    step = max(1, math.ceil(total / (jobs * 20)))
    parts = [(names, axes, b, min(total, b + step)) for b in range(0, total, step)]
    with concurrent.futures.ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        return "".join(pool.map(_grid_part, parts))


def truth(name: str, compute: bool = False, jobs: int = 1) -> dict[str, Any]:
    """The stored ground truth of case *name* (computed and stored first if asked or missing)."""
    path = ROOT / "falsify_cases" / f"{name}.truth.json"
    if path.exists() and not compute:
        return json.loads(path.read_text())  # type: ignore[no-any-return]
    sweep = _sweep(name)
    space = Space.of(sweep.variations)
    names = [d.name for d in space.dimensions]
    t0 = time.perf_counter()
    axes = _axes(name, space, focus=name in FOCUS)
    bits = _grid(sweep, names, axes, jobs)
    total = len(bits)
    share = bits.count("1") / total
    outside = None
    if name in FOCUS:
        coarse = _axes(name, space)
        outer = _grid(sweep, names, coarse, jobs)
        outside = {"axes": dict(zip(names, coarse)), "points": len(outer), "failing": outer.count("1")}
        k = names.index(FOCUS[name][0])  # the dense part's share of the declared grid (none fails outside it)
        share *= len(axes[k]) / space.dimensions[k].grid_size()
    data = {"case": name, "command": f"python -m benchmarks.falsify --truth --cases {name}",
            "axes": dict(zip(names, axes)), "points": total, "failing": bits.count("1"), "share": share,
            "first_failure": bits.index("1") + 1 if "1" in bits else None, "outside": outside,
            "seconds": round(time.perf_counter() - t0, 1), "bits": bits}  # fmt: skip
    path.write_text(json.dumps(data) + "\n")
    return data


def _declared_first(name: str, t: dict[str, Any], space: Space) -> int | None:
    """The grid at the declared resolution, in sweep order: the index of its first failing point (from the truth grid)."""
    if t["first_failure"] is None:
        return None
    axes = list(t["axes"].values())
    rest, point = t["first_failure"] - 1, []
    for axis in reversed(axes):
        rest, i = divmod(rest, len(axis))
        point.append(axis[i])
    point.reverse()
    flat = 0
    for d, v in zip(space.dimensions, point):
        flat = flat * d.grid_size() + round((v - d.low) / d.resolution)
    return flat + 1


def _declared_axis(d: Any) -> Any:
    import numpy as np

    return d.low + d.resolution * np.arange(round((d.high - d.low) / d.resolution) + 1)


def declared_truth(name: str, t: dict[str, Any]) -> dict[str, Any]:
    """The failing share and the grid's first failure (sweep order) at the declared resolution.

    For the built-in cases, counted from the criterion's equation on the grid at the declared
    resolution, once the equation is checked to give the verdict of every real run of the stored
    truth grid (an AssertionError otherwise); for SUMO (no equation), the stored grid's share and its
    first failure mapped onto the declared grid.
    """
    space = Space.of(_sweep(name).variations)
    if name not in ("island_2d", "island_4d"):
        return {"share": t["share"], "first": _declared_first(name, t, space), "points": space.grid_size(),
                "how": f"real-run grid ({t['points']} points{' in its dense part' if t.get('outside') else ''})"}  # fmt: skip
    import itertools

    import numpy as np

    names, axes = list(t["axes"]), list(t["axes"].values())
    wrong = [p for flat, p in enumerate(itertools.product(*axes)) if (island_margin(name, dict(zip(names, p))) < 0) != (t["bits"][flat] == "1")]
    assert not wrong, f"{name}: the equation disagrees with the real runs at {wrong[:3]}"
    ax = {d.name: _declared_axis(d) for d in space.dimensions}
    if name == "island_2d":
        A, B = np.meshgrid(ax["a"], ax["b"], indexing="ij")
        flat = ((A - 6) ** 2 / 4 + (B - 2.5) ** 2 < 0.08).ravel()
        share, first, points = float(flat.mean()), int(np.argmax(flat)) + 1, flat.size
    else:  # x depends on (a, d1), y on (b, d2): count the (x, y) pairs inside the ellipse
        a, b, d1, d2 = ax["a"], ax["b"], ax["d1"], ax["d2"]
        X = a[:, None] * np.minimum(1.0, 3 / d1)[None, :]
        Y = b[:, None] * np.minimum(1.0, 3 / d2)[None, :]
        ys = np.sort(Y.ravel())
        r2 = 0.06 - (X - 6) ** 2 / 4
        r = np.sqrt(np.maximum(r2, 0.0))
        counts = np.where(r2 > 0, np.searchsorted(ys, 2.5 + r, side="left") - np.searchsorted(ys, 2.5 - r, side="right"), 0)
        points = a.size * b.size * d1.size * d2.size
        share, first = float(counts.sum()) / points, None
        for i in range(a.size):  # sweep order: a slowest, then b, d1, d2
            if (counts[i] > 0).any():
                cube = ((X[i][None, :, None] - 6) ** 2 / 4 + (Y[:, None, :] - 2.5) ** 2 < 0.06).ravel()
                first = i * cube.size + int(np.argmax(cube)) + 1
                break
    return {"share": share, "first": first, "points": points,
            "how": f"equation on the declared grid (agrees with all {t['points']:,} real runs of the stored grid)"}  # fmt: skip


# -- boundary distance ---------------------------------------------------------------------------------


def island_margin(name: str, p: dict[str, float]) -> float:
    """The built-in cases' criterion at 3 s, from its equation (> 0 passes)."""
    if name == "island_2d":
        return (p["a"] - 6) ** 2 / 4 + (p["b"] - 2.5) ** 2 - 0.08
    x = p["a"] * min(1.0, 3 / p["d1"])
    y = p["b"] * min(1.0, 3 / p["d2"])
    return (x - 6) ** 2 / 4 + (y - 2.5) ** 2 - 0.06


def _distance(name: str, search: Search, boundary: Any) -> float:
    """Distance of a boundary point to the true boundary along its parameter, in resolutions."""
    p, f = search.runs[boundary.passing], search.runs[boundary.failing]
    along = boundary.parameter
    d = next(d for d in search.space.dimensions if d.name == along)
    mid = {k: (p.parameters[k] + f.parameters[k]) / 2 for k in p.parameters}
    if name == "cut_in_3d":  # no equation: the boundary lies between the pair
        return abs(p.parameters[along] - f.parameters[along]) / 2 / d.resolution
    step = d.resolution / 1000
    best = math.inf
    for k in range(-5000, 5001):  # the nearest sign change within 5 resolutions
        a, b = dict(mid), dict(mid)
        a[along] += k * step
        b[along] += (k + 1) * step
        if (island_margin(name, a) > 0) != (island_margin(name, b) > 0):
            best = min(best, abs(k + 0.5) * step)
    return best / d.resolution


# -- searches --------------------------------------------------------------------------------------------


def search_case(name: str, method: str, seeds: int, budget: int, batch: int = 1, first_seed: int = 0, start: int | None = None) -> dict[str, Any]:
    sweep = _sweep(name)
    space = Space.of(sweep.variations)
    firsts, distances, own, runs_time, own_cpu, runs_cpu = [], [], 0.0, 0.0, 0.0, 0.0
    done: list[Search] = []
    groups = groups_of(validate(sweep.document(sweep.defaults), sweep.source, default_registry()))
    warm, _ = _evaluator(sweep)  # imports (the optimiser libraries, numpy, scipy) are a process's, paid once: not timed
    Search(space, sweep.defaults, Settings(method=method, seed=10**6, budget=2 * batch, batch=batch, stop="cluster"), warm, groups).run()
    for seed in range(first_seed, first_seed + seeds):
        evaluate, spent = _evaluator(sweep)
        t0, c0 = time.perf_counter(), time.process_time()
        settings = Settings(method=method, seed=seed, budget=budget, stop="cluster", batch=batch, start=start)
        search = Search(space, sweep.defaults, settings, evaluate, groups).run()
        total, cpu = time.perf_counter() - t0, time.process_time() - c0
        own += total - spent[0]
        runs_time += spent[0]
        own_cpu += cpu - spent[1]
        runs_cpu += spent[1]
        firsts.append(search.first_failure)
        if method == "auto":
            done.append(search)
    # the boundary's distances after every search: their ten thousand steps per point between two timed
    # searches left the next one's set-up to run cold (0.4 ms of a 2.6 ms search's own 60 us-a-run work)
    for search in done:
        for c in search.clusters:
            for b in c.boundary:
                if b.parameter is not None:
                    distances.append(_distance(name, search, b))
    found = [f for f in firsts if f is not None]
    return {"case": name, "method": search.method if method != "auto" else f"auto ({search.method})", "seeds": seeds, "batch": batch,
            "found": len(found), "median": statistics.median(f if f is not None else budget + 1 for f in firsts),
            "firsts": firsts, "search_cost": own / runs_time if runs_time else None,
            "search_cost_cpu": own_cpu / runs_cpu if runs_cpu else None,
            "boundary_max": max(distances) if distances else None, "boundary_points": len(distances)}  # fmt: skip


def workers_case(name: str, workers: int, budget: int, kept: bool) -> dict[str, Any]:
    """*name*'s search as ``falsify --jobs WORKERS`` runs it (seed 3, batch WORKERS, ``stop: all``), its workers
    kept for the whole search (*kept*) or a pool started for each batch (as before): seconds, and every run."""
    sweep = _sweep(name)
    space = Space.of(sweep.variations)
    groups = groups_of(validate(sweep.document(sweep.defaults), sweep.source, default_registry()))
    settings = Settings(method="auto", seed=3, budget=budget, batch=workers, stop="all")
    available()  # the optimiser libraries' import is the process's, paid once (as in search_case): not timed
    import scipy.linalg  # noqa: F401
    import scipy.special  # noqa: F401

    t0 = time.perf_counter()
    pool = Workers(workers, keep_simulations) if kept else None
    try:
        search = Search(space, sweep.defaults, settings, evaluator(sweep, RunOptions(), workers, None, pool), groups).run()
    finally:
        if pool is not None:
            pool.close()
    return {"seconds": time.perf_counter() - t0, "runs": [[r.parameters, r.verdict, r.row.get("margins")] for r in search.runs]}


_WORKERS_CHILD = ("import json, sys\nfrom benchmarks.falsify import workers_case\n"
                  "print(json.dumps(workers_case(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == 'kept')))\n")  # fmt: skip


def workers_in_new_process(name: str, workers: int, budget: int, rounds: int = 2) -> dict[str, Any]:
    """:func:`workers_case` both ways, taking turns, each search in a new Python process (one that has run
    nothing of SUMO itself, as the command: a batch of one point runs in the process, and afterwards its
    forked workers would have libsumo imported already); the least of *rounds* seconds each."""
    import os
    import subprocess

    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT.parent), os.environ.get("PYTHONPATH")]))}
    times: dict[str, list[float]] = {"kept": [], "per batch": []}
    runs: dict[str, Any] = {}
    for _ in range(rounds):
        for how in times:
            done = subprocess.run([sys.executable, "-c", _WORKERS_CHILD, name, str(workers), str(budget), how.replace(" ", "-")],
                                  capture_output=True, text=True, cwd=ROOT.parent, env=env, check=True)  # fmt: skip
            one = json.loads(done.stdout.splitlines()[-1])
            times[how].append(one["seconds"])
            if runs.setdefault(how, one["runs"]) != one["runs"]:
                raise AssertionError(f"{name}: the same search ran differently")
    if runs["kept"] != runs["per batch"]:
        raise AssertionError(f"{name}: the kept workers ran another search")
    kept, fresh = min(times["kept"]), min(times["per batch"])
    return {"case": name, "workers": workers, "runs": len(runs["kept"]), "kept_s": kept, "per_batch_s": fresh,
            "ratio": fresh / kept, "times": times}  # fmt: skip


def workers_text(rows: Sequence[dict[str, Any]]) -> str:
    lines = [f"\nfalsify's batches through the local pool (seed 3, batch = workers, stop: all; each search in a new process, "
             f"the least of {len(rows[0]['times']['kept'])}):"]  # fmt: skip
    for r in rows:
        lines.append(f"{r['case']}: {r['runs']} runs on {r['workers']} workers kept for the search {r['kept_s']:.2f} s, "
                     f"a pool started per batch {r['per_batch_s']:.2f} s: {r['ratio']:.1f}x; the same search")  # fmt: skip
    return "\n".join(lines) + "\n"


# -- a bare libsumo loop -----------------------------------------------------------------------------------


def _bare_arguments(config: str) -> list[str]:
    """What the bare loop starts SUMO with: the case's own command line (see SumoSystem.arguments)."""
    return ["sumo", "-c", config, "--step-length", "0.1", "--begin", "0", "--no-step-log", "true", "--no-warnings",
            "true", "--duration-log.disable", "true", "--xml-validation", "never", "--xml-validation.net", "never",
            "--xml-validation.routes", "never", "--seed", "1"]  # fmt: skip


def bare_run(libsumo: Any, args: list[str], v: dict[str, Any], reload: bool = False) -> int:
    """``cut_in_3d`` at the setting *v* written by hand against libsumo: the same steps and commands as the
    case's run (set both speeds; when the gap is down to ``gap``, the cutter changes to lane 0 for 2 s
    with lane-change mode 0; 8 s after it is there the run ends; it ends early on a collision or an
    ``ego.gap`` below 0.5 m), reading only what it needs (two positions, the leader, collisions, the
    cutter's lane). Returns SUMO's steps. *reload*: ``libsumo.load`` instead of ``start`` ... ``close``."""
    if reload:
        libsumo.load(args[1:])
    else:
        libsumo.start(args)
    veh, sim = libsumo.vehicle, libsumo.simulation
    libsumo.simulationStep()  # SUMO's step at 0, as SumoSystem.start
    steps, cut, there = 1, None, None
    for k in range(400):  # tick k (the case's timeout: 40 s)
        leader = veh.getLeader("ego", 1000.0)
        if sim.getCollidingVehiclesNumber() or (leader and leader[0] and leader[1] + 2.5 < 0.5):
            break
        if k == 0:
            veh.setSpeed("cutter", v["cutter_speed"])
            veh.setSpeed("ego", v["ego_speed"])
        if cut is None and veh.getPosition("cutter")[0] - 5 - veh.getPosition("ego")[0] <= v["gap"]:
            veh.setLaneChangeMode("cutter", 0)
            veh.changeLane("cutter", 0, 1.9)
            cut = k
        elif cut is not None and there is None and veh.getLaneIndex("cutter") == 0:
            there = k
        if there is not None and k - there >= 80:
            break
        libsumo.simulationStep()
        steps += 1
    if not reload:
        libsumo.close()
    return steps


def _breakdown(sweep: Any, v: dict[str, Any]) -> dict[str, float]:
    """One run of the search's job taken apart (s): validation, system and tree, SUMO's start (or its
    restore from the snapshot, in a :func:`reuse_simulations` block) and close (or keeping it), SUMO's
    steps, the adapter, and the rest of the run (the tree's ticks, the collector)."""
    from btgen_pytrees.construct import generate
    from btgen_pytrees.run import create_system, run_tree, runner

    registry = default_registry()
    t0 = time.perf_counter()
    case = validate(sweep.document({**sweep.defaults, **v}), sweep.source, registry)
    t1 = time.perf_counter()
    system = create_system(case, registry)
    system.timer = time.perf_counter  # type: ignore[attr-defined]
    root = generate(case, registry=registry, clock=system)
    t2 = time.perf_counter()
    run_tree(root, case, system=system, record=False)  # as the sweep's job
    t3 = time.perf_counter()
    take_apart = getattr(runner, "take_apart", None)  # what run() does with its tree (before it: release)
    take_apart(root) if take_apart is not None else root.btgen_env.release()
    timing = system.timing  # type: ignore[attr-defined]
    return {"validate": t1 - t0, "system and tree": t2 - t1, "SUMO start+close": timing["start"] + timing["close"],
            "SUMO steps": timing["sumo"], "adapter": timing["adapter"],
            "tree, collector": t3 - t2 - sum(timing.values())}  # fmt: skip


def sumo_loop(points: int = 20, rounds: int = 5) -> dict[str, Any]:
    """cut_in_3d's run inside a search (validate + run, as the search's job does it) against the same
    settings in a bare libsumo loop (:func:`bare_run`, started and closed per run); medians per run.

    libsumo is one simulation per process, so a simulation kept open between the search's runs
    (:func:`reuse_simulations`, as a worker's chunk and an in-process search run them) and the bare
    loop cannot take turns run by run: each round runs the 20 settings as four blocks - the bare loop,
    the search's runs with the simulation kept (the block's first run starts SUMO and takes the
    snapshot), the search's runs each starting SUMO, the bare loop reloading with ``libsumo.load``."""
    import random

    import libsumo

    sweep = _sweep("cut_in_3d")
    space = Space.of(sweep.variations)
    rng = random.Random(1)
    values = [space.values([rng.random() for _ in space.dimensions]) for _ in range(points)]
    args = _bare_arguments(str((case_path("cut_in_3d").parent / sweep.template["system"]["config"]).resolve()))
    wall, cpu = time.perf_counter, time.process_time
    bare_run(libsumo, args, values[0])  # warm-up (imports, caches)
    _row(sweep, values[0])
    names = ("search", "search_fresh", "bare", "bare_load")
    times: dict[str, list[float]] = {k: [] for k in names}
    cpus: dict[str, list[float]] = {k: [] for k in names}
    steps = {"search": 0, "bare": 0}

    def clock(name: str, run: Callable[[], Any]) -> Any:
        t0, c0 = wall(), cpu()
        out = run()
        times[name].append(wall() - t0)
        cpus[name].append(cpu() - c0)
        return out

    for r in range(rounds):
        for v in values:
            n = clock("bare", lambda: bare_run(libsumo, args, v))
            steps["bare"] += n if r == 0 else 0
        with reuse_simulations():
            for v in values:
                row = clock("search", lambda: _row(sweep, v))
                steps["search"] += row["ticks"] if r == 0 else 0
        for v in values:
            clock("search_fresh", lambda: _row(sweep, v))
        libsumo.start(args)  # started once, reloaded per run
        for v in values:
            clock("bare_load", lambda: bare_run(libsumo, args, v, reload=True))
        libsumo.close()
    parts: dict[str, list[float]] = {}
    fresh_parts: dict[str, list[float]] = {}
    with reuse_simulations():
        _breakdown(sweep, values[0])  # the block's first run starts SUMO; the runs below restore it
        for v in values:
            for k, t in _breakdown(sweep, v).items():
                parts.setdefault(k, []).append(t)
    for v in values:
        for k, t in _breakdown(sweep, v).items():
            fresh_parts.setdefault(k, []).append(t)
    ms = {k: 1000 * statistics.median(t) for k, t in times.items()}
    cpu_ms = {k: 1000 * statistics.median(t) for k, t in cpus.items()}
    return {"points": points, "runs": points * rounds, "search_ms": ms["search"], "bare_ms": ms["bare"],
            "search_fresh_ms": ms["search_fresh"], "bare_load_ms": ms["bare_load"],
            "search_mean_ms": 1000 * statistics.fmean(times["search"]), "ratio": ms["search"] / ms["bare"],
            "search_cpu_ms": cpu_ms["search"], "bare_cpu_ms": cpu_ms["bare"], "search_fresh_cpu_ms": cpu_ms["search_fresh"],
            "ratio_cpu": cpu_ms["search"] / cpu_ms["bare"], "ratio_fresh_cpu": cpu_ms["search_fresh"] / cpu_ms["bare"],
            "steps": steps, "breakdown_ms": {k: 1000 * statistics.median(t) for k, t in parts.items()},
            "breakdown_fresh_ms": {k: 1000 * statistics.median(t) for k, t in fresh_parts.items()}}  # fmt: skip


def sumo_loop_text(loop: dict[str, Any]) -> str:
    parts = ", ".join(f"{k} {v:.2f}" for k, v in loop["breakdown_ms"].items())
    fresh = ", ".join(f"{k} {v:.2f}" for k, v in loop["breakdown_fresh_ms"].items())
    return (f"\nSUMO run inside a search (validate + run, as the search's job; SUMO kept open and restored between "
            f"runs): {loop['search_ms']:.2f} ms (mean {loop['search_mean_ms']:.2f}: each block's first run starts SUMO); "
            f"bare libsumo loop (start ... close): {loop['bare_ms']:.2f} ms; ratio {loop['ratio']:.2f}x "
            f"(goal <= {GOALS['sumo_vs_bare']}x); CPU time of this process: {loop['search_cpu_ms']:.2f} ms and "
            f"{loop['bare_cpu_ms']:.2f} ms, {loop['ratio_cpu']:.2f}x\n"
            f"the same runs each starting SUMO: {loop['search_fresh_ms']:.2f} ms, CPU {loop['search_fresh_cpu_ms']:.2f} ms, "
            f"{loop['ratio_fresh_cpu']:.2f}x the bare loop's CPU time\n"
            f"medians of {loop['runs']} runs each ({loop['points']} settings x {loop['runs'] // loop['points']}, in "
            f"blocks of {loop['points']} taking turns); SUMO steps over the {loop['points']} settings: search "
            f"{loop['steps']['search']}, bare {loop['steps']['bare']}\n"
            f"the bare loop started once and reloaded with libsumo.load: {loop['bare_load_ms']:.2f} ms\n"
            f"the search's run, ms (medians), SUMO kept: {parts}\n"
            f"the search's run, ms (medians), SUMO started per run: {fresh}\n")  # fmt: skip


# -- the search's own cost at scale ----------------------------------------------------------------------------


def _spin(seconds: float) -> None:
    """Busy for *seconds* of this process's processor time: a run that uses the processor, as a simulation does."""
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def synthetic_search(d: int, budget: int, objective: Callable[[list[float]], float], run_s: float = 0.0,
                     seed: int = 0, batch: int = 1) -> dict[str, Any]:  # fmt: skip
    """A ``gp`` search (``stop: all``) of *budget* runs over *d* parameters in [0, 1] whose runs are
    *objective* (the margin of one criterion; a run fails below 0) and *run_s* seconds of processor work
    each: the search's own wall and processor time (all but the runs) against the runs'."""
    from btgen_pytrees.falsify.space import Dimension

    space = Space(tuple(Dimension(f"p{i}", "range", 0.0, 1.0, 0.001) for i in range(d)))
    spent = [0.0, 0.0]
    names = [f"p{i}" for i in range(d)]

    def evaluate(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
        t0, c0 = time.perf_counter(), time.process_time()
        rows = []
        for p in points:
            if run_s:
                _spin(run_s)
            m = objective([p[k] for k in names])
            rows.append({"verdict": "pass" if m >= 0 else "fail", "margins": {"F1": m}})
        spent[0] += time.perf_counter() - t0
        spent[1] += time.process_time() - c0
        return rows

    t0, c0 = time.perf_counter(), time.process_time()
    search = Search(space, {}, Settings(budget=budget, seed=seed, batch=batch), evaluate, {"others": ("&&", ["F1"])}).run()
    wall, cpu = time.perf_counter() - t0 - spent[0], time.process_time() - c0 - spent[1]
    return {"d": d, "budget": budget, "runs": len(search.runs), "failures": sum(r.failed for r in search.runs),
            "clusters": len(search.clusters), "own_wall_s": wall, "own_cpu_s": cpu, "runs_wall_s": spent[0],
            "own_ms_per_run": 1000 * cpu / max(1, len(search.runs)),
            "share": wall / spent[0] if run_s and spent[0] else None}  # fmt: skip


def _two_valleys(x: list[float]) -> float:
    """Never below 0.02: two valleys (at 0.2 and 0.75 in every coordinate, L1) and a ripple - no bowl the
    quadratic model could take, so the Gaussian process chooses every batch."""
    d = len(x)
    return 0.02 + min(sum(abs(u - c) for u in x) / d for c in (0.2, 0.75)) + 0.01 * math.sin(20 * x[0])


def _half(x: list[float]) -> float:
    return x[0] - 0.5


def _never(x: list[float]) -> float:
    return 0.5 + x[0]


def startup(runs: int = 5) -> dict[str, Any]:
    """``falsify`` as a new process (imports, the pool of 2 workers, 2 runs, the table): wall-clock and processor
    seconds (its own and its workers'), the median of *runs* - with the project's bytecode cached (as an
    installed package has it: a fresh cache directory, warmed by one run first) and, interleaved, as this
    interpreter's environment has it (with ``PYTHONDONTWRITEBYTECODE`` set, every module of the project is
    compiled from source at every start)."""
    import resource
    import subprocess
    import tempfile

    command = [sys.executable, "-m", "btgen_pytrees", "falsify", str(case_path("island_2d")), "--budget", "2", "--jobs", "2"]
    with tempfile.TemporaryDirectory() as cache:
        envs = {"cached": {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "PYTHONPYCACHEPREFIX": cache},
                "as is": dict(os.environ)}  # fmt: skip
        subprocess.run(command, check=False, capture_output=True, env=envs["cached"])
        walls: dict[str, list[float]] = {k: [] for k in envs}
        cpus: dict[str, list[float]] = {k: [] for k in envs}
        for _ in range(runs):
            for kind, env in envs.items():
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.perf_counter()
                subprocess.run(command, check=False, capture_output=True, env=env)
                walls[kind].append(time.perf_counter() - t0)
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpus[kind].append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return {"wall_s": statistics.median(walls["cached"]), "cpu_s": statistics.median(cpus["cached"]),
            "as_is_wall_s": statistics.median(walls["as is"]), "as_is_cpu_s": statistics.median(cpus["as is"]),
            "no_bytecode_written": bool(os.environ.get("PYTHONDONTWRITEBYTECODE"))}  # fmt: skip


def scale(budget: int = 1500, d: int = 20, run_ms: float = 20.0) -> dict[str, Any]:
    """The search's own cost at competition scale (issue 36): *budget* runs of *run_ms* over *d* parameters;
    the bookkeeping's growth with the runs (a half-failing and a never-failing 2-parameter box); start-up."""
    big = synthetic_search(d, budget, _two_valleys, run_ms / 1000)
    half = [synthetic_search(2, n, _half) for n in (250, 500, 1000)]
    never = synthetic_search(2, 20000, _never)
    return {"scale": big, "half": half, "never": never, "startup": startup()}


def scale_text(figures: dict[str, Any]) -> str:
    big, st = figures["scale"], figures["startup"]
    lines = ["", f"search's own cost, {big['d']} parameters, budget {big['budget']}, runs of {big['runs_wall_s'] / big['runs'] * 1000:.1f} ms "
             f"(in-process, batch 1): {100 * big['share']:.1f} % of the runs' wall time ({big['own_wall_s']:.2f} s; CPU {big['own_cpu_s']:.2f} s, "
             f"{big['own_ms_per_run']:.2f} ms a run)",
             "bookkeeping, 2 parameters (the search's own CPU seconds, all runs 0 ms): half-failing box "
             + ", ".join(f"{h['runs']} runs {h['own_cpu_s']:.2f} s ({h['failures']} failing, {h['clusters']} cluster{'s' * (h['clusters'] != 1)})" for h in figures["half"])
             + f"; never-failing box {figures['never']['runs']} runs {figures['never']['own_cpu_s']:.2f} s",
             startup_text(st)]  # fmt: skip
    return "\n".join(lines) + "\n"


def startup_text(st: dict[str, Any]) -> str:
    return (f"falsify process start-up (imports, a pool of 2, 2 runs of island_2d, the table): {st['wall_s']:.2f} s wall, {st['cpu_s']:.2f} s CPU "
            f"with the bytecode cached; {st['as_is_wall_s']:.2f} s wall, {st['as_is_cpu_s']:.2f} s CPU as this environment starts it"
            + (" (PYTHONDONTWRITEBYTECODE set: the project compiled at every start)" if st["no_bytecode_written"] else ""))  # fmt: skip


# -- the report --------------------------------------------------------------------------------------------


def table(rows: Sequence[dict[str, Any]], truths: dict[str, dict[str, Any]], budget: int) -> str:
    lines = ["| case | method | batch | median runs to 1st failure | seeds falsified | vs uniform random | search's own cost | boundary (max, resolutions) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
    for r in rows:
        p = truths[r["case"]]["declared"]["share"]
        expected = math.log(2) / -math.log(1 - p) if 0 < p < 1 else None
        ratio = f"{r['median'] / expected:.2f}" if expected else "-"
        cost = f"{100 * r['search_cost']:.1f} %" if r["search_cost"] is not None else "-"
        if r.get("search_cost_cpu") is not None:
            cost += f" (CPU {100 * r['search_cost_cpu']:.1f} %)"
        bound = f"{r['boundary_max']:.2f} ({r['boundary_points']} points)" if r["boundary_max"] is not None else "-"
        lines.append(f"| {r['case']} | {r['method']} | {r.get('batch', 1)} | {r['median']:g} | {r['found']}/{r['seeds']} | {ratio} | {cost} | {bound} |")
    lines.append("")
    lines.append("| case | failing share | from | uniform random: median runs / found within budget | grid at the declared resolution: points / first failure |")
    lines.append("| --- | --- | --- | --- | --- |")
    for name, t in truths.items():
        dt = t["declared"]
        p = dt["share"]
        median = math.log(2) / -math.log(1 - p) if 0 < p < 1 else None
        chance = 1 - (1 - p) ** budget
        first = f"{dt['first']:,}" if dt["first"] is not None else "none"
        lines.append(f"| {name} | {100 * p:.3f} % | {dt['how']} | {median:.1f} / {100 * chance:.0f} % | {dt['points']:,} / {first} |")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.falsify", description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated case names")
    parser.add_argument("--methods", default=",".join(METHODS), help="comma-separated methods")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=0, help="the searches' seeds are FIRST_SEED, FIRST_SEED + 1, ... (default 0)")
    parser.add_argument("--start", type=int, default=None, help="space-filling runs first (the search block's start; default: the method's)")
    parser.add_argument("--budget", type=int, default=200)
    parser.add_argument("--batch", type=int, default=1,
                        help="runs asked and told together (default 1: the runs are in-process, one at a time, and falsify's batch is its worker count)")  # fmt: skip
    parser.add_argument("--truth", action="store_true", help="compute the ground-truth grids again and store them")
    parser.add_argument("--truth-jobs", type=int, default=1, metavar="N", help="processes for --truth's grid (default 1)")
    parser.add_argument("--sumo-loop", action="store_true", help="also compare a SUMO run in a search with a bare libsumo loop")
    parser.add_argument("--workers", type=int, default=0, metavar="N",
                        help="also run each case's search on N local workers kept for the search and on a pool started per batch")  # fmt: skip
    parser.add_argument("--workers-budget", type=int, default=60, metavar="RUNS", help="runs of each --workers search (default 60)")
    parser.add_argument("--scale", action="store_true",
                        help="only the search's own cost at scale: 20 parameters, budget 1,500, runs of 20 ms; bookkeeping against the runs; start-up")  # fmt: skip
    parser.add_argument("--startup", action="store_true", help="only the start-up of a falsify process (imports, a pool of 2, 2 runs)")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")
    args = parser.parse_args(argv)
    if args.startup:
        st = startup(7)
        sys.stdout.write(startup_text(st) + "\n")
        if args.json:
            Path(args.json).write_text(json.dumps(st, indent=2) + "\n")
        return 0
    if args.scale:
        figures = scale()
        sys.stdout.write(scale_text(figures))
        if args.json:
            Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")
        return 0
    cases = [c for c in args.cases.split(",") if c]
    t0 = time.perf_counter()
    if not available():
        print("the 'search' extra is missing: pip install -e '.[search]'", file=sys.stderr)
        return 2
    import scipy.linalg  # noqa: F401 - the gp method's model
    import scipy.special  # noqa: F401

    import_s = time.perf_counter() - t0
    truths = {c: truth(c, args.truth, args.truth_jobs) for c in cases}
    for c in cases:
        truths[c]["declared"] = declared_truth(c, truths[c])
    rows = []
    for c in cases:
        for m in args.methods.split(","):
            rows.append(search_case(c, m, args.seeds, args.budget, args.batch, args.first_seed, args.start))
            print(f"{c} {m}: median {rows[-1]['median']}, found {rows[-1]['found']}/{args.seeds}", file=sys.stderr)
    text = table(rows, truths, args.budget)
    loop = sumo_loop() if args.sumo_loop else None
    if loop:
        text += sumo_loop_text(loop)
    pools = [workers_in_new_process(c, args.workers, args.workers_budget) for c in cases] if args.workers > 0 else None
    if pools:
        text += workers_text(pools)
    text += (f"\n{platform.python_implementation()} {platform.python_version()}, {platform.machine()}; in-process runs, one after the other, batch {args.batch}"
             f"{' (one worker: the default)' if args.batch == 1 else ''}; "
             f"importing the optimiser libraries took {import_s:.2f} s once\n")  # fmt: skip
    sys.stdout.write(text)
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "truth": {k: {x: v for x, v in t.items() if x != "bits"} for k, t in truths.items()},
                                               "sumo_loop": loop, "workers": pools, "import_s": import_s}, indent=2) + "\n")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
