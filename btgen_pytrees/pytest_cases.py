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
  plot (the ``plot`` extra) and replay page into DIR, under names of its own
  (:func:`artifact_base`); the reports written there are not collected as cases.
* **The budget**: every run has the work budget of ``run`` (``--btgen-max-work``,
  ``btgen_max_work``; default :data:`~btgen_pytrees.load.MAX_WORK`): a case over it
  is a collection error, a run that spends it ends ``error`` and fails.
"""

from __future__ import annotations

import argparse
import dataclasses
import fnmatch
import hashlib
import os
import pickle
import re
import traceback
from pathlib import Path
from typing import Any, Iterator, Mapping

import pytest

from .cli.options import positive
from .construct import generate
from .errors import MAX_PROBLEMS, InvalidTestCase, printable
from .leaves import FactoryError, PluginError, Registry, default_registry
from .leaves.plugins import is_path, loads_user_code
from .load import MAX_WORK, check_work, load_json, validate
from .model import TestCase
from .openscenario import is_catalog
from .supervise import LOST, ChildLost, in_child
from .writing import commit
from .run import Report, run, run_tree
from .run.plot import PlotUnavailable, plot_bytes, require_matplotlib
from .run.replay import replay_html
from .load.sweep import load_sweep
from .load.template import has_variations
from .sweep.overrides import MAX_NAME, choose, given_values
from .systems import System, SystemSpec
from .systems.sumo import libsumo_installed
from .systems.sumo.system import INSTALL_HINT, libsumo_module

__all__ = ["Settings", "settings", "CaseFile", "CaseItem", "CaseFailed", "ItemError", "Btgen", "in_ci", "ARTIFACTS_TAG",
           "artifact_base", "is_artifact"]


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
    max_work: int = MAX_WORK
    taken: set[str] = dataclasses.field(default_factory=set)
    """The artifact names this session's runs have written (:func:`artifact_base`): none is written twice."""
    supervised: bool = False
    """Whether items run in a supervised child: user code is loaded (plugins, installed entry points) and
    ``os.fork`` exists - so a leaf's ``os._exit(0)`` fails its item instead of ending the session with 0."""


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


def _budget(text: str, where: str) -> int:
    """The work budget *text* read as ``run --max-work`` reads it; a usage error otherwise."""
    try:
        return positive(text) if text else MAX_WORK
    except argparse.ArgumentTypeError as error:
        raise pytest.UsageError(f"btgen_pytrees: {where} {text}: {error}") from None


def _artifacts_dir(given: str, base: Path, where: str) -> str | None:
    """*given* (relative to *base*) made absolute, if a directory can be made there: an existing file, or a
    file on the way, is a usage error (pytest's exit 4), not a traceback when the first item fails."""
    if not given:
        return None
    path = at = base / given
    while not at.exists() and at != at.parent:
        at = at.parent
    if not at.is_dir():
        raise pytest.UsageError(f"btgen_pytrees: {where} {given}: {_shown(at, base)} is a file, not a directory")
    return str(path)


def _try_loading(plugins: list[str]) -> None:
    """Load the plugins once in a supervised child before pytest's process does: one that ends the process
    as it loads (``os._exit(0)`` at import) is a usage error (exit 4), not a session ended with 0. What
    else goes wrong there is left to the real loading, which says it."""

    def load() -> bytes:
        try:
            default_registry(plugins)
        except BaseException:  # noqa: BLE001 - reported by the loading in pytest's process
            pass
        return b""

    try:
        in_child(load)
    except ChildLost as lost:
        raise pytest.UsageError(f"btgen_pytrees: error: the process loading the plugins {lost} {LOST}") from None


