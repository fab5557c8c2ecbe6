"""The replay page at size: ``python -m benchmarks.replay_page`` (needs selenium, chromium, chromium-driver).

For docs/pictures.py's 500-entry ``timeline_case`` and the 2,000-entry ``comb``
of :mod:`benchmarks.timelines` it writes the page (:func:`replay_html`, wall
time and size), opens it in headless Chromium (wall time until the page's
script is done), and times in the page a step of the slider (the mean of 50
← keys) and "expand all" (every node laid out and drawn). One run each: the
figures in docs/views.md come from it.
"""

from __future__ import annotations

import pathlib
import shutil
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "docs")]

import btgen_pytrees  # noqa: E402
from benchmarks.timelines import comb  # noqa: E402
from btgen_pytrees.run import run  # noqa: E402
from btgen_pytrees.run.replay import replay_html  # noqa: E402

STEP = """const t = performance.now();
for (let i = 0; i < 50; i++) document.dispatchEvent(new KeyboardEvent('keydown', {key: 'ArrowLeft'}));
return (performance.now() - t) / 50;"""
EXPAND = "const t = performance.now(); document.getElementById('expand-all').click(); return performance.now() - t;"


def main() -> None:
    from browser import chromium  # tests/browser.py: Debian's chromium through selenium
    from pictures import timeline_case

    for name, data in (("timeline_case (500 entries)", timeline_case()), ("comb (2,000 entries)", comb(2000))):
        case = btgen_pytrees.load(data)
        report = run(case)
        root = btgen_pytrees.generate(case)
        t0 = time.perf_counter()
        page = replay_html(report, case, root)
        written = time.perf_counter() - t0
        folder = pathlib.Path(tempfile.mkdtemp(prefix="btgen-replay-bench-"))
        path = folder / "page.html"
        path.write_bytes(page)
        try:
            with chromium() as driver:
                t0 = time.perf_counter()
                driver.get(path.as_uri())
                opened = time.perf_counter() - t0
                step, expand = driver.execute_script(STEP), driver.execute_script(EXPAND)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        print(f"{name}: {len(report.trace.nodes):,} nodes, {report.ticks:,} ticks: written in {written:.2f} s, "
              f"{len(page) / 1024:,.0f} KB; opened in {opened:.2f} s; a slider step {step:.1f} ms; "
              f"expand all {expand:,.0f} ms")  # fmt: skip


if __name__ == "__main__":
    main()
