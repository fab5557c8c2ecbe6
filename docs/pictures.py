"""Make every picture and sample output of the README and docs/, and say which ones are stale.

    python docs/pictures.py              # everything: pictures into docs/images/, sample outputs into the docs
    python docs/pictures.py plots        # only the run pictures, verdict maps and tree pictures (matplotlib, Graphviz)
    python docs/pictures.py replay       # only the replay screenshots (selenium, chromium, chromium-driver)
    python docs/pictures.py samples      # only the sample outputs written in the docs
    python docs/pictures.py --check      # change nothing: list what is stale (exit 1 if anything is)

``tests/test_pictures.py`` runs the check, so a picture or a sample that no longer shows what the
project makes fails the suite.

**Sample outputs.** A code block in README.md or docs/*.md right after a comment line

* ``<!-- sample: ARGS -->`` is the output of ``python -m btgen_pytrees ARGS`` (stdout and stderr as
  a terminal shows them), after a line ``$ python -m btgen_pytrees ARGS`` when the block starts so;
* ``<!-- sample -->`` is a session: each line ``$ python -m btgen_pytrees ARGS`` followed by its output;
* ``<!-- sample file: PATH -->`` is the file PATH of this repository, as it is;
* ``<!-- sample (NAME = the block above): ARGS -->`` runs with the doc's previous code block as the
  file NAME (a case shown in the doc, run as it is shown);
* ``<!-- sample pytest: ARGS -->`` is the output of ``pytest ARGS``, after a line ``$ pytest ARGS``
  when the block starts so. It runs in a child process as ``python -m pytest -p no:randomly -p
  no:cacheprovider -p no:hypothesispytest ARGS`` (pytest's own order, no cache, and not Hypothesis'
  plugin, which no sample uses and which costs a second of CPU a run), with ``COLUMNS=80``,
  ``PY_COLORS=0``, without the ``PYTEST_*``, ``CI`` and ``BUILD_NUMBER`` variables (on a CI server
  pytest does not shorten its summary lines), this repository first on ``PYTHONPATH``. ARGS must
  hold ``-q``: pytest's header names the machine (its Python, plugins, paths). The duration pytest
  ends with (``1 failed in 0.52s``) is left out (``1 failed``): a time is never the same twice.
* ``<!-- sample python: ARGS -->`` is the output of ``python ARGS`` (a program shown in the doc, written
  to a scratch directory as below), run in a child process as a pytest sample is, after a line
  ``$ python ARGS`` when the block starts so.

Before the ``:``, ``(NAME = SOURCE, NAME = SOURCE...)`` runs the command in a scratch directory holding
each file NAME (a relative path; folders are made), made from SOURCE: ``the block above`` (the doc's
previous code block), ``the 2nd block above`` (the one before it, and so on), or a repository path
(``examples/fig1_failing.json``). Without it, the command runs from the repository's root (where a
pytest sample runs under this project's own pytest configuration, ``pyproject.toml`` and ``conftest.py``).
``(in corpus/DIR)`` runs it in the folder DIR of the ALKS OpenSCENARIO corpus (:data:`CORPUS`), which
is not part of this repository: where it is absent (on a CI server, say) the sample is not checked.

**Excerpts.** ARGS may end with `` | `` and a rule that keeps a part of the output, never an edit by
hand:

* ``| lines REGEX`` keeps the lines in which REGEX (Python's ``re.search``) matches;
* ``| section TITLE`` keeps pytest's section TITLE: its title line (``____ TITLE ____``) and the lines
  up to the next title line (``____ ... ____`` or ``==== ... ====``);
* ``| usage`` keeps argparse's usage, the lines up to the first blank line (a command's synopsis).

``lines`` and ``section`` show each run of lines left out as one line ``...``. A rule that keeps
nothing is an error. The commands of ``btgen_pytrees`` run in this process. Text is compared exactly.

**Pictures** (:data:`PICTURES`, recorded in ``docs/images/pictures.json``). Rendered pictures are
not byte-stable across machines: Chromium's screenshots differ with its version and fonts,
Graphviz's SVG with its version, matplotlib's output with its version. So what is compared is what
can be compared exactly:

* what the picture is drawn from, made again and compared byte for byte: the run's JSON report and
  its signals as CSV (run pictures), the sweep's JSON report (verdict maps), the ``dot`` source
  (tree pictures), the replay page's HTML and the steps taken in it (screenshots);
* a SUMO run's data only where the SUMO (libsumo) that made the picture is the one installed;
* matplotlib's own drawing, where the matplotlib that made the picture is the one installed: the
  figure as SVG, made again and compared byte for byte (the project's ``--plot`` SVG is
  deterministic for one matplotlib);
* the picture file itself against the record written with it, so that a picture is never replaced
  or edited by hand without the record.

The 500-entry case of the pictures and of the tests is :func:`timeline_case`:
a chain of 100 ramps of ``level``, each with four side branches (a wait,
three holds), ``R1`` (a record) and ``F1`` (a final) that pass.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import io
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from typing import Any, Callable, Iterator

ROOT = pathlib.Path(__file__).resolve().parent.parent
IMAGES = ROOT / "docs" / "images"
RECORD = IMAGES / "pictures.json"
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SAMPLE = re.compile(r"^<!-- sample(?: (?P<kind>pytest|python))?(?: \((?P<inputs>[^)]+)\))?(?: file: (?P<file>\S+)|: (?P<args>.+?))? -->\n"
                    r"(?P<fence>```\w*\n)(?P<body>.*?)^```", re.S | re.M)  # fmt: skip
FENCE = re.compile(r"^```\w*\n(.*?)^```", re.S | re.M)
PROMPT = "$ python -m btgen_pytrees "
CORPUS = pathlib.Path(os.environ.get("BTGEN_OSC_CORPUS", "/work/shared/corpus/openscenario/alks"))
"""The ALKS OpenSCENARIO corpus (BMW's, MPL-2.0: not part of this repository), as tests/test_openscenario.py finds it."""
IN_CORPUS = re.compile(r"in corpus(?:/(?P<dir>[\w.-]+(?:/[\w.-]+)*))?")
INPUT = re.compile(r"(?P<name>[\w.-]+(?:/[\w.-]+)*) = (?:the (?:(?P<nth>\d+)(?:st|nd|rd|th) )?block above|(?P<path>[\w.-]+(?:/[\w.-]+)*))")
EXCERPT = re.compile(r"(?P<args>.*?)(?: \| (?P<rule>lines|section|usage)(?: (?P<what>.+))?)?")
TITLE = re.compile(r"(?:_{3,}|={3,}) (?P<title>.*?) (?:_{3,}|={3,})")
DURATION = re.compile(r" in \d+(?:\.\d+)?s(?: \(\d+:\d\d:\d\d\))?$")


def timeline_case(n: int = 500) -> dict[str, Any]:
    """A generated case of *n* execute entries (n a multiple of 5) that passes: the large-case pictures and tests."""
    entries: list[dict[str, Any]] = []
    for g in range(n // 5):
        head = f"E{g}"
        after = [f"E{g - 1}"] if g else []
        entries.append({"id": head, "kind": "behavior", "action": "ramp", "after": after,
                        "params": {"signal": "level", "to": g % 7, "duration": 0.2}})  # fmt: skip
        for b in range(4):  # a wait and three holds: only the chain writes a signal (no overlap warning)
            action, params = ("wait", {"duration": 0.1}) if b == 0 else ("hold", {"duration": 0.1 * b})
            entries.append({"id": f"E{g}_{b}", "kind": "constraint" if b == 0 else "behavior", "action": action,
                            "after": [head], "params": params})  # fmt: skip
    return {
        "name": f"timeline_{n}",
        "signals": {"level": 0},
        "tick": 0.1,
        "timeout": n,
        "execute": entries,
        "oracle": {"criteria": [
            {"id": "R1", "type": "record", "expect": "level <= 10", "name": "level stays low"},
            {"id": "F1", "type": "final", "expect": "level >= 0"},
        ]},  # fmt: skip
    }


def fig1_fast() -> dict[str, Any]:
    """fig1, but B2 ramps the speed to 40: R1 (speed <= 30) fails at 1.6 s (docs/views.md)."""
    data = json.loads((ROOT / "examples" / "fig1.json").read_text(encoding="utf-8"))
    data["execute"][2]["params"]["to"] = 40
    return data  # type: ignore[no-any-return]


# -- running the command line in this process -------------------------------------------------------------


@contextlib.contextmanager
def inside(directory: pathlib.Path) -> Iterator[None]:
    """Run from *directory*, in a terminal 80 columns wide (argparse's help wraps at its width)."""
    before, columns = os.getcwd(), os.environ.get("COLUMNS")
    os.chdir(directory)
    os.environ["COLUMNS"] = "80"
    try:
        yield
    finally:
        os.chdir(before)
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns


def cli(args: list[str], cwd: pathlib.Path = ROOT) -> str:
    """What ``python -m btgen_pytrees ARGS`` prints, stdout then stderr, run in this process from *cwd*."""
    from btgen_pytrees.cli import main

    both = io.TextIOWrapper(io.BytesIO(), encoding="utf-8", newline="\n", write_through=True)  # a UTF-8 terminal
    with inside(cwd), contextlib.redirect_stdout(both), contextlib.redirect_stderr(both):
        main(args)
    return both.buffer.getvalue().decode("utf-8")  # type: ignore[attr-defined]


def child(argv: list[str], cwd: pathlib.Path) -> str:
    """What ``python ARGV`` prints from *cwd* in a child process (see the module's docstring), stdout then stderr."""
    env = {name: value for name, value in os.environ.items()
           if not name.startswith("PYTEST_") and name not in ("CI", "BUILD_NUMBER")}  # on CI pytest does not shorten lines
    env.update(COLUMNS="80", PY_COLORS="0", PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, *argv], cwd=cwd, env=env, capture_output=True, encoding="utf-8", timeout=300, check=False)
    return done.stdout + done.stderr


def pytest_output(args: list[str], cwd: pathlib.Path = ROOT) -> str:
    """What ``pytest ARGS`` prints from *cwd* (a child process; see the module's docstring), its duration left out."""
    if not {"-q", "--quiet"} & set(args):
        raise ValueError(f"a pytest sample needs -q (pytest's header names the machine): {shlex.join(args)}")
    lines = child(["-m", "pytest", "-p", "no:randomly", "-p", "no:cacheprovider", "-p", "no:hypothesispytest", *args], cwd).splitlines()
    if lines:
        lines[-1] = DURATION.sub("", lines[-1])
    return "".join(line + "\n" for line in lines)


def python_output(args: list[str], cwd: pathlib.Path = ROOT) -> str:
    """What ``python ARGS`` prints from *cwd* (a child process: a program that changes its process changes no other)."""
    return child(args, cwd)


RUNNERS: dict[str | None, tuple[str, Callable[[list[str], pathlib.Path], str]]] = {
    None: (PROMPT, cli), "pytest": ("$ pytest ", pytest_output), "python": ("$ python ", python_output)}
"""Each sample kind's prompt and what runs it."""


# -- sample outputs ---------------------------------------------------------------------------------------


def excerpt(text: str, rule: str | None, what: str | None) -> str:
    """The part of *text* that *rule* keeps (``lines REGEX``, ``section TITLE``, ``usage``: the module's docstring)."""
    if rule is None:
        return text
    lines = text.splitlines()
    if rule == "usage":
        kept = lines[:lines.index("")] if "" in lines else lines
        return "".join(line + "\n" for line in kept)
    if rule == "lines":
        keep = [re.search(what or "", line) is not None for line in lines]
    else:
        keep, inside_it = [], False
        for line in lines:
            title = TITLE.fullmatch(line)
            inside_it = title["title"] == what if title else inside_it
            keep.append(inside_it)
    if not any(keep):
        raise ValueError(f"'{rule} {what}' keeps no line of:\n{text}")
    shown, before = [], True
    for line, kept_line in zip(lines, keep):
        if kept_line or before:
            shown.append(line if kept_line else "...")
        before = kept_line
    return "".join(line + "\n" for line in shown)


def inputs(match: re.Match[str]) -> dict[str, str]:
    """The files a sample runs with, by name: ``(NAME = SOURCE, ...)`` (the module's docstring)."""
    if not match["inputs"]:
        return {}
    above = FENCE.findall(match.string[:match.start()])
    files = {}
    for spec in match["inputs"].split(", "):
        found = INPUT.fullmatch(spec)
        if found is None or ".." in found["name"].split("/"):
            raise ValueError(f"not NAME = the block above, the Nth block above or a repository path: {spec!r}")
        files[found["name"]] = ((ROOT / found["path"]).read_text(encoding="utf-8") if found["path"]
                                else above[-int(found["nth"] or 1)])  # fmt: skip
    return files


def sample_text(match: re.Match[str]) -> str:
    """What the block after a ``<!-- sample ... -->`` comment must hold."""
    if match["file"]:
        return (ROOT / match["file"]).read_text(encoding="utf-8")
    if match["args"]:
        parts = EXCERPT.fullmatch(match["args"])
        assert parts is not None  # every text matches
        args = parts["args"]
        typed, run = RUNNERS[match["kind"]]
        typed += args
        prompt = typed + "\n" if match["body"].startswith("$ ") else ""
        corpus = IN_CORPUS.fullmatch(match["inputs"] or "")
        if corpus:
            where = CORPUS / (corpus["dir"] or "")
            return prompt + excerpt(run(shlex.split(args), where), parts["rule"], parts["what"])
        files = inputs(match)
        if not files:
            return prompt + excerpt(run(shlex.split(args)), parts["rule"], parts["what"])
        with tempfile.TemporaryDirectory(prefix="btgen-sample-") as scratch:
            for name, text in files.items():
                (pathlib.Path(scratch) / name).parent.mkdir(parents=True, exist_ok=True)
                (pathlib.Path(scratch) / name).write_text(text, encoding="utf-8")
            return prompt + excerpt(run(shlex.split(args), pathlib.Path(scratch)), parts["rule"], parts["what"])
    text = ""
    for line in match["body"].splitlines():
        if line.startswith(PROMPT):
            text += line + "\n" + cli(shlex.split(line[len(PROMPT):]))
    return text


def missing(match: re.Match[str]) -> str | None:
    """What a sample needs that is not here: the corpus of an ``(in corpus...)`` sample, libsumo for a SUMO case."""
    if match["file"]:
        return None
    in_corpus = (match["inputs"] or "").startswith("in corpus")
    if in_corpus and not CORPUS.is_dir():
        return "the OpenSCENARIO corpus"
    if (in_corpus or "sumo" in (match["inputs"] or "") + (match["args"] or match["body"])) and importlib.util.find_spec("libsumo") is None:
        return "libsumo"
    return None


def samples(write: bool = False, skip: Callable[[str], None] | None = None) -> list[str]:
    """Every sample whose block is not what its command prints now (``DOC: args``); with *write*, fix them.

    A sample that cannot be made here (:func:`missing`: a SUMO case without libsumo, a sample of the corpus without
    it) is passed to *skip* (``DOC: args (needs WHAT)``), or reported without it.
    """
    stale = []
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")

        def made_again(m: re.Match[str]) -> str:
            needed = missing(m)
            if needed:
                (skip or stale.append)(f"{doc.name}: {m['args'] or 'session'} (needs {needed})")
                return m.group(0)
            return m.group(0)[:m.start("body") - m.start()] + sample_text(m) + "```"

        made = SAMPLE.sub(made_again, text)
        if made != text:
            olds, news = SAMPLE.finditer(text), SAMPLE.finditer(made)
            stale += [f"{doc.name}: {old['file'] or old['args'] or 'session'}" for old, new in zip(olds, news)
                      if old["body"] != new["body"]]  # fmt: skip
            if write:
                doc.write_text(made, encoding="utf-8")
    return stale


# -- pictures ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Picture:
    """One picture of docs/images/: made from *run* (a key of :data:`RUNS`) as *kind* shows it.

    kind: ``tree`` (``--format svg``, Graphviz), ``plot`` (``run --plot``, matplotlib), ``map`` (a sweep's
    ``run --plot``), ``replay`` (a screenshot of ``run --replay`` at *tick*, after finding *search*).
    """

    file: str
    run: str
    kind: str
    tick: int = 0
    search: str = ""


RUNS: dict[str, str | Callable[[], dict[str, Any]]] = {
    "fig1": "examples/fig1.json",
    "fig1_fast": fig1_fast,
    "fig1_failing": "examples/fig1_failing.json",
    "cut_in": "examples/sumo/cut_in.json",
    "timeline_500": timeline_case,
    "fig1_sweep": "examples/fig1_sweep.json",
    "cut_in_sweep": "examples/sumo/cut_in_sweep.json",
}
PICTURES = (
    Picture("fig1.svg", "fig1", "tree"),
    Picture("fig1-run.svg", "fig1", "plot"),
    Picture("fig1-fast-run.svg", "fig1_fast", "plot"),
    Picture("cut_in-run.svg", "cut_in", "plot"),
    Picture("timeline_500-run.png", "timeline_500", "plot"),
    Picture("fig1_sweep_map.svg", "fig1_sweep", "map"),
    Picture("cut_in_sweep_map.svg", "cut_in_sweep", "map"),
    Picture("fig1-replay.png", "fig1_failing", "replay", tick=12),
    Picture("cut_in-replay.png", "cut_in", "replay", tick=38),
    Picture("timeline_500-replay.png", "timeline_500", "replay", tick=40, search="E99_3"),
)
WINDOW = (1400, 820)
"""The browser window of the screenshots."""


def case_path(run: str, scratch: pathlib.Path) -> tuple[str, pathlib.Path]:
    """*run*'s case as a path and the directory to run it from: a file of the repository from its root,
    a generated case written to *scratch* and run from there (so that reports name it alike everywhere)."""
    source = RUNS[run]
    if isinstance(source, str):
        return source, ROOT
    (scratch / f"{run}.json").write_text(json.dumps(source()), encoding="utf-8")
    return f"{run}.json", scratch


def made_by(picture: Picture) -> str:
    source = RUNS[picture.run]
    case = source if isinstance(source, str) else f"{picture.run}.json ({source.__name__}() in docs/pictures.py)"
    out = f"docs/images/{picture.file}"
    if picture.kind == "tree":
        return f"python -m btgen_pytrees {case} --format svg -o {out}"
    if picture.kind in ("plot", "map"):
        return f"python -m btgen_pytrees run {case} --plot {out}"
    found = f", found {picture.search!r}" if picture.search else ""
    return f"python -m btgen_pytrees run {case} --replay PAGE; Chromium at {WINDOW[0]}x{WINDOW[1]}, tick {picture.tick + 1}{found}"


def matplotlib_version() -> str | None:
    if importlib.util.find_spec("matplotlib") is None:
        return None
    import matplotlib

    return str(matplotlib.__version__)


def sumo_version() -> str | None:
    """The installed libsumo's version: a SUMO run's numbers are compared only with the same SUMO's."""
    if importlib.util.find_spec("libsumo") is None:
        return None
    from importlib import metadata

    return metadata.version("libsumo")


def drawn_from(run: str, scratch: pathlib.Path) -> dict[str, bytes]:
    """Everything *run*'s pictures are drawn from, made now: ``tree.dot``, ``report.json``, ``signals.csv``,
    ``replay.html``, and the figure as ``figure.svg`` when matplotlib is installed."""
    kinds = {p.kind for p in PICTURES if p.run == run}
    case, cwd = case_path(run, scratch)
    out = scratch / run
    out.mkdir(exist_ok=True)
    files: dict[str, pathlib.Path] = {}
    if "tree" in kinds:
        (out / "tree.dot").write_text(cli([case, "--format", "dot"], cwd), encoding="utf-8")
        files["tree.dot"] = out / "tree.dot"
    if kinds - {"tree"}:
        args = ["run", case, "--json", str(out / "report.json")]
        files["report.json"] = out / "report.json"
        if "map" not in kinds:
            args += ["--signals-out", str(out / "signals.csv")]
            files["signals.csv"] = out / "signals.csv"
        if "replay" in kinds:
            args += ["--replay", str(out / "replay.html")]
            files["replay.html"] = out / "replay.html"
        if kinds & {"plot", "map"} and matplotlib_version():
            args += ["--plot", str(out / "figure.svg")]
            files["figure.svg"] = out / "figure.svg"
        cli(args, cwd)
    return {name: path.read_bytes() for name, path in files.items()}


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def picture_record(picture: Picture, made: dict[str, bytes]) -> dict[str, Any]:
    """What the record keeps of *picture*, drawn from *made* (the file itself excluded)."""
    names = {"tree": ["tree.dot"], "plot": ["report.json", "signals.csv"], "map": ["report.json"],
             "replay": ["replay.html"]}[picture.kind]  # fmt: skip
    record: dict[str, Any] = {"made_by": made_by(picture), "drawn_from": {n: digest(made[n]) for n in names}}
    if picture.kind in ("plot", "map"):
        record["figure.svg"] = digest(made["figure.svg"])
    return record


def needs(picture: Picture) -> list[str]:
    """What is missing here to make *picture* again: ``libsumo`` for the SUMO runs, ``matplotlib``."""
    missing = []
    if "sumo" in str(RUNS[picture.run]) and importlib.util.find_spec("libsumo") is None:
        missing.append("libsumo")
    if picture.kind != "tree" and not matplotlib_version():
        missing.append("matplotlib")
    return missing


def read_record() -> dict[str, Any]:
    return json.loads(RECORD.read_text(encoding="utf-8")) if RECORD.exists() else {"pictures": {}}  # type: ignore[no-any-return]


def stale_pictures(skip: Callable[[Picture, list[str], bool], None] | None = None) -> list[str]:
    """Every picture that is not what the project draws now, with why (see the module's docstring).

    *skip(picture, reasons, missing)* is called for a picture that cannot be checked here: a component is
    missing (*missing* true), or it was drawn from a run of another SUMO than the one installed (a SUMO
    release may move a vehicle by a millimetre). Without *skip* such a picture is reported stale.
    """
    record = read_record()
    stale = []
    with tempfile.TemporaryDirectory(prefix="btgen-pictures-") as tmp:
        made: dict[str, dict[str, bytes]] = {}
        for picture in PICTURES:
            kept = record["pictures"].get(picture.file)
            path = IMAGES / picture.file
            if kept is None or not path.exists():
                stale.append(f"{picture.file}: not made by docs/pictures.py (no record, or no file)")
                continue
            if kept["sha256"] != digest(path.read_bytes()):
                stale.append(f"{picture.file}: the file is not the one its record was written with")
                continue
            missing = needs(picture)
            other = [f"SUMO {kept['sumo']} (here {sumo_version()})"] if not missing and kept.get("sumo", sumo_version()) != sumo_version() else []
            if missing or other:
                if skip is None:
                    stale.append(f"{picture.file}: cannot be checked without {', '.join(missing or other)}")
                else:
                    skip(picture, missing or other, bool(missing))
                continue
            if picture.run not in made:
                made[picture.run] = drawn_from(picture.run, pathlib.Path(tmp))
            now = picture_record(picture, made[picture.run])
            for name, value in now["drawn_from"].items():
                if kept["drawn_from"].get(name) != value:
                    stale.append(f"{picture.file}: its {name} is not what the project makes now")
            if "figure.svg" in now and kept.get("matplotlib") == matplotlib_version() and kept["figure.svg"] != now["figure.svg"]:
                # what it is drawn from is the same (checked above): the same matplotlib release on another Python
                # build (Debian's 3.11.2 against pyenv's 3.11.7) was seen drawing cut_in-run.svg's SVG differently
                if skip is None:
                    stale.append(f"{picture.file}: matplotlib {kept['matplotlib']} draws it differently here")
                else:
                    skip(picture, [f"the SVG matplotlib {kept['matplotlib']} draws here (its data is the same)"], False)
            if kept["made_by"] != now["made_by"]:
                stale.append(f"{picture.file}: made by {kept['made_by']!r}, not {now['made_by']!r}")
    return stale


def make_pictures(kinds: set[str]) -> None:
    """Make the pictures of *kinds* and write their record."""
    record = read_record()
    with tempfile.TemporaryDirectory(prefix="btgen-pictures-") as tmp:
        made: dict[str, dict[str, bytes]] = {}
        for picture in PICTURES:
            if picture.kind not in kinds:
                continue
            if picture.run not in made:
                made[picture.run] = drawn_from(picture.run, pathlib.Path(tmp))
            target = IMAGES / picture.file
            if picture.kind == "replay":
                sys.path.insert(0, str(ROOT / "tests"))
                from browser import screenshot  # tests/browser.py: Debian's chromium through selenium

                page = pathlib.Path(tmp) / picture.run / "replay.html"
                screenshot(page, str(target), tick=picture.tick, search=picture.search, window=WINDOW)
            else:
                case, cwd = case_path(picture.run, pathlib.Path(tmp))
                args = [case, "--format", "svg", "-o", str(target)] if picture.kind == "tree" else ["run", case, "--plot", str(target)]
                cli(args, cwd)
            entry = picture_record(picture, made[picture.run])
            if "figure.svg" in entry:
                entry["matplotlib"] = matplotlib_version()
            if "sumo" in str(RUNS[picture.run]):
                entry["sumo"] = sumo_version()
            entry["sha256"] = digest(target.read_bytes())
            record["pictures"][picture.file] = entry
            print(f"docs/images/{picture.file}: {entry['made_by']}")
    record["pictures"] = dict(sorted(record["pictures"].items()))
    RECORD.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.path.insert(0, str(ROOT))
    if "--check" in sys.argv:
        problems = samples() + stale_pictures()
        print("\n".join(problems) or "every picture and sample is what the project makes now")
        sys.exit(1 if problems else 0)
    which = sys.argv[1:] or ["plots", "replay", "samples"]
    if "plots" in which:
        make_pictures({"tree", "plot", "map"})
    if "replay" in which:
        make_pictures({"replay"})
    if "samples" in which:
        for name in samples(write=True):
            print(f"rewritten: {name}")
