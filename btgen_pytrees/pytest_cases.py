"""JSON test cases as pytest items, and the ``btgen`` fixture (docs/pytest.md).

Registered by :mod:`btgen_pytrees.pytest_plugin` when a session asks for it.

* **Collection**: a file matching ``--btgen-files``/``btgen_files`` (or named on
  the command line) is a :class:`CaseFile`; a case is one :class:`CaseItem`
  named after the case (``follow.json::follow``), a sweep one item per variation
  (``cut_in_sweep.json::cut_in_sweep[gap=4,ego_speed=21]``). The whole file is
  checked as ``validate`` checks it: an invalid case is a collection error made
  of the CLI's ``FILE: /json/pointer: message`` lines.
* **A case needing SUMO** (its system, or ``--btgen-system``, is ``sumo``)
  where libsumo is not installed is skipped with that reason - a collection
  error instead when the ``CI`` environment variable is set (as ``.ci/run``
  does), where a skipped simulator would hide a broken set-up.
* **Running**: an item runs its case as ``python -m btgen_pytrees run`` does; a
  verdict other than pass fails it, and its report is the CLI's explanation:
  the verdict table with the margins of failed criteria, why (what was still
  waiting), and the tree with the last status of every node - no traceback.
  With ``--btgen-artifacts DIR`` a failing item also writes its JSON report,
  plot (the ``plot`` extra) and replay page into DIR.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import os
import re
from pathlib import Path
from typing import Any, Iterator, Mapping

import pytest

from .construct import generate
from .errors import MAX_PROBLEMS, InvalidTestCase, printable
from .leaves import FactoryError, PluginError, Registry, default_registry
from .leaves.plugins import is_path
from .load import check_work, load_json, validate
from .model import TestCase
from .writing import commit
from .run import Report, run, run_tree
from .run.plot import PlotUnavailable, plot_bytes, require_matplotlib
from .run.replay import replay_html
from .load.sweep import load_sweep
from .load.template import has_variations
from .sweep.overrides import MAX_NAME, choose, given_values
from .systems import System, SystemSpec
from .systems.sumo import libsumo_installed
from .systems.sumo.system import INSTALL_HINT

__all__ = ["Settings", "settings", "CaseFile", "CaseItem", "CaseFailed", "Btgen", "in_ci"]


def in_ci() -> bool:
    """Whether ``CI`` is set to something other than empty, ``0``, ``false`` or ``no``."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


@dataclasses.dataclass
class Settings:
    """The session's options, resolved once (paths made absolute)."""

    patterns: list[str]
    plugins: list[str]
    system: SystemSpec | None
    artifacts: str | None
    rootdir: Path
    registry: Registry


_KEY = pytest.StashKey[Settings]()


def _ini_dir(config: pytest.Config) -> Path:
    return Path(config.inipath).parent if config.inipath else Path(config.rootpath)


def _system(text: str, base: Path) -> SystemSpec | None:
    if not text:
        return None
    kind, colon, config = text.partition(":")
    if not kind or (colon and not config):
        raise pytest.UsageError(f"btgen system {text!r}: expected TYPE or TYPE:CONFIG")
    return SystemSpec(kind, str(base / config) if config else None)


def settings(config: pytest.Config) -> Settings:
    """The :class:`Settings` of *config*'s session: command line first, then the ini file."""
    if _KEY in config.stash:
        return config.stash[_KEY]
    here, ini = Path(config.invocation_params.dir), _ini_dir(config)
    option, from_ini = config.getoption, config.getini
    plugins = [p if not is_path(p) else str(here / p) for p in option("btgen_plugin") or []] or [
        p if not is_path(p) else str(ini / p) for p in from_ini("btgen_plugins")]  # fmt: skip
    system = _system(option("btgen_system"), here) if option("btgen_system") else _system(from_ini("btgen_system"), ini)
    artifacts = str(here / option("btgen_artifacts")) if option("btgen_artifacts") else (
        str(ini / from_ini("btgen_artifacts")) if from_ini("btgen_artifacts") else None)  # fmt: skip
    try:
        registry = default_registry(plugins)
    except (PluginError, FactoryError) as error:
        raise pytest.UsageError(f"btgen_pytrees: {error}") from None
    patterns = list(option("btgen_files") or from_ini("btgen_files"))
    config.stash[_KEY] = Settings(patterns, plugins, system, artifacts, Path(config.rootpath), registry)
    return config.stash[_KEY]


