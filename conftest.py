"""Every example is a test item of the project's own suite (docs/pytest.md#this-projects-own-suite).

``pyproject.toml`` collects ``examples/**.json`` with the pytest plugin. Most
examples pass; the ones below *fail by design* - they show what a failing run
reports - and this is where that is declared: a mapping from the example (its
path under ``examples/``) to the rule saying which of its runs fail, and why.

* ``EXPECTED_FAIL``: ``xfail(strict=True)`` where the rule says the run fails -
  the suite stays green while they fail, and turns red if one starts to pass;
  for a sweep the rule reads the variation's parameters.
* ``MAY_FAIL``: ``xfail(strict=False)`` where the rule says the run may fail -
  where the verdict depends on the simulator's model (SUMO's ACC), so another
  version of it may move the boundary; a pass there is reported as XPASS, not
  as an error. The runs outside the rule must pass.

``examples/host_app/`` holds a host application and its leaf plugin (``btgen_plugins`` in
``pyproject.toml`` registers it for ``pick.json``), not tests.

This is the root conftest (loaded for every path of the repository, so ``pytest examples/``
alone sees it) rather than one in ``examples/``: conftests outside packages are all the module
``conftest``, and ``--doctest-modules`` imports ``tests/conftest.py`` by that name - with a second
one in a test path loaded after it, that import finds the wrong file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Mapping

import pytest

HERE = Path(__file__).resolve().parent / "examples"

collect_ignore = ["examples/host_app/app.py", "examples/host_app/robot.py", "examples/temporal/arch.py"]

EXPECTED_FAIL: dict[str, tuple[Callable[[Mapping[str, Any]], bool], str]] = {
    "fig1_failing.json": (lambda p: True, "fig1 with a speed limit the ramp exceeds: fails by design"),
    "fig1_sweep.json": (lambda p: p["top_speed"] > p["limit"], "the ramp's top speed is over the limit R1 checks"),
    "sumo/cut_in.json": (lambda p: True, "the cut-in ends in a collision: fails by design"),
    **{f"temporal/{name}.json": (lambda p: True, "an ARCH-COMP requirement the stand-in plant's fixed drive violates "
                                 "(examples/temporal/README.md lists each verdict)")
       for name in ("at2", "cc2", "cc3", "cc4", "cc5", "afc29")},
    "temporal/response_falsify.json": (lambda p: p["delay"] > 1.45, "the ego reacts more than 1.4 s after the lead "
                                       "brakes: its deceleration starts after the 1.5 s the requirement allows"),
    "sumo/cut_in_sweep.json": (lambda p: p["gap"] <= 2, "the cutter cuts in 2 m or less ahead: R2 (never closer than "
                               "2 m) cannot hold"),
}

MAY_FAIL: dict[str, tuple[Callable[[Mapping[str, Any]], bool], str]] = {
    "sumo/cut_in_sweep.json": (lambda p: p["gap"] > 2 and p["ego_speed"] >= 23, "the ego closes on the 20 m/s cutter at 3 m/s or more: "
                               "fails where SUMO's ACC lets the gap fall below 2 m, which depends on SUMO's model"),
}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        try:
            where = item.path.resolve().relative_to(HERE).as_posix()
        except ValueError:
            continue
        parameters = getattr(item, "parameters", {})
        for table, strict in ((EXPECTED_FAIL, True), (MAY_FAIL, False)):
            rule, why = table.get(where, (None, ""))
            if rule is not None and rule(parameters):
                item.add_marker(pytest.mark.xfail(reason=why, strict=strict))
