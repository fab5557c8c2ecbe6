"""btgen_pytrees: turn a JSON test case into a runnable py_trees behaviour tree.

The pipeline, one module (or package) per step, each depending only on the
ones before it:

load/validate (:mod:`.load`) → timeline graph (:mod:`.timeline`) → construct
(:mod:`.construct`: Algorithm 1, Algorithm 2, full tree) → leaves
(:mod:`.leaves`) → render (:mod:`.render`) / run (:mod:`.run`) → CLI (:mod:`.cli`).

>>> import btgen_pytrees
>>> case = btgen_pytrees.load("examples/fig1.json")
>>> root = btgen_pytrees.generate(case)
>>> root.name
'fig1'
"""

import sys as _sys

if _sys.stdout is None:  # pragma: no cover - closed stdout (">&-", pythonw): py_trees reads sys.stdout.encoding at import
    import os as _os

    _sys.stdout = open(_os.devnull, "w", encoding="utf-8")  # noqa: SIM115 - lives as long as the process
    _sys.stdout.btgen_closed = True  # type: ignore[attr-defined]  # the CLI refuses to run (exit 2)

from .construct import generate  # noqa: E402
from .errors import InvalidTestCase, Problem  # noqa: E402
from .load import load  # noqa: E402
from .timeline import timeline  # noqa: E402

__version__ = "0.1.0"
__all__ = ["load", "generate", "timeline", "InvalidTestCase", "Problem", "__version__"]
