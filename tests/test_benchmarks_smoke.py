"""The benchmark code must keep running: every shape, the floor, the tick and schema jobs, at n=50.

This does not check speed (the suite's machine is shared and noisy); it checks
that ``python -m benchmarks.run`` still works against the current core, that
the synthetic timelines are what their names say, and that the floor rebuilds
the generated tree node for node.
"""

from __future__ import annotations

import json
import pathlib
import sys

import pytest

import btgen_pytrees

# benchmarks/ is beside the package, not inside it: importable under
# `python -m pytest` (the working directory is on sys.path) but not under a bare
# `pytest`, hence the repository root here
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
from benchmarks import floor, measure, run, timelines  # noqa: E402

N = 50


@pytest.mark.parametrize("shape", list(timelines.SHAPES))
def test_every_shape_is_a_valid_case_of_n_entries(shape: str) -> None:
    case = btgen_pytrees.load(timelines.build(shape, N))
    assert len(case.entries) == N
    edges = btgen_pytrees.timeline(case).number_of_edges()
    expected = {"chain": N - 1, "comb": N - 1, "fan_out": N - 1, "fan_in": N - 1, "random": 2 * N - 3}
    assert edges == expected[shape]


def test_random_dag_is_deterministic() -> None:
    assert timelines.random_dag(N) == timelines.random_dag(N)
    assert timelines.random_dag(N) != timelines.random_dag(N, seed=7)


def test_floor_rebuilds_the_same_shape() -> None:
    root = btgen_pytrees.generate(btgen_pytrees.load(timelines.comb(N)))
    shape = floor.capture(root)
    rebuilt = floor.build(shape)
    assert floor.capture(rebuilt).counts() == shape.counts()
    assert [n for _, _, n in floor.capture(rebuilt).nodes] == [n for _, _, n in shape.nodes]
    assert floor.count(rebuilt) == len(shape) and floor.depth(rebuilt) == floor.depth(root)


def test_one_command_inline(tmp_path, capsys, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    # a full collection before every repeat steadies real measurements; in the
    # test process's large heap it would be most of this test's time
    monkeypatch.setattr(measure, "_fresh", lambda: None)
    out = tmp_path / "bench.json"
    argv = ["--inline", "--sizes", "5", str(N), "--repeats", "1", "--tick-n", str(N), "--schema-n", str(N),
            "--json", str(out)]  # fmt: skip
    assert run.main(argv) == 0
    text = capsys.readouterr().out
    assert "total/floor" in text and "run/bare" in text and "the loader's validator" in text
    document = json.loads(out.read_text())
    rows = document["generation"]
    assert {(r["shape"], r["n"]) for r in rows} == {(s, n) for s in timelines.SHAPES for n in (5, N)}
    for row in rows:
        assert row["status"] == "ok", row
        assert row["total"] >= row["load"] > 0 and row["floor"] > 0 and row["peak"] > 0 and row["floor_peak"] > 0
        assert row["nodes"] == sum(row["counts"].values())
    assert document["ticks"]["verdict"] == "pass" and document["ticks"]["status"] == "ok"
    assert {t["target"] for t in document["targets"]} == {"total/floor", "scaling", "peak/floor", "tick/bare"}


def test_collector_off_and_no_memory(monkeypatch, capsys) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(measure, "_fresh", lambda: None)
    argv = ["--inline", "--sizes", "20", "--shapes", "chain", "--gc", "off", "--no-memory", "--repeats", "1",
            "--tick-n", "0", "--schema-n", "0"]  # fmt: skip
    assert run.main(argv) == 0
    assert "garbage collector off" in capsys.readouterr().out


@pytest.mark.skipif(__import__("importlib").util.find_spec("libsumo") is None and not __import__("os").environ.get("CI"),
                    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)")  # fmt: skip
def test_the_bare_libsumo_loop_does_the_steps_of_the_search_s_runs() -> None:
    """benchmarks.falsify --sumo-loop compares like with like: its hand-written libsumo loop runs as many
    SUMO steps as the case's runs at the same settings - the search's runs on a simulation kept open and set
    back between them (and both sides are measured)."""
    from benchmarks import falsify

    loop = falsify.sumo_loop(points=4, rounds=1)
    assert loop["steps"]["bare"] == loop["steps"]["search"] > 4 * 20
    assert loop["runs"] == 4 and min(loop[k] for k in ("search_ms", "bare_ms", "search_fresh_ms", "bare_load_ms")) > 0
    assert set(loop["breakdown_ms"]) == set(loop["breakdown_fresh_ms"]) == {
        "validate", "system and tree", "SUMO start+close", "SUMO steps", "adapter", "tree, collector"}  # fmt: skip


def test_the_workers_benchmark_runs_one_search_both_ways() -> None:
    """benchmarks.falsify --workers: the search on workers kept for it and on a pool started per batch, each in
    a new process, is the same search (the benchmark raises otherwise), and both are timed."""
    pytest.importorskip("optuna")
    from benchmarks import falsify

    row = falsify.workers_in_new_process("island_2d", 2, 12, rounds=1)
    assert row["runs"] == 12 and row["kept_s"] > 0 and row["per_batch_s"] > 0


@pytest.mark.skipif(__import__("importlib").util.find_spec("libsumo") is None and not __import__("os").environ.get("CI"),
                    reason="libsumo is not installed (pip install -e '.[sumo]'; CI installs it)")  # fmt: skip
def test_a_small_run_taken_apart(capsys) -> None:  # type: ignore[no-untyped-def]
    """benchmarks.small_run: the parts of cut_in_3d's runs (SUMO kept and started per run) and the steady tick."""
    from benchmarks import small_run

    result = small_run.measure(points=2, rounds=1, ticks=50)
    for name in ("kept", "fresh"):
        assert set(result[name]) == {*small_run.PARTS, "python"} and min(result[name].values()) >= 0
        assert result[name]["python"] == pytest.approx(sum(result[name][p] for p in small_run.PYTHON))
    assert result["steady_tick_us"] > 0
    assert small_run.main(["--rounds", "1", "--ticks", "20"]) == 0
    assert "steady tick" in capsys.readouterr().out


@pytest.mark.skipif(not pathlib.Path(__import__("os").environ.get("BTGEN_OSC_CORPUS", "/work/shared/corpus/openscenario/alks"))
                    .joinpath("logical_scenarios").is_dir(), reason="the ALKS corpus is not on this machine")  # fmt: skip
def test_the_openscenario_corpus_benchmark_takes_a_variation_apart(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """benchmarks.openscenario: a distribution's variation split into its parts, and the projection."""
    pytest.importorskip("libsumo")
    from benchmarks import openscenario

    out = tmp_path / "o.json"
    assert openscenario.main(["--skip-commands", "--sample", "1", "--only", "4_6_2", "--json", str(out)]) == 0
    (row,) = json.loads(out.read_text())["files"]
    assert row["count"] == 2 and row["sampled"] == 1 and set(row["mean"]) == set(openscenario.PARTS)
    assert row["per variation"] == pytest.approx(sum(row["mean"].values())) and row["mean"]["sumo"] > 0
