"""Start-up: what a command imports before it needs it (issue 36: a ``falsify`` process started in under 1 s).

The figure itself is measured in ``python -m benchmarks.falsify --scale`` (docs/performance.md, "Falsify at
scale"); here the imports that made it are guarded, in a fresh interpreter each: ``validate`` and ``run``
import none of the optional libraries (NumPy, SciPy, matplotlib, Optuna, Dask, libsumo), and a search that
ends within its space-filling start imports NumPy (the Sobol points) but not SciPy's LAPACK and special
functions, which the Gaussian-process model needs only when it first proposes a batch.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import pytest

from btgen_pytrees.falsify.sampler import available

ROOT = pathlib.Path(__file__).resolve().parent.parent
OPTIONAL = ("numpy", "scipy", "scipy.linalg", "scipy.special", "scipy.stats", "matplotlib", "optuna", "cmaes",
            "dask", "distributed", "libsumo", "traci", "pandas", "pyarrow")  # fmt: skip


def imported_after(*commands: list[str]) -> list[list[str]]:
    """The optional libraries in ``sys.modules`` after each of *commands* (``btgen_pytrees`` arguments, run
    one after another by ``cli.main`` in one fresh interpreter, their output discarded)."""
    code = (
        "import contextlib, io, json, sys\n"
        "from btgen_pytrees.cli import main\n"
        f"seen = []\n"
        f"for argv in {list(commands)!r}:\n"
        "    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):\n"
        "        code = main(argv)\n"
        "    assert code == 0, (argv, code)\n"
        f"    seen.append(sorted(m for m in {OPTIONAL!r} if m in sys.modules))\n"
        "print(json.dumps(seen))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})  # fmt: skip
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not available() and not os.environ.get("CI"),
                    reason="the 'search' extra is not installed (pip install -e '.[search]'; CI installs it)")  # fmt: skip
def test_validate_and_run_import_no_optional_library_and_a_short_search_no_scipy() -> None:
    fig1 = str(ROOT / "examples" / "fig1.json")
    island = str(ROOT / "benchmarks" / "falsify_cases" / "island_2d.json")
    after_validate, after_run, after_falsify = imported_after(
        ["validate", fig1], ["run", fig1, "--json", os.devnull],
        ["falsify", island, "--budget", "2", "--jobs", "1", "--json", os.devnull])  # fmt: skip
    assert after_validate == [] and after_run == []
    assert after_falsify == ["numpy"]  # the Sobol points; the model's SciPy waits for the model's first batch
