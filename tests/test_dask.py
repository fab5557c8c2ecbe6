"""Sweeps and batches on a real Dask cluster: a ``distributed.LocalCluster`` with worker processes.

No mock: the scheduler, the nannies and the worker processes are real, the
tasks are pickled and run in other processes, and one test kills a worker
process (SIGKILL) in the middle of a sweep. The tests skip only when
``distributed`` is missing and ``CI`` is unset; ``.ci/run`` installs the
``dask`` extra. One cluster is shared by the module (it takes seconds to start).
"""

from __future__ import annotations

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
from helpers import case, crit, entry

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


def cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "btgen_pytrees", *args], capture_output=True, text=True,
                          timeout=300, cwd=ROOT, env={**os.environ, **(env or {})})  # fmt: skip


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
    from btgen_pytrees import batch
    from btgen_pytrees.sweep import load_sweep
    from btgen_pytrees.sweep.executors import DaskExecutor
    from btgen_pytrees.sweep.jobs import VariationOutcome, job_variation

    sweep = load_sweep(slow_sweep(60))
    variations = list(sweep)
    seen: list[str] = []
    killed: list[int] = []

    def on_result(outcome: batch.Outcome) -> None:
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
        outcomes = batch.process(job_variation, [((), sweep.source, v.document) for v in variations],
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
    from btgen_pytrees.sweep.executors import DaskExecutor
    from btgen_pytrees.sweep.jobs import job_variation

    sweep = load_sweep(slow_sweep(40))
    calls = [partial(job_variation, v.label, (), sweep.source, v.document) for v in sweep]
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
    from btgen_pytrees.sweep.executors import DaskExecutor, DaskUnavailable

    with pytest.raises(DaskUnavailable, match="cannot reach the Dask scheduler at tcp://127.0.0.1:9"):
        DaskExecutor("tcp://127.0.0.1:9", timeout=1).connect()
    result = cli("run", str(FIG1_SWEEP), "--executor", "dask", "--json", str(tmp_path / "r.json"),
                 env={"DASK_SCHEDULER_ADDRESS": ""})  # fmt: skip
    assert result.returncode == 2 and "--executor dask needs --scheduler" in result.stderr
    assert not (tmp_path / "r.json").exists()