def _matches(pattern: str, path: Path) -> bool:
    """pytest's rule for ``python_files``: a pattern with a ``/`` matches the whole path, else the name."""
    if "/" not in pattern and os.sep not in pattern:
        return Path(path.name).match(pattern) if pattern else False
    name, pattern = str(path), pattern.replace("/", os.sep)
    if not os.path.isabs(pattern):
        pattern = "*" + os.sep + pattern
    return fnmatch.fnmatch(name, pattern)


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    if file_path.suffix.lower() not in (".json", ".xosc"):  # an OpenSCENARIO file is a case too (docs/openscenario.md)
        return None
    config = parent.config
    if not (config.getoption("btgen_files") or config.getini("btgen_files")):
        return None  # registered for the fixture only
    wanted = settings(config).patterns
    if parent.session.isinitpath(file_path) or any(_matches(p, file_path) for p in wanted):
        return CaseFile.from_parent(parent, path=file_path)
    return None


def _shown(path: Path, rootdir: Path) -> str:
    """*path* relative to the rootdir when under it (as pytest shows node ids)."""
    try:
        return str(path.relative_to(rootdir))
    except ValueError:
        return str(path)


def invalid_text(error: InvalidTestCase, shown: str) -> str:
    """The CLI's lines for *error*: ``FILE: /json/pointer: message``, at most :data:`MAX_PROBLEMS`."""
    problems = error.problems
    lines = [p.render(shown) for p in problems[:MAX_PROBLEMS]]
    if len(problems) > MAX_PROBLEMS:
        lines.append(f"{shown}: … and {len(problems) - MAX_PROBLEMS} more problems")
    return "\n".join(lines)


def _needs_sumo(data: Any, system: SystemSpec | None) -> bool:
    declared = data.get("system") if isinstance(data, dict) else None
    kind = system.type if system is not None else (declared.get("type") if isinstance(declared, dict) else None)
    return kind == "sumo"


def _item_name(text: str, fallback: str) -> str:
    """A node id part: printable, without pytest's ``::`` separator."""
    return printable(text).replace("::", ":_:") or fallback


class CaseFile(pytest.File):
    """A JSON test case file: one item, or one per variation of a sweep."""

    def collect(self) -> Iterator[CaseItem]:
        conf = settings(self.config)
        shown = _shown(self.path, conf.rootdir)
        try:
            data = load_json(str(self.path))
            if _needs_sumo(data, conf.system) and not libsumo_installed():
                reason = f"{shown}: needs the 'sumo' extra, and libsumo is not installed ({INSTALL_HINT})"
                if in_ci():
                    raise self.CollectError(reason + "; under CI=true this is an error, not a skip")
                pytest.skip(reason)
            if has_variations(data):
                sweep = load_sweep(data, registry=conf.registry, source_name=str(self.path), system=conf.system)
                stem = _item_name(sweep.name, self.path.stem)
                for variation in sweep:
                    name = f"{stem}[{printable(variation.label)}]"
                    document = {**variation.document, "name": f"{sweep.name}[{variation.label}]"[:MAX_NAME]}
                    # the node id given as text: pytest 9 parses it into name and [params], as it parses the
                    # ids --lf and --sw read back from its cache (built from the name alone, they would differ)
                    yield CaseItem.from_parent(self, name=name, nodeid=f"{self.nodeid}::{name}", document=document,
                                               parameters=dict(variation.values))  # fmt: skip
                return
            case = validate(data, str(self.path), conf.registry, conf.system)
            check_work(case)
        except InvalidTestCase as error:
            raise self.CollectError(invalid_text(error, shown)) from None
        yield CaseItem.from_parent(self, name=_item_name(case.name, self.path.stem), case=case)


class CaseFailed(Exception):
    """An item's run did not pass; carries the report (shown by :meth:`CaseItem.repr_failure`)."""

    def __init__(self, report: Report, written: list[str], notes: list[str]):
        super().__init__(f"{report.test}: {report.verdict}")
        self.report, self.written, self.notes = report, written, notes


def failure_text(report: Report, written: list[str] = (), notes: list[str] = ()) -> str:  # type: ignore[assignment]
    """What a failing item shows: why in one line (pytest's short summary shows it), the CLI's verdict
    table and explanation, the tree at the end, and the artifacts written."""
    headline = report.explanation[0] if report.explanation else report.message or report.verdict
    text = f"{report.test}: {report.verdict.upper()} - {headline}\n\n" + report.table()
    if report.tree:
        text += "\ntree at the end (last status of each node):\n" + report.tree
    for path in written:
        text += f"\nwritten: {path}"
    for note in notes:
        text += f"\nnot written: {note}"
    return text.rstrip("\n")


