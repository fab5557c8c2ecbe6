"""btgen_pytrees: turn a JSON test case into a runnable py_trees behaviour tree.

The pipeline, one module (or package) per step, each depending only on the
ones before it:

load/validate (:mod:`.loader`) → timeline graph (:mod:`.timeline`) → construct
(:mod:`.construct`: Algorithm 1, Algorithm 2, full tree) → leaves
(:mod:`.leaves`) → render (:mod:`.render`) / run (:mod:`.run`) → CLI (:mod:`.cli`).

>>> import btgen_pytrees
>>> case = btgen_pytrees.load("examples/fig1.json")
>>> root = btgen_pytrees.generate(case)
>>> root.name
'fig1'
"""

from .construct import generate
from .errors import InvalidTestCase, Problem
from .loader import load
from .timeline import timeline

__version__ = "0.1.0"
__all__ = ["load", "generate", "timeline", "InvalidTestCase", "Problem", "__version__"]
