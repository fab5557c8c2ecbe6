"""Sweeps and batches on a real Dask cluster: a ``distributed.LocalCluster`` with worker processes.

No mock: the scheduler, the nannies and the worker processes are real, the
tasks are pickled and run in other processes, and one test kills a worker
process (SIGKILL) in the middle of a sweep. The tests skip only when
``distributed`` is missing and ``CI`` is unset; ``.ci/run`` installs the
``dask`` extra. One cluster is shared by the module (it takes seconds to start).
"""

from __future__ import annotations

import importlib.util
import json
import logging
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time
from typing import Any, Iterator

import pytest
from helpers import DYING_PLUGIN, case, crit, entry

try:
    import distributed
except ImportError:  # pragma: no cover - CI installs the extra
    distributed = None

pytestmark = pytest.mark.skipif(
    distributed is None and not os.environ.get("CI"),
    reason="distributed is not installed (pip install -e '.[dask]'; CI installs it)",
)

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIG1_SWEEP = ROOT / "examples" / "fig1_sweep.json"


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL) as c:  # fmt: skip
        yield c


@pytest.fixture(scope="module")
def client(cluster: Any) -> Iterator[Any]:
    from distributed import Client

    with Client(cluster.scheduler_address, set_as_default=False) as c:
        yield c


def cli(*args: str, env: dict[str, str] | None = None, cwd: pathlib.Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env={**os.environ, **(env or {})})  # fmt: skip


def btgen_tasks(client: Any) -> list[str]:
    """Keys of this package's tasks the scheduler still holds."""

    def keys(dask_scheduler: Any) -> list[str]:
        return [str(k) for k in dask_scheduler.tasks if str(k).startswith("btgen-")]

    return client.run_on_scheduler(keys)  # type: ignore[no-any-return]


def slow_sweep(n: int, tick: float = 0.001) -> dict[str, Any]:
    """*n* variations of a case whose run takes about 10-30 ms here (1000 ticks), durations 1.000 s, 1.001 s, ..."""
    data = case(entry("A", duration="$d"), criteria=[crit("F", "final", "true")], tick=tick, timeout=5)
    data["parameters"] = {"d": 1}
    data["variations"] = {"d": {"from": 1, "to": 1 + (n - 1) * 0.001, "step": 0.001}}
    return data


def test_a_sweep_on_the_cluster_reports_exactly_what_the_local_pool_does(cluster: Any, tmp_path: pathlib.Path) -> None:
    local = cli("run", str(FIG1_SWEEP), "--jobs", "1", "--json", str(tmp_path / "l.json"), "--junit", str(tmp_path / "l.xml"))
    dask = cli("run", str(FIG1_SWEEP), "--executor", "dask", "--scheduler", cluster.scheduler_address,
               "--json", str(tmp_path / "d.json"), "--junit", str(tmp_path / "d.xml"))  # fmt: skip
    assert local.returncode == dask.returncode == 1, dask.stderr
    assert (tmp_path / "l.json").read_bytes() == (tmp_path / "d.json").read_bytes()
    assert (tmp_path / "l.xml").read_bytes() == (tmp_path / "d.xml").read_bytes()
    assert local.stdout == dask.stdout and "18 pass, 10 fail" in dask.stdout


def test_the_scheduler_address_may_come_from_the_environment(cluster: Any, tmp_path: pathlib.Path) -> None:
    path = tmp_path / "s.json"
    path.write_text(json.dumps(slow_sweep(4, tick=0.1)))
    result = cli("run", str(path), "--executor", "dask", env={"DASK_SCHEDULER_ADDRESS": cluster.scheduler_address})
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("t: 4 variations of d: 4 pass")