def _artifact_base(nodeid: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.=,\[\]+-]+", "_", nodeid).strip("_")[:200] or "case"


def write_artifacts(directory: str, nodeid: str, report: Report, case: TestCase,
                    registry: Registry) -> tuple[list[str], list[str]]:  # fmt: skip
    """Write the JSON report, the plot (svg) and the replay page of a failing run; (written, notes)."""
    base = os.path.join(directory, _artifact_base(nodeid))
    outputs: list[tuple[str, str | bytes]] = [(base + ".report.json", report.to_json())]
    notes = []
    try:
        require_matplotlib()
        outputs.append((base + ".plot.svg", plot_bytes(report, case, "svg")))
    except PlotUnavailable as missing:
        notes.append(f"the plot: {missing}")
    outputs.append((base + ".replay.html", replay_html(report, case, generate(case, registry=registry))))
    os.makedirs(directory, exist_ok=True)
    return commit(outputs), notes


class CaseItem(pytest.Item):
    """One run: a case, or one variation of a sweep (``parameters`` holds its values)."""

    def __init__(self, *, case: TestCase | None = None, document: Mapping[str, Any] | None = None,
                 parameters: Mapping[str, Any] | None = None, **kwargs: Any) -> None:  # fmt: skip
        super().__init__(**kwargs)
        self.case = case
        self.document = document
        self.parameters = dict(parameters or {})
        for name, value in self.parameters.items():
            self.user_properties.append((f"parameter {name}", value))

    def runtest(self) -> None:
        conf = settings(self.config)
        case = self.case
        if case is None:
            case = validate(self.document, str(self.path), conf.registry, conf.system)
        report = run(case, registry=conf.registry)
        self.user_properties.append(("verdict", report.verdict))
        if report.passed:
            return
        written, notes = [], []
        if conf.artifacts:
            written, notes = write_artifacts(conf.artifacts, self.nodeid, report, case, conf.registry)
        raise CaseFailed(report, written, notes)

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException], style: Any = None) -> Any:
        if isinstance(excinfo.value, CaseFailed):
            failed = excinfo.value
            return failure_text(failed.report, failed.written, failed.notes)
        if isinstance(excinfo.value, InvalidTestCase):
            return invalid_text(excinfo.value, _shown(self.path, settings(self.config).rootdir))
        return super().repr_failure(excinfo, style=style)

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, self.name


class Btgen:
    """The ``btgen`` fixture: load and run test cases from a Python test.

    Relative paths are relative to pytest's rootdir (where the ini file is), so
    ``btgen.run("cases/follow.json")`` works wherever pytest is started. The
    session's ``--btgen-plugin``/``--btgen-system``/``--btgen-artifacts`` apply.
    A run that does not pass adds its explanation (as a failing item shows it)
    to the test's report, so ``assert report.passed`` fails with the reason.
    """

    def __init__(self, request: pytest.FixtureRequest, conf: Settings):
        self.request = request
        self.settings = conf
        self.registry = conf.registry

    def path(self, path: str | os.PathLike[str]) -> Path:
        return self.settings.rootdir / Path(path)

    def load(self, path: str | os.PathLike[str], *, parameters: Mapping[str, Any] | None = None) -> TestCase:
        """The case at *path*; a sweep's variation with *parameters* (others at their defaults)."""
        full = str(self.path(path))
        data = load_json(full)
        if parameters is not None or has_variations(data):
            data = choose(data, full, given_values(dict(parameters or {}), "parameters"), registry=self.registry,
                          system=self.settings.system).document  # fmt: skip
        case = validate(data, full, self.registry, self.settings.system)
        check_work(case)
        return case

    def run(self, path: str | os.PathLike[str], *, system: System | None = None,
            parameters: Mapping[str, Any] | None = None) -> Report:  # fmt: skip
        """Run the case at *path*, against *system* (a new, not started :class:`~btgen_pytrees.systems.System`)
        or else the case's own (or ``--btgen-system``); return its :class:`~btgen_pytrees.run.Report`."""
        case = self.load(path, parameters=parameters)
        if system is None:
            report = run(case, registry=self.registry)
        else:
            root = generate(case, registry=self.registry, clock=system)
            try:
                report = run_tree(root, case, system=system)
            finally:
                root.btgen_env.release()
        if not report.passed:
            written, notes = [], []
            if self.settings.artifacts:
                written, notes = write_artifacts(self.settings.artifacts, self.request.node.nodeid, report, case,
                                                 self.registry)  # fmt: skip
            self.request.node.add_report_section("call", f"btgen {report.test}", failure_text(report, written, notes))
        return report
