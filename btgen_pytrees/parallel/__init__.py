"""Many jobs, no domain knowledge: where jobs run (this process, local worker processes, a Dask
cluster) and what each one gave (:class:`Outcome`, never an exception).

* :mod:`.outcome` - :class:`Outcome`, :func:`guard` (every exception -> an outcome), the summary table, one JUnit document
* :mod:`.pool` - :func:`process`: the local worker processes, or another engine's ``map_unordered``
* :mod:`.dask` - :class:`DaskExecutor`: the same calls on a Dask ``distributed`` cluster (the ``dask`` extra)
* :mod:`.shipping` - the files runs read, sent once to every Dask worker

Nothing here imports the leaves, the systems, the views or the steps of the pipeline: a job is a
plain picklable function, and its invalid input is recognised by the one family
:class:`~btgen_pytrees.errors.UserError`.
"""

from .outcome import WORDS, Interrupted, Outcome, capped, guard, merge_junit, summary
from .pool import Workers, process, progress_stream

__all__ = ["Outcome", "Interrupted", "guard", "capped", "summary", "merge_junit", "WORDS", "process", "progress_stream", "Workers"]