def test_a_batch_of_files_runs_on_the_cluster_and_outputs_are_written_here(cluster: Any, tmp_path: pathlib.Path) -> None:
    suite = tmp_path / "suite"
    suite.mkdir()
    shutil.copy(ROOT / "examples" / "fig1.json", suite / "a_pass.json")
    shutil.copy(ROOT / "examples" / "fig1_failing.json", suite / "b_fail.json")
    (suite / "c_invalid.json").write_text(json.dumps(case(entry("A", ["Z"]))))
    (suite / "d_broken.json").write_text("{not json")
    out_local, out_dask = tmp_path / "local", tmp_path / "dask"
    local = cli("run", str(suite), "--jobs", "2", "--out-dir", str(out_local))
    dask = cli("run", str(suite), "--executor", "dask", "--scheduler", cluster.scheduler_address, "--out-dir", str(out_dask))
    assert local.returncode == dask.returncode == 2
    assert local.stdout == dask.stdout and "4 files: 1 ok, 1 fail, 2 invalid" in dask.stdout
    assert f"{suite}/c_invalid.json: /execute/0/after/0: unknown id 'Z'" in dask.stderr
    assert sorted(p.name for p in out_dask.iterdir()) == sorted(p.name for p in out_local.iterdir())
    for p in out_local.iterdir():
        assert (out_dask / p.name).read_bytes() == p.read_bytes()


def test_a_worker_killed_mid_sweep_loses_nothing_and_counts_nothing_twice(cluster: Any, client: Any) -> None:
    from btgen_pytrees import parallel
    from btgen_pytrees.sweep import load_sweep
    from btgen_pytrees.parallel.dask import DaskExecutor
    from btgen_pytrees.sweep.jobs import RunOptions, VariationOutcome, job_variation

    sweep = load_sweep(slow_sweep(60))
    variations = list(sweep)
    seen: list[str] = []
    killed: list[int] = []

    def on_result(outcome: parallel.Outcome) -> None:
        seen.append(outcome.path)
        if killed:
            return
        processing = client.processing()  # worker address -> task keys it is running now
        busy = [address for address, keys in processing.items() if any(str(k).startswith("btgen-") for k in keys)]
        if busy:
            pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
            os.kill(pid, signal.SIGKILL)  # as the out-of-memory killer would
            killed.append(pid)

    with DaskExecutor(cluster.scheduler_address, chunk=3) as executor:
        outcomes = parallel.process(job_variation, [(RunOptions(), sweep.source, v.document) for v in variations],
                                 [v.label for v in variations], executor=executor, on_result=on_result)  # fmt: skip
    assert killed, "no worker was busy to kill"
    assert sorted(seen) == sorted(v.label for v in variations)  # every result once
    assert [o.path for o in outcomes] == [v.label for v in variations]
    assert all(isinstance(o, VariationOutcome) and o.code == 0 for o in outcomes), [o.summary for o in outcomes if o.code]
    assert [round(o.row["duration"], 3) for o in outcomes] == [round(1 + k * 0.001, 3) for k in range(60)]
    client.wait_for_workers(2, timeout=60)  # the nanny restarted it, for the next tests


def test_stopping_early_cancels_what_was_submitted(cluster: Any, client: Any) -> None:
    from functools import partial

    from btgen_pytrees.sweep import load_sweep
    from btgen_pytrees.parallel.dask import DaskExecutor
    from btgen_pytrees.sweep.jobs import RunOptions, job_variation

    sweep = load_sweep(slow_sweep(40))
    calls = [partial(job_variation, v.label, RunOptions(), sweep.source, v.document) for v in sweep]
    with DaskExecutor(cluster.scheduler_address, chunk=1) as executor:
        stream = executor.map_unordered(calls)
        next(stream)
        assert btgen_tasks(client)  # the rest is queued or running on the cluster
        stream.close()  # what Ctrl-C does to the loop
    deadline = time.monotonic() + 10
    while btgen_tasks(client) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert btgen_tasks(client) == []


def test_ctrl_c_stops_a_sweep_on_the_cluster(cluster: Any, client: Any, tmp_path: pathlib.Path) -> None:
    path = tmp_path / "long.json"
    path.write_text(json.dumps(slow_sweep(400)))
    report = tmp_path / "r.json"
    proc = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", str(path), "--executor", "dask",
                             "--scheduler", cluster.scheduler_address, "--json", str(report)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    deadline = time.monotonic() + 60
    while not btgen_tasks(client) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted by SIGINT" in err and "Traceback" not in err
    assert not report.exists()
    deadline = time.monotonic() + 10
    while btgen_tasks(client) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert btgen_tasks(client) == []


