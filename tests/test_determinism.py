"""Same input, same bytes: every output of a run and of ``show`` is independent of ``PYTHONHASHSEED``.

Issue 10, defect 7: the JSON report's ``oracles[].values`` took its key order from a
frozenset of signal names, so it changed from one process to the next. Each output
is produced in fresh interpreters with different hash seeds and compared byte for byte.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

from helpers import case, crit, entry

SEEDS = ("0", "1", "4242")
MANY = " + ".join(f"s{i}" for i in range(8))


def _case() -> dict:  # type: ignore[type-arg]
    signals = {f"s{i}": i for i in range(8)}
    return case(
        entry("A", action="ramp", signal="s0", to=40, duration=1),
        entry("B", ["A"], action="until", expect=f"{MANY} > 1000", timeout=0.5),
        entry("C", ["A"], duration=0.2),
        signals=signals,
        criteria=[crit("R", "record", f"{MANY} < 60"), crit("F", "final", f"{MANY} >= 0 && s7 == 7"),
                  crit("P", "period", "s1 + s2 + s3 + s4 + s5 + s6 > 0", to=0.5)],  # fmt: skip
    )


def _outputs(tmp: pathlib.Path, seed: str, path: pathlib.Path) -> dict[str, bytes]:
    env = {**os.environ, "PYTHONHASHSEED": seed}
    out = tmp / seed
    out.mkdir()
    result = subprocess.run(
        [sys.executable, "-m", "btgen_pytrees", "run", str(path), "--trace",
         "--json", str(out / "r.json"), "--junit", str(out / "r.xml")],
        capture_output=True, env=env, check=False,
    )  # fmt: skip
    assert result.returncode == 1, result.stderr
    found = {"table": result.stdout, "trace": result.stderr}
    found.update({f.name: f.read_bytes() for f in sorted(out.iterdir())})
    for fmt in ("unicode", "dot", "btcpp", "json", "matrix"):
        shown = subprocess.run([sys.executable, "-m", "btgen_pytrees", "show", str(path), "-f", fmt],
                               capture_output=True, env=env, check=True)  # fmt: skip
        found[fmt] = shown.stdout
    return found


def test_every_output_is_the_same_bytes_under_any_hash_seed(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "many.json"
    path.write_text(json.dumps(_case()))
    first = _outputs(tmp_path, SEEDS[0], path)
    assert set(first) >= {"table", "trace", "r.json", "r.xml", "unicode", "btcpp"}
    values = [o["values"] for o in json.loads(first["r.json"])["oracles"]]
    assert list(values[0]) == sorted(values[0]) and len(values[0]) == 8
    for seed in SEEDS[1:]:
        again = _outputs(tmp_path, seed, path)
        for name, data in first.items():
            assert again[name] == data, f"{name} differs with PYTHONHASHSEED={seed}"
