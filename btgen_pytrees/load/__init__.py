"""Step 1 of the pipeline: a test case's JSON → a validated :class:`~btgen_pytrees.model.TestCase`.

One validation path, in modules named for what they own (docs/architecture.md lists them):
the file read within the limits, whole or entry by entry (:mod:`.read`), the
``parameters``/``variations`` blocks and their substitution (:mod:`.template`,
:mod:`.parameters`, :mod:`.variations`), the rules - each a cheap condition plus its words -
of the entries (:mod:`.entries`) and of the rest (:mod:`.values`, :mod:`.schema`,
:mod:`.words`, :mod:`.context`, :mod:`.document`), the case built (:mod:`.document`, with the
load-time warnings of :mod:`.warnings`), all driven by :mod:`.case` (one case) and
:mod:`.sweep` (every variation of a sweep).

Note: ``btgen_pytrees.load`` as an attribute of the package is the function
:func:`btgen_pytrees.load` (the public API); import this package's names with
``from btgen_pytrees.load import validate`` or ``from btgen_pytrees.load.read import parse_json``.
"""

from .case import load, validate
from .context import system_spec
from .limits import MAX_FILE_BYTES, MAX_MAGNITUDE, MAX_NESTING, MAX_TICKS, MAX_WORK, MIN_TICK, check_work, work
from .read import load_json, parse_json
from .schema import case_validator, inline_refs, schema, schema_for, schema_text
from .sweep import load_sweep
from .template import MAX_VARIATIONS, Sweep, Variation, has_variations, is_parameterised
from .values import value_problems
from .warnings import overlapping_writes, warning_lines
from .words import MAX_SUGGESTIONS

__all__ = ["load", "load_json", "validate", "schema", "schema_for", "schema_text", "MAX_FILE_BYTES", "MAX_TICKS",
           "MAX_MAGNITUDE", "MIN_TICK", "MAX_WORK", "MAX_NESTING", "MAX_SUGGESTIONS", "work", "check_work", "system_spec",
           "parse_json", "case_validator", "inline_refs", "value_problems", "load_sweep", "MAX_VARIATIONS", "Sweep",
           "Variation", "has_variations", "is_parameterised", "overlapping_writes", "warning_lines"]