def test_an_unreachable_scheduler_is_a_usage_error_before_anything_runs(tmp_path: pathlib.Path) -> None:
    from btgen_pytrees.parallel.dask import DaskExecutor, DaskUnavailable

    with pytest.raises(DaskUnavailable, match="cannot reach the Dask scheduler at tcp://127.0.0.1:9"):
        DaskExecutor("tcp://127.0.0.1:9", timeout=1).connect()
    result = cli("run", str(FIG1_SWEEP), "--executor", "dask", "--json", str(tmp_path / "r.json"),
                 env={"DASK_SCHEDULER_ADDRESS": ""})  # fmt: skip
    assert result.returncode == 2 and "--executor dask needs --scheduler" in result.stderr
    assert not (tmp_path / "r.json").exists()


# ---------------------------------------------------------------------------
# issue 19 items 7-8, issue 20 items 1, 6, 8: workers elsewhere, threads, options, a lost scheduler, addresses

needs_sumo = pytest.mark.skipif(
    importlib.util.find_spec("libsumo") is None and not os.environ.get("CI"),
    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)",
)

HIDE = '''
"""Worker preload: run in another directory, and make the client's case folder invisible to this process."""
import os
import sys


def dask_setup(worker):
    hidden = os.environ["BTGEN_TEST_HIDDEN"]
    os.chdir(os.environ["BTGEN_TEST_CWD"])

    def hook(event, args):
        if event in ("open", "os.listdir", "os.scandir", "os.chdir") and args and isinstance(args[0], (str, bytes)):
            path = os.path.abspath(os.fsdecode(args[0]))
            if path == hidden or path.startswith(hidden + os.sep):
                raise PermissionError(13, "this worker shares no disk with the client", path)

    sys.addaudithook(hook)
'''

MARK_PLUGIN = '''
import py_trees
from py_trees.common import Status


class Mark(py_trees.behaviour.Behaviour):
    def __init__(self, entry, env):
        super().__init__(name=entry.name)
        self.level = entry.params.get("level")

    def update(self):
        return Status.SUCCESS if self.level <= 2 else Status.FAILURE


def register(registry):
    registry.register("mark", lambda entry, env: Mark(entry, env), kind="behavior")
'''


@pytest.fixture(scope="module")
def elsewhere(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, pathlib.Path]]:
    """A LocalCluster of 2 worker processes with 2 threads each, running in another directory, that cannot
    read the client's case folder (an audit hook refuses every open there); yields it and that folder."""
    from distributed import LocalCluster

    base = tmp_path_factory.mktemp("elsewhere")
    client_dir, worker_dir = base / "client", base / "worker"
    client_dir.mkdir()
    worker_dir.mkdir()
    for name in ("cut_in_sweep.json", "cut_in.json", "acc_hard_brake.json", "cut_in.sumocfg", "cut_in.rou.xml",
                 "acc.sumocfg", "acc.rou.xml", "road.net.xml"):
        shutil.copy(ROOT / "examples" / "sumo" / name, client_dir / name)
    (client_dir / "mark_plugin.py").write_text(MARK_PLUGIN)
    preload = base / "hide.py"
    preload.write_text(HIDE)
    env = {"BTGEN_TEST_HIDDEN": str(client_dir), "BTGEN_TEST_CWD": str(worker_dir)}
    with LocalCluster(n_workers=2, threads_per_worker=2, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL, preload=[str(preload)], env=env) as c:  # fmt: skip
        yield c, client_dir


def test_the_workers_elsewhere_really_cannot_see_the_case_folder(elsewhere: tuple[Any, pathlib.Path]) -> None:
    from distributed import Client

    cluster, client_dir = elsewhere

    def look(path: str) -> str:
        try:
            with open(path, "rb"):
                return "read"
        except OSError as exc:
            return f"{os.getcwd()}: {type(exc).__name__}"

    with Client(cluster.scheduler_address, set_as_default=False) as c:
        seen = c.run(look, str(client_dir / "cut_in.sumocfg"))
        threads = c.nthreads()
    assert len(seen) == 2 and set(seen.values()) == {f"{client_dir.parent / 'worker'}: PermissionError"}
    assert sorted(threads.values()) == [2, 2]


