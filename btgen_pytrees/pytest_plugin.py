"""The pytest plugin's entry point (``pytest11``): options only, until asked for (docs/pytest.md).

Installed with the package, so every pytest session in an environment that has
btgen_pytrees loads this module. It therefore stays small and imports nothing of
the package: it declares the options and the ``btgen`` fixture, and registers the
plugin that does the work, :mod:`btgen_pytrees.pytest_cases`, only when a session
asks for it - ``--btgen-files GLOB`` or the ini option ``btgen_files`` (collect
JSON test cases), or a test that requests the ``btgen`` fixture. A suite that does
neither runs exactly as without btgen_pytrees installed.

The entry point is named like this module, so ``-p btgen_pytrees.pytest_plugin``
(or ``pytest_plugins = [...]`` in a conftest) next to the installed entry point
loads it once, never twice.
"""

from __future__ import annotations

from typing import Any

import pytest

__all__ = ["CASES", "enabled"]

CASES = "btgen_pytrees.pytest_cases"
"""The module that collects and runs test cases, registered with pytest when asked for."""


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("btgen", "btgen_pytrees test cases (docs/pytest.md)")
    group.addoption("--btgen-files", action="append", metavar="GLOB", default=None,
                    help="collect the JSON files matching GLOB under the given paths as test cases (repeatable; "
                         "a GLOB with a '/' matches the whole path). Overrides the ini option btgen_files.")  # fmt: skip
    group.addoption("--btgen-plugin", action="append", metavar="MODULE|FILE.py", default=None,
                    help="as the CLI's --plugin: import MODULE or FILE.py and call its register(registry) "
                         "(repeatable; overrides the ini option btgen_plugins)")  # fmt: skip
    group.addoption("--btgen-system", metavar="TYPE[:CONFIG]", default=None,
                    help="as the CLI's run --system: run every case against this system (CONFIG relative to the "
                         "current directory; overrides the ini option btgen_system)")  # fmt: skip
    group.addoption("--btgen-artifacts", metavar="DIR", default=None,
                    help="write the report, plot and replay page of every failing case into DIR "
                         "(overrides the ini option btgen_artifacts)")  # fmt: skip
    group.addoption("--btgen-max-work", metavar="N", default=None,
                    help="as the CLI's run --max-work: the work budget of every run, by default the CLI's (overrides the "
                         "ini option btgen_max_work)")  # fmt: skip
    parser.addini("btgen_files", type="args", default=[],
                  help="glob patterns of JSON test case files to collect, e.g. test_*.json (off when empty)")
    parser.addini("btgen_plugins", type="args", default=[],
                  help="leaf/system plugins, MODULE or FILE.py (a file relative to the ini file's directory)")
    parser.addini("btgen_system", default="", help="TYPE[:CONFIG] to run every case against (CONFIG relative to the ini file's directory)")
    parser.addini("btgen_artifacts", default="", help="directory for the reports, plots and replay pages of failing cases")
    parser.addini("btgen_max_work", default="", help="the work budget of every run, as run --max-work (default: the CLI's)")


def enabled(config: pytest.Config) -> bool:
    """Whether the session collects test cases: ``--btgen-files`` or ``btgen_files`` given."""
    return bool(config.getoption("btgen_files") or config.getini("btgen_files"))


def _cases(config: pytest.Config) -> Any:
    """The working plugin (:mod:`btgen_pytrees.pytest_cases`), registered with pytest on first use."""
    manager = config.pluginmanager
    manager.import_plugin(CASES)  # idempotent: pytest registers a module once under its name
    return manager.get_plugin(CASES)


@pytest.hookimpl(trylast=True)
def pytest_configure(config: pytest.Config) -> None:
    if enabled(config):
        _cases(config).settings(config)  # a bad plugin or system option: a usage error before collection


@pytest.fixture
def btgen(request: pytest.FixtureRequest) -> Any:
    """Run test cases from Python: ``report = btgen.run("cases/follow.json", system=MySystem())``.

    See :class:`btgen_pytrees.pytest_cases.Btgen`.
    """
    cases = _cases(request.config)
    return cases.Btgen(request, cases.settings(request.config))