def settings(config: pytest.Config) -> Settings:
    """The :class:`Settings` of *config*'s session: command line first, then the ini file."""
    if _KEY in config.stash:
        return config.stash[_KEY]
    here, ini = Path(config.invocation_params.dir), _ini_dir(config)
    option, from_ini = config.getoption, config.getini
    plugins = [p if not is_path(p) else str(here / p) for p in option("btgen_plugin") or []] or [
        p if not is_path(p) else str(ini / p) for p in from_ini("btgen_plugins")]  # fmt: skip
    system = _system(option("btgen_system"), here) if option("btgen_system") else _system(from_ini("btgen_system"), ini)
    artifacts = (_artifacts_dir(option("btgen_artifacts"), here, "--btgen-artifacts") if option("btgen_artifacts")
                 else _artifacts_dir(from_ini("btgen_artifacts"), ini, "btgen_artifacts"))  # fmt: skip
    budget = (_budget(option("btgen_max_work"), "--btgen-max-work") if option("btgen_max_work") else
              _budget(from_ini("btgen_max_work"), "btgen_max_work"))  # fmt: skip
    supervised = hasattr(os, "fork") and loads_user_code(plugins)
    if supervised:
        _try_loading(plugins)
    try:
        registry = default_registry(plugins)
    except (PluginError, FactoryError) as error:
        raise pytest.UsageError(f"btgen_pytrees: {error}") from None
    patterns = list(option("btgen_files") or from_ini("btgen_files"))
    config.stash[_KEY] = Settings(patterns, plugins, system, artifacts, Path(config.rootpath), registry, budget,
                                  supervised=supervised)  # fmt: skip
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
    if file_path.suffix.lower() not in (".json", ".xosc") or file_path.name.endswith(".oracle.json"):
        return None  # an OpenSCENARIO file is a case too, its sidecar oracle file is not (docs/openscenario.md)
    config = parent.config
    if not (config.getoption("btgen_files") or config.getini("btgen_files")):
        return None  # registered for the fixture only
    if parent.session.isinitpath(file_path):
        return CaseFile.from_parent(parent, path=file_path)
    if any(_matches(p, file_path) for p in settings(config).patterns) and not is_artifact(file_path):
        if file_path.suffix.lower() == ".xosc" and is_catalog(str(file_path)):
            return None  # an OpenSCENARIO catalog beside the scenarios that use it: not a case
        return CaseFile.from_parent(parent, path=file_path)
    return None


ARTIFACTS_TAG = ".btgen-artifacts"
"""The file that marks a directory written by ``--btgen-artifacts``: its ``*.report.json`` are reports."""

_TAG_TEXT = ("This directory holds the artifacts of failing btgen_pytrees test cases (pytest --btgen-artifacts).\n"
             "Its *.report.json files are run reports, not test cases: the pytest plugin does not collect them.\n")


def is_artifact(path: Path) -> bool:
    """Whether *path* is a report ``--btgen-artifacts`` wrote (a ``*.report.json`` beside :data:`ARTIFACTS_TAG`)."""
    return path.name.endswith(REPORT_SUFFIX) and (path.parent / ARTIFACTS_TAG).is_file()


def _shown(path: Path, rootdir: Path) -> str:
    """*path* relative to the rootdir when under it (as pytest shows node ids)."""
    try:
        return str(path.relative_to(rootdir))
    except ValueError:
        return str(path)


def _source_shown(error: InvalidTestCase, path: Path, shown: str, rootdir: Path) -> str:
    """The file *error*'s pointers are in, as the CLI names it: *shown* (the collected file), or the other
    file the problem is in - the scenario an OpenSCENARIO distribution names, whose ``/OpenSCENARIO/...``
    path is no place in the distribution."""
    if error.source in ("<dict>", str(path)) or not os.path.isfile(error.source) or os.path.samefile(error.source, path):
        return shown
    return _shown(Path(os.path.abspath(error.source)), rootdir)


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


def _item(parent: CaseFile, name: str, **kwargs: Any) -> CaseItem:
    """The item *name* of *parent*, its node id given as text: pytest 9 parses such a text into names and
    ``[params]``, as it parses the ids ``--lf`` and ``--sw`` read back from its cache - an id built from the
    name alone would keep ``brake[hard]`` whole, and never equal the cached one."""
    return CaseItem.from_parent(parent, name=name, nodeid=f"{parent.nodeid}::{name}", **kwargs)