@needs_sumo
def test_a_sumo_sweep_from_a_relative_path_on_workers_elsewhere_with_two_threads(elsewhere: tuple[Any, pathlib.Path],
                                                                               tmp_path: pathlib.Path) -> None:  # fmt: skip
    """Issue 19 items 7 and 8: the workers share neither the client's directory nor its disk, and run 2 threads
    each; every verdict, and the reports to the byte, are the local pool's."""
    cluster, client_dir = elsewhere
    local = cli("run", "cut_in_sweep.json", "--jobs", "2", "--json", str(tmp_path / "l.json"), "--junit",
                str(tmp_path / "l.xml"), cwd=client_dir)  # fmt: skip
    dask = cli("run", "cut_in_sweep.json", "--executor", "dask", "--scheduler", cluster.scheduler_address,
               "--json", str(tmp_path / "d.json"), "--junit", str(tmp_path / "d.xml"), cwd=client_dir)  # fmt: skip
    assert local.returncode == dask.returncode == 1, dask.stderr
    rows = json.loads((tmp_path / "d.json").read_text())["rows"]
    assert len(rows) == 60 and {r["verdict"] for r in rows} == {"pass", "fail"}, rows[0]
    assert (tmp_path / "l.json").read_bytes() == (tmp_path / "d.json").read_bytes()
    assert (tmp_path / "l.xml").read_bytes() == (tmp_path / "d.xml").read_bytes()


@needs_sumo
def test_each_worker_keeps_its_sumo_between_tasks_and_lets_it_go_when_the_sweep_ends(elsewhere: tuple[Any, pathlib.Path]) -> None:
    """A sweep's (and a search's) executor keeps SUMO open in each worker process from one task to the
    next (``keep``: it was started for every run, a task being one variation), with 2 threads per worker,
    and every row is the local pool's; when the executor closes, no worker keeps one any more."""
    from distributed import Client

    from btgen_pytrees.parallel.dask import DaskExecutor
    from btgen_pytrees.sweep import load_sweep
    from btgen_pytrees.sweep.jobs import RunOptions
    from btgen_pytrees.sweep.runs import run_variations
    from btgen_pytrees.systems.sumo import keep_simulations, kept_simulation, release_simulations

    cluster, client_dir = elsewhere
    sweep = load_sweep(str(client_dir / "cut_in_sweep.json"))
    variations = list(sweep)[:16]
    local = run_variations(sweep, variations, RunOptions(), None, 2)
    with Client(cluster.scheduler_address, set_as_default=False) as client:
        executor = DaskExecutor(cluster.scheduler_address, keep=(keep_simulations, release_simulations))
        try:
            first = run_variations(sweep, variations[:8], RunOptions(), None, 1, executor)
            during = client.run(kept_simulation)
            second = run_variations(sweep, variations[8:], RunOptions(), None, 1, executor)
        finally:
            executor.close()
        after = client.run(kept_simulation)
    assert [o.row for o in first + second] == [o.row for o in local]  # type: ignore[attr-defined]
    assert any(key is not None for key in during.values()), during
    assert all(key is None for key in after.values()), after


@needs_sumo
def test_a_batch_of_sumo_cases_runs_on_workers_elsewhere(elsewhere: tuple[Any, pathlib.Path], tmp_path: pathlib.Path) -> None:
    cluster, client_dir = elsewhere
    files = ["cut_in.json", "acc_hard_brake.json"]
    local = cli("run", *files, "--out-dir", str(tmp_path / "l"), cwd=client_dir)
    dask = cli("run", *files, "--executor", "dask", "--scheduler", cluster.scheduler_address, "--out-dir",
               str(tmp_path / "d"), cwd=client_dir)  # fmt: skip
    assert local.returncode == dask.returncode, dask.stdout + dask.stderr
    assert "INVALID" not in dask.stdout and "ERROR" not in dask.stdout
    assert sorted(p.name for p in (tmp_path / "d").iterdir()) == sorted(p.name for p in (tmp_path / "l").iterdir())
    for p in (tmp_path / "l").iterdir():
        assert (tmp_path / "d" / p.name).read_bytes() == p.read_bytes()


