"""Make every picture of docs/views.md (and the README's replay screenshot) from the examples.

    python docs/pictures.py            # all of them, into docs/images/
    python docs/pictures.py plots      # only the run pictures (needs matplotlib)
    python docs/pictures.py replay     # only the replay screenshots (needs selenium, chromium, chromium-driver)

The 500-entry case of the pictures and of the tests is :func:`timeline_case`:
a chain of 100 ramps of ``level``, each with four side branches (a wait,
three holds), ``R1`` (a record) and ``F1`` (a final) that pass.
"""

from __future__ import annotations

import os
import pathlib
import sys
from typing import Any

ROOT = pathlib.Path(__file__).resolve().parent.parent
IMAGES = ROOT / "docs" / "images"


def timeline_case(n: int = 500) -> dict[str, Any]:
    """A generated case of *n* execute entries (n a multiple of 5) that passes: the large-case pictures and tests."""
    entries: list[dict[str, Any]] = []
    for g in range(n // 5):
        head = f"E{g}"
        after = [f"E{g - 1}"] if g else []
        entries.append({"id": head, "kind": "behavior", "action": "ramp", "after": after,
                        "params": {"signal": "level", "to": g % 7, "duration": 0.2}})  # fmt: skip
        for b in range(4):  # a wait and three holds: only the chain writes a signal (no overlap warning)
            action, params = ("wait", {"duration": 0.1}) if b == 0 else ("hold", {"duration": 0.1 * b})
            entries.append({"id": f"E{g}_{b}", "kind": "constraint" if b == 0 else "behavior", "action": action,
                            "after": [head], "params": params})  # fmt: skip
    return {
        "name": f"timeline_{n}",
        "signals": {"level": 0},
        "tick": 0.1,
        "timeout": n,
        "execute": entries,
        "oracle": {"criteria": [
            {"id": "R1", "type": "record", "expect": "level <= 10", "name": "level stays low"},
            {"id": "F1", "type": "final", "expect": "level >= 0"},
        ]},  # fmt: skip
    }


def fig1_fast() -> dict[str, Any]:
    """fig1, but B2 ramps the speed to 40: R1 (speed <= 30) fails at 1.6 s (docs/views.md)."""
    import json

    data = json.loads((ROOT / "examples" / "fig1.json").read_text(encoding="utf-8"))
    data["execute"][2]["params"]["to"] = 40
    return data  # type: ignore[no-any-return]


def plots() -> None:
    import btgen_pytrees
    from btgen_pytrees.run import run
    from btgen_pytrees.run.plot import plot_run

    for name, source, picture in (
        ("fig1", ROOT / "examples" / "fig1.json", "fig1-run.svg"),
        ("fig1 ramping to 40", fig1_fast(), "fig1-fast-run.svg"),
        ("SUMO cut-in", ROOT / "examples" / "sumo" / "cut_in.json", "cut_in-run.svg"),
        ("500 entries", None, "timeline_500-run.png"),
    ):
        case = btgen_pytrees.load(source if isinstance(source, dict) else str(source) if source else timeline_case())
        plot_run(run(case), case, str(IMAGES / picture))
        print(f"{name}: docs/images/{picture}")


def replays() -> None:
    sys.path.insert(0, str(ROOT / "tests"))
    from browser import make_screenshot  # tests/browser.py: Debian's chromium through selenium

    make_screenshot(str(ROOT / "examples" / "fig1_failing.json"), str(IMAGES / "fig1-replay.png"), tick=12)
    make_screenshot(str(ROOT / "examples" / "sumo" / "cut_in.json"), str(IMAGES / "cut_in-replay.png"), tick=38)
    make_screenshot(timeline_case(), str(IMAGES / "timeline_500-replay.png"), tick=40, search="E99_3")
    print("docs/images/fig1-replay.png, cut_in-replay.png, timeline_500-replay.png")


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    which = sys.argv[1:] or ["plots", "replay"]
    if "plots" in which:
        plots()
    if "replay" in which:
        replays()