class CaseFile(pytest.File):
    """A JSON test case file: one item, or one per variation of a sweep."""

    def collect(self) -> Iterator[CaseItem]:
        conf = settings(self.config)
        shown = _shown(self.path, conf.rootdir)
        try:
            data = load_json(str(self.path))
            sumo = _needs_sumo(data, conf.system)
            if sumo and not libsumo_installed():
                reason = f"{shown}: needs the 'sumo' extra, and libsumo is not installed ({INSTALL_HINT})"
                if in_ci():
                    raise self.CollectError(reason + "; under CI=true this is an error, not a skip")
                pytest.skip(reason)
            if has_variations(data):
                sweep = load_sweep(data, registry=conf.registry, source_name=str(self.path), system=conf.system,
                                   max_work=conf.max_work)  # fmt: skip
                stem = _item_name(sweep.name, self.path.stem)
                for variation in sweep:
                    name = f"{stem}[{printable(variation.label)}]"
                    document = {**variation.document, "name": f"{sweep.name}[{variation.label}]"[:MAX_NAME]}
                    yield _item(self, name, document=document, parameters=dict(variation.values), sumo=sumo)
                return
            case = validate(data, str(self.path), conf.registry, conf.system)
            check_work(case, conf.max_work)
        except InvalidTestCase as error:
            raise self.CollectError(invalid_text(error, _source_shown(error, self.path, shown, conf.rootdir))) from None
        yield _item(self, _item_name(case.name, self.path.stem), case=case, sumo=sumo)


class ItemError(Exception):
    """An item that gave no report: ``str()`` is what it shows (an invalid variation, a supervised run's
    exception as its traceback's text)."""


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


REPORT_SUFFIX = ".report.json"
MAX_READABLE = 200
"""The most characters of a node id an artifact's name keeps (the digest after it tells longer ids apart)."""


def artifact_base(nodeid: str, taken: set[str]) -> str:
    """The name, without suffix, of the artifacts of a run of *nodeid*: unique in the session.

    The node id made a file name (``/``, ``::`` and other characters outside
    ``A-Za-z0-9_.=,[]+-`` become ``_``, cut at :data:`MAX_READABLE`), then ``-``
    and 12 hex digits of the id's SHA-256: ids that read alike once made a name
    (``a b.json`` and ``a_b.json``, ``a/b.json`` and ``a_b.json``, two cut at the
    same length) differ in their digest, and the same item has the same name in
    every session. A second run of one id in the session (the fixture run twice
    in one test, a rerun plugin) gets ``-2``, ``-3``...: nothing written in a
    session is replaced. The name returned is added to *taken*.
    """
    readable = re.sub(r"[^A-Za-z0-9_.=,\[\]+-]+", "_", nodeid).strip("_")[:MAX_READABLE] or "case"
    base = f"{readable}-{hashlib.sha256(nodeid.encode('utf-8', 'surrogatepass')).hexdigest()[:12]}"
    name, count = base, 1
    while name in taken:
        count += 1
        name = f"{base}-{count}"
    taken.add(name)
    return name


def write_artifacts(directory: str, nodeid: str, report: Report, case: TestCase, registry: Registry,
                    taken: set[str]) -> tuple[list[str], list[str]]:  # fmt: skip
    """Write the JSON report, the plot (svg) and the replay page of a failing run; (written, notes).

    A directory that cannot be written (removed, made a file, full) is a note, not an error: the item
    fails for its verdict either way, and its failure text says what was not written."""
    base = os.path.join(directory, artifact_base(nodeid, taken))
    outputs: list[tuple[str, str | bytes]] = [(base + REPORT_SUFFIX, report.to_json())]
    notes = []
    try:
        require_matplotlib()
        outputs.append((base + ".plot.svg", plot_bytes(report, case, "svg")))
    except PlotUnavailable as missing:
        notes.append(f"the plot: {missing}")
    outputs.append((base + ".replay.html", replay_html(report, case, generate(case, registry=registry))))
    try:
        os.makedirs(directory, exist_ok=True)
        tag = os.path.join(directory, ARTIFACTS_TAG)
        if not os.path.isfile(tag):
            commit([(tag, _TAG_TEXT)])
        return commit(outputs), notes
    except OSError as error:
        return [], [*notes, f"the artifacts in {directory}: {error.strerror or error}"]