def test_plugin_files_and_run_options_reach_every_variation_on_workers_elsewhere(elsewhere: tuple[Any, pathlib.Path],
                                                                                tmp_path: pathlib.Path) -> None:  # fmt: skip
    """A --plugin file is sent to the workers; --require-complete and --max-work reach each variation (issue 20 item 1)."""
    cluster, client_dir = elsewhere
    data = case(entry("M", action="mark", level="$w"), entry("A", duration="$d"), entry("H", ["A"]),
                criteria=[crit("F", "final", "true", at=2)], tick="$dt", timeout=100)  # fmt: skip
    data["parameters"] = {"w": 1, "d": 1, "dt": 0.1}
    data["variations"] = {"w": [1, 3], "d": [1, 3], "dt": [0.1, 0.001]}
    (client_dir / "opts.json").write_text(json.dumps(data))
    common = ["opts.json", "--plugin", "mark_plugin.py", "--require-complete", "--max-work", "20000"]
    for engine, extra in (("l", ["--jobs", "2"]), ("d", ["--executor", "dask", "--scheduler", cluster.scheduler_address])):
        result = cli("run", *common, *extra, "--json", str(tmp_path / f"{engine}.json"), cwd=client_dir)
        assert result.returncode == 1, result.stderr
    rows = json.loads((tmp_path / "d.json").read_text())["rows"]
    verdicts = {r["label"]: r["verdict"] for r in rows}
    assert verdicts["w=1,d=1,dt=0.1"] == "pass" and verdicts["w=3,d=1,dt=0.1"] == "fail"  # the plugin's leaf ran
    assert verdicts["w=1,d=3,dt=0.1"] == "fail"  # --require-complete: H never ran, A was stopped at 2 s
    assert verdicts["w=1,d=1,dt=0.001"] == "error"  # --max-work: 2000 ticks x 13 > 20000
    assert "work budget" in next(r["message"] for r in rows if r["label"] == "w=1,d=1,dt=0.001")
    assert (tmp_path / "l.json").read_bytes() == (tmp_path / "d.json").read_bytes()


@pytest.mark.parametrize("address, why", [
    ("garbage", "not a scheduler address; expected tcp://HOST:PORT"),
    ("tcp://127.0.0.1:99999", "port 99999 is out of range"),
    ("ucx://127.0.0.1:8786", "the ucx:// protocol is not supported"),
    ("tls://127.0.0.1:8786", "tls:// needs Dask's TLS settings"),
])  # fmt: skip
def test_a_malformed_or_unsupported_scheduler_address_is_refused_at_once(address: str, why: str, tmp_path: pathlib.Path) -> None:
    """Issue 20 item 8: exit 2, one line, nothing run, no traceback; checked before anything else (the sweep's
    variations are validated after it) and without connecting (which took 21 s and ended in a traceback)."""
    result = cli("run", str(FIG1_SWEEP), "--executor", "dask", "--scheduler", address, "--json", str(tmp_path / "r.json"))
    assert result.returncode == 2, result.stderr
    assert why in result.stderr and "Traceback" not in result.stderr and result.stderr.count("\n") == 1
    assert not (tmp_path / "r.json").exists()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**json.loads(FIG1_SWEEP.read_text()), "variations": {"top_speed": [1, 1]}}))
    first = cli("run", str(bad), "--executor", "dask", "--scheduler", address)
    assert first.returncode == 2 and why in first.stderr and "listed twice" not in first.stderr


def test_a_scheduler_that_dies_mid_sweep_keeps_the_finished_rows(tmp_path: pathlib.Path) -> None:
    """Issue 20 item 6: one line says what happened, finished rows are kept, the rest are errors, exit 3."""
    from distributed import Client

    scheduler_file = tmp_path / "scheduler.json"
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                  "--port", "0", "--no-dashboard", "--scheduler-file", str(scheduler_file)],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    worker = None
    try:
        deadline = time.monotonic() + 60
        address = None
        while address is None and time.monotonic() < deadline:  # the file may exist before its text is written
            try:
                address = json.loads(scheduler_file.read_text())["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.1)
        assert address is not None, "the scheduler never wrote its address"
        worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                   "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
        path = tmp_path / "long.json"
        path.write_text(json.dumps(slow_sweep(800)))  # 13 tasks of about 1 s here
        report = tmp_path / "r.json"
        with Client(address, set_as_default=False) as watcher:
            watcher.wait_for_workers(1, timeout=60)
            proc = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", str(path), "--executor", "dask",
                                     "--scheduler", address, "--json", str(report)],
                                    cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip

            def finished(dask_scheduler: Any) -> int:
                return sum(1 for k, t in dask_scheduler.tasks.items() if str(k).startswith("btgen-") and t.state == "memory")

            deadline = time.monotonic() + 120
            while watcher.run_on_scheduler(finished) < 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(2)  # the client fetches the results of finished tasks
            scheduler.kill()  # SIGKILL: as a lost machine would
        out, err = proc.communicate(timeout=180)
    finally:
        for p in (worker, scheduler):
            if p is not None:
                p.kill()
                p.wait(30)
    assert proc.returncode == 3, err
    assert "Traceback" not in err and "NoneType" not in out + err
    (line,) = err.splitlines()
    assert line.startswith(f"btgen_pytrees: the connection to the Dask scheduler at {address} was lost after ")
    assert line.endswith(" of 800 runs had finished; the rest are reported as errors")
    rows = json.loads(report.read_text())["rows"]
    passed = [r for r in rows if r["verdict"] == "pass"]
    assert len(rows) == 800 and 0 < len(passed) < 800
    assert f" {len(passed)} of 800 runs" in line
    assert {r["message"] for r in rows if r["verdict"] != "pass"} == {
        f"internal error: not run: the connection to the Dask scheduler at {address} was lost"}


