"""OpenSCENARIO XML 1.0-1.3 files as test cases (docs/openscenario.md).

A front end onto the project's one case model: a ``.xosc`` scenario becomes a test-case document
(the storyboard as the timeline with the control-flow keys, the entities and the OpenDRIVE road
as the SUMO system, the default pass criteria), and a ``ParameterValueDistribution`` a sweep.
The loader (``load/read.py``) calls :func:`read_openscenario` for a ``.xosc`` file, so every
command and the pytest plugin take one as they take ``.json``.
"""

from .convert import SUFFIX, ScenarioSweep, ScenarioVariations, convert_file, is_catalog, is_openscenario, read_openscenario
from .oracle import read_sidecar, sidecar_path
from .scenario import DEFAULT_TICK, DEFAULT_TIMEOUT, EGO_NAMES, Options

__all__ = ["read_openscenario", "convert_file", "is_openscenario", "ScenarioSweep", "ScenarioVariations", "SUFFIX",
           "Options", "DEFAULT_TIMEOUT", "DEFAULT_TICK", "EGO_NAMES", "read_sidecar", "sidecar_path", "is_catalog"]