class CaseItem(pytest.Item):
    """One run: a case, or one variation of a sweep (``parameters`` holds its values)."""

    def __init__(self, *, case: TestCase | None = None, document: Mapping[str, Any] | None = None,
                 parameters: Mapping[str, Any] | None = None, sumo: bool = False, **kwargs: Any) -> None:  # fmt: skip
        super().__init__(**kwargs)
        self.case = case
        self.sumo = sumo
        self.document = document
        self.parameters = dict(parameters or {})
        for name, value in self.parameters.items():
            self.user_properties.append((f"parameter {name}", value))

    def runtest(self) -> None:
        conf = settings(self.config)
        if conf.supervised:
            if self.sumo:  # imported once here, not in every child (it takes about a second)
                libsumo_module()
            try:
                kind, *result = pickle.loads(in_child(self._outcome_bytes))
            except ChildLost as lost:
                self.user_properties.append(("verdict", "error"))
                raise ItemError(f"{self.name}: ERROR - the run's process {lost} {LOST}") from None
        else:
            kind, *result = self._outcome(conf)
        if kind != "ran":
            raise ItemError(result[0])
        report, written, notes = result
        if written:  # the child's names are the session's too
            conf.taken.add(Path(written[0]).name.removesuffix(REPORT_SUFFIX))
        self.user_properties.append(("verdict", report.verdict))
        if not report.passed:
            raise CaseFailed(report, written, notes)

    def _outcome(self, conf: Settings) -> tuple[Any, ...]:
        """Run the item: ``("ran", report, written, notes)``, or ``("invalid", text)`` (a variation's check)."""
        case = self.case
        try:
            if case is None:
                case = validate(self.document, str(self.path), conf.registry, conf.system)
        except InvalidTestCase as error:
            return ("invalid", invalid_text(error, _shown(self.path, conf.rootdir)))
        report = run(case, registry=conf.registry, max_work=conf.max_work)
        written, notes = [], []
        if not report.passed and conf.artifacts:
            written, notes = write_artifacts(conf.artifacts, self.nodeid, report, case, conf.registry, conf.taken)
        return ("ran", report, written, notes)

    def _outcome_bytes(self) -> bytes:
        """:meth:`_outcome` in a supervised child (``btgen_pytrees.supervise.in_child``), pickled for the
        parent - an exception too, as its traceback's text (the parent fails the item with it)."""
        try:
            outcome: tuple[Any, ...] = self._outcome(settings(self.config))
            return pickle.dumps(outcome)
        except BaseException:  # noqa: BLE001 - any, SystemExit too: the item's error, reported by the parent
            return pickle.dumps(("raised", traceback.format_exc()))

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException], style: Any = None) -> Any:
        if isinstance(excinfo.value, CaseFailed):
            failed = excinfo.value
            return failure_text(failed.report, failed.written, failed.notes)
        if isinstance(excinfo.value, ItemError):
            return str(excinfo.value)
        return super().repr_failure(excinfo, style=style)

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, self.name


class Btgen:
    """The ``btgen`` fixture: load and run test cases from a Python test.

    Relative paths are relative to pytest's rootdir (where the ini file is), so
    ``btgen.run("cases/follow.json")`` works wherever pytest is started. The
    session's ``--btgen-plugin``/``--btgen-system``/``--btgen-artifacts``/``--btgen-max-work`` apply.
    Its runs are the test's own code, in the test's process (the system is the
    test's object, which it may read after the run): unlike items, never in a
    supervised child.
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
        check_work(case, self.settings.max_work)
        return case

    def run(self, path: str | os.PathLike[str], *, system: System | None = None,
            parameters: Mapping[str, Any] | None = None) -> Report:  # fmt: skip
        """Run the case at *path*, against *system* (a new, not started :class:`~btgen_pytrees.systems.System`)
        or else the case's own (or ``--btgen-system``); return its :class:`~btgen_pytrees.run.Report`."""
        case = self.load(path, parameters=parameters)
        if system is None:
            report = run(case, registry=self.registry, max_work=self.settings.max_work)
        else:
            root = generate(case, registry=self.registry, clock=system)
            try:
                report = run_tree(root, case, system=system, max_work=self.settings.max_work)
            finally:
                root.btgen_env.release()
        if not report.passed:
            written, notes = [], []
            if self.settings.artifacts:
                written, notes = write_artifacts(self.settings.artifacts, self.request.node.nodeid, report, case,
                                                 self.registry, self.settings.taken)  # fmt: skip
            self.request.node.add_report_section("call", f"btgen {report.test}", failure_text(report, written, notes))
        return report