def test_a_file_that_cannot_be_read_says_the_same_on_the_cluster(cluster: Any, tmp_path: pathlib.Path) -> None:
    """The client reads a batch's files for the cluster with the reader the local workers use."""
    suite = tmp_path / "suite"
    suite.mkdir()
    shutil.copy(ROOT / "examples" / "fig1.json", suite / "a_pass.json")
    os.mkfifo(suite / "b_fifo.json")  # would block a reader that opened it
    (suite / "c_big.json").write_bytes(b" " * (16 * 1024 * 1024 + 1))
    local = cli("run", str(suite), "--jobs", "2")
    dask = cli("run", str(suite), "--executor", "dask", "--scheduler", cluster.scheduler_address)
    assert local.returncode == dask.returncode == 2
    assert f"{suite}/b_fifo.json: /: not a regular file (a pipe or socket)" in dask.stderr
    assert f"{suite}/c_big.json: /: file is 16777217 bytes; the limit is 16777216" in dask.stderr
    assert local.stdout == dask.stdout and sorted(local.stderr.splitlines()) == sorted(dask.stderr.splitlines())


def test_user_code_that_kills_every_worker_costs_its_own_runs_only(tmp_path: pathlib.Path) -> None:
    """A plugin leaf that kills its worker process kills the next one too when the task is tried again, until the
    scheduler gives up on it (KilledWorker) - and with every worker that held them, the files shipped for the run
    (the plugin file) are lost: the tasks that needed them were cancelled, and the sweep ended with an internal
    error (FutureCancelledError), no report written; a search's next batch could not ship its files while the
    workers were restarting (TimeoutError). Now the cancelled tasks run again with the files in the task, and a
    search's next batch waits for a worker. And a task the scheduler gave up on (KilledWorker) may only have waited on
    a worker beside the killing one: its runs are tried again one at a time, so only the killing run is an error. The
    files now reach the workers as a worker plugin (restarted workers install them too): no task depends on data the
    cluster can lose."""
    import dask
    from distributed import Client, LocalCluster

    from btgen_pytrees.parallel.dask import KILLED

    plugin = tmp_path / "killing_plugin.py"
    plugin.write_text(DYING_PLUGIN)
    data = case(entry("A", action="maybe_die", when="$w"), criteria=[crit("F", "final", "true")])
    # a LocalCluster closes for good a worker that is not back 15 s after it was lost (lost-worker-timeout),
    # which a worker restarting at that moment after the next kill is not: the cluster then shrank mid-test
    with dask.config.set({"distributed.deploy.lost-worker-timeout": "1h"}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                         silence_logs=logging.CRITICAL) as own, Client(own.scheduler_address, set_as_default=False) as client:  # fmt: skip
        sweep = tmp_path / "s.json"
        sweep.write_text(json.dumps({**data, "parameters": {"w": 0}, "variations": {"w": list(range(1, 41))}}))
        result = cli("run", str(sweep), "--plugin", str(plugin), "--executor", "dask", "--scheduler",
                     own.scheduler_address, "--json", str(tmp_path / "r.json"))  # fmt: skip
        assert result.returncode == 1, result.stderr  # the killing run is its error, as on the local pool
        rows = json.loads((tmp_path / "r.json").read_text())["rows"]
        assert [r["label"] for r in rows] == [f"w={k}" for k in range(1, 41)]
        verdicts = {r["label"]: r["verdict"] for r in rows}
        # chunks of 3 variations (40 over 2 workers x 8): w=3 kills every worker that runs w=1..3, and the tasks
        # queued beside it; each of their runs is tried alone after, so only w=3 itself is an error
        # the same words every time: Dask's own message names the task's random key and a worker's port
        assert verdicts["w=3"] == "error" and rows[2]["message"] == f"w=3: error: {KILLED}"
        assert verdicts["w=5"] == "error" and "SystemExit" in rows[4]["message"]
        assert [k for k, v in verdicts.items() if v != "pass"] == ["w=3", "w=5"]
        # the local pool's verdicts (and exit code): it too runs a dead chunk's variations again one by one
        local = cli("run", str(sweep), "--plugin", str(plugin), "--jobs", "2", "--json", str(tmp_path / "l.json"))
        assert local.returncode == 1, local.stderr
        assert {r["label"]: r["verdict"] for r in json.loads((tmp_path / "l.json").read_text())["rows"]} == verdicts
        client.wait_for_workers(2, timeout=60)
        search = tmp_path / "f.json"
        search.write_text(json.dumps({**data, "parameters": {"w": 1}, "variations": {"w": {"from": 0, "to": 200, "step": 0.5}},
                                      "search": {"method": "random", "budget": 12, "batch": 4}}))  # fmt: skip
        result = cli("falsify", str(search), "--plugin", str(plugin), "--executor", "dask", "--scheduler",
                     own.scheduler_address, "--json", str(tmp_path / "f.report.json"))  # fmt: skip
        assert result.returncode == 1, result.stderr
        runs = json.loads((tmp_path / "f.report.json").read_text())["runs"]
        assert len(runs) == 12
        killed = [r for r in runs if r["parameters"]["w"] > 190]
        assert killed and all(r["verdict"] == "error" and r["message"].endswith(f": error: {KILLED}") for r in killed)
        assert all(r["verdict"] == "pass" for r in runs if r["parameters"]["w"] <= 190), [(r["index"], r["parameters"], r["verdict"], r.get("message")) for r in runs]
        # the files reached the restarted workers as a worker plugin, which each command removed as it ended
        assert not [name for name in client.run_on_scheduler(_worker_plugins) if name.startswith("btgen")]


def _worker_plugins(dask_scheduler: Any) -> list[str]:
    return list(dask_scheduler.worker_plugins)


SLOW_INSTALL = '''
"""Worker preload: writing a shipped file takes 3 s (as 60 MB of SUMO network and routes to a busy disk would)."""
import sys
import time


def dask_setup(worker):
    def hook(event, args):
        if event == "open" and args and isinstance(args[0], str) and "/.btgen-files-" in args[0]:
            time.sleep(3)

    sys.addaudithook(hook)
'''


def test_ctrl_c_while_the_workers_install_the_files_leaves_no_plugin_on_the_scheduler(tmp_path: pathlib.Path) -> None:
    """The scheduler holds a files plugin as soon as it gets it, then waits for every worker to install the files:
    a Ctrl-C in that wait left the plugin registered for good (the executor recorded its name only once the
    registration returned), and every worker that joined the cluster later installed those files again."""
    from distributed import Client, LocalCluster

    preload = tmp_path / "slow.py"
    preload.write_text(SLOW_INSTALL)
    (tmp_path / "mark_plugin.py").write_text(MARK_PLUGIN)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(slow_sweep(4)))
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL, preload=[str(preload)]) as own, \
            Client(own.scheduler_address, set_as_default=False) as client:  # fmt: skip
        proc = subprocess.Popen([sys.executable, "-m", "btgen_pytrees", "run", str(path), "--plugin",
                                 str(tmp_path / "mark_plugin.py"), "--executor", "dask", "--scheduler",
                                 own.scheduler_address, "--json", str(tmp_path / "r.json")],
                                cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
        deadline = time.monotonic() + 60
        while not client.run_on_scheduler(_btgen_plugins) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert client.run_on_scheduler(_btgen_plugins), "the command never shipped its files"
        proc.send_signal(signal.SIGINT)  # the worker is still installing them (3 s)
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 130, err
        assert not (tmp_path / "r.json").exists()
        assert client.run_on_scheduler(_btgen_plugins) == []


def _btgen_plugins(dask_scheduler: Any) -> list[str]:
    return [name for name in dask_scheduler.worker_plugins if name.startswith("btgen")]
