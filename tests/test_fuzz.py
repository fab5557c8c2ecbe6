"""Fuzz the CLI with mutated test cases: no traceback, no hang, a JSON path for every problem.

Each example takes a valid test case (``examples/fig1.json`` or one of two cases
below), applies one to four *structure-aware* mutations at random JSON paths
(drop, duplicate, rename a key, retarget a reference, replace a value by one of
another type, a huge or odd number, a deeply nested value, a unicode id, a 1 MB
string, ...), dumps it and sometimes damages the text itself (truncate, flip
bytes, insert bytes, encode as UTF-16). A third of the examples get gentle
mutations only (small numbers, other strings of the case, dropped keys, copied
entries), so that ``show`` and ``run`` see many odd but valid cases. The file is
then given to the CLI,
in-process, as ``validate FILE``, ``show FILE -f json`` and ``run FILE``. Asserted:

* exit code 0 or 2 for validate/show, 0, 1 or 2 for run (1 is a legitimate
  fail/timeout verdict), never 3 (internal error), and the three agree on 2;
* a run of a case the loader accepted never ends in the ``error`` verdict (a leaf
  raised: the loader let through a value the leaves cannot handle);
* no ``Traceback`` and no warning on stderr, nothing on stdout when the exit is 2,
  and valid JSON from ``show -f json`` when it is 0;
* for exit 2, stderr holds exactly one ``FILE: /json/pointer: message`` line per
  problem, and every pointer points into the document (or at a defaulted key of an
  object in it);
* each command ends (``run`` is only started when the case takes at most
  :data:`RUN_TICKS` ticks): one still running after :data:`HANG_SECONDS` is cut by
  an alarm and the example fails. That is a liveness bound, not a speed check (speed
  is measured in benchmarks): the commands take well under a second here.

CI runs 200 examples, derandomized (the same ones every time; ~4 s). A longer,
random run - do one before a release or after touching the loader, expressions
or CLI::

    BTGEN_FUZZ_EXAMPLES=20000 python -m pytest tests/test_fuzz.py -q -k fuzz_cli

(about 7 minutes on one core). It draws new examples each time; a failure prints the
``@seed``/``@reproduce_failure`` line that replays it. ``BTGEN_FUZZ_SEED=N``
fixes the seed of a long run; ``--hypothesis-show-statistics`` shows how many
examples ended in which exit codes.

The rest of the file: regressions for what the fuzzer found, bounded reading of
large files (:data:`btgen_pytrees.load.MAX_FILE_BYTES`), and fixes outside
the loader.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import os
import pathlib
import re
import signal
import subprocess
import sys
import tracemalloc
import warnings
from dataclasses import dataclass
from typing import Any, Iterator

import pytest
from hypothesis import HealthCheck, event, given, seed, settings
from hypothesis import strategies as st

import btgen_pytrees
from btgen_pytrees import InvalidTestCase
from btgen_pytrees.cli import main
from btgen_pytrees.load import MAX_FILE_BYTES, MAX_NESTING, load_json

ROOT = pathlib.Path(__file__).resolve().parent.parent

HANG_SECONDS = 30
"""A command still running after this is interrupted (SIGALRM) and the example fails.

Generous on purpose: it separates "ends" from "hangs" (or does work far beyond what the input
size calls for) on any machine, and is never a measure of speed."""

RUN_TICKS = 1000
"""``run`` is fuzzed only on cases of at most this many ticks (``timeout / tick``)."""

_LONG = int(os.environ.get("BTGEN_FUZZ_EXAMPLES", "0"))
FUZZ_SETTINGS = settings(
    max_examples=_LONG or 200,
    deadline=None,  # the per-command bound above is checked by hand
    derandomize=not _LONG,  # CI: the same examples every run, never flaky
    database=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.large_base_example],
)

# ---------------------------------------------------------------------------
# valid starting points

FIG1 = json.loads((ROOT / "examples" / "fig1.json").read_text(encoding="utf-8"))
MINIMAL = {"name": "m", "execute": [{"id": "A", "kind": "behavior", "action": "hold", "params": {"duration": 1}}]}
RICH = {
    "$schema": "urn:btgen-pytrees:schema:testcase:1",
    "name": "rich",
    "description": "until, relation object, every criterion key",
    "signals": {"speed": 0, "on": False},
    "tick": 0.5,
    "timeout": 20,
    "join": "all",
    "execute": [
        {"id": "S", "kind": "behavior", "action": "ramp", "name": "speed up", "params": {"signal": "speed", "to": 10, "duration": 2}},
        {"id": "W", "kind": "constraint", "action": "wait", "params": {"duration": 0.5}},
        {"id": "U", "kind": "constraint", "action": "until", "after": ["S", "W"], "join": "any",
         "params": {"expect": "speed >= 10 && !on", "timeout": 3}},
        {"id": "O", "kind": "behavior", "action": "set", "after": ["U"], "params": {"signal": "on", "value": True, "duration": 1}},
    ],
    "oracle": {
        "relation": {"record": "&&", "others": "||"},
        "criteria": [
            {"id": "R", "type": "record", "expect": "abs(speed) <= max(10, 0) || on", "name": "bounded"},
            {"id": "P", "type": "period", "expect": "speed >= 0", "from": 0.5, "to": 2},
            {"id": "F", "type": "final", "expect": "on == true", "at": 4},
        ],
    },
}  # fmt: skip
BASES = [FIG1, MINIMAL, RICH]

# ---------------------------------------------------------------------------
# values a mutation puts somewhere


@dataclass(frozen=True)
class Raw:
    """JSON text to splice in as is (what json.dumps cannot write: 10**5000, -0, 10k nesting...)."""

    text: str


MEGABYTE = "x" * (1 << 20)
KEYS = [
    "id", "kind", "action", "params", "after", "join", "name", "type", "expect", "from", "to", "at",
    "signals", "tick", "timeout", "execute", "oracle", "criteria", "relation", "record", "others",
    "duration", "value", "signal", "description", "$schema", "afer", "", "Id", "ID ", "é", "a/b", "m~0",
]  # fmt: skip
ODD_IDS = [
    "Ä", "B1\u200b", "\U0001d505", "B\u0301", "ＡＢ", "א", "B1 ", " B1", "B/1", "B~1", "B1\t", "1B", "-B",
    "_", "a" * 64, "a" * 65, "speed", "max", "and", "\u2028", "\x00", "B1\n",
]  # fmt: skip
EXPRESSIONS = [
    "speed <= 30", "0 <= speed < 5", "!(mode == 1) || brake", "max(speed, 1) / 0", "speed % 0", "1e308 * 10",
    "9999999999 * " * 76 + "1", "-" * 999 + "1", "(" * 199 + "1" + ")" * 199, "not " * 249 + "x",
    "speed.__class__", "__import__('os')", "2 ** 10 ** 10", "'a' * 10**9", "0x10", "1or 2", "x if y else z",
    "(lambda: 1)()", "[x for x in y]", "a[0]", "{}", "(x := 1)", "abs", "abs(1, 2)", "min(1)", "max(*x)",
    "True", "None", "1e999", "9" * 41, "", " ", "speed <=", "sp\u00e9ed > 1", "\u0661 > 0",
]  # fmt: skip
DEEP = [
    Raw("[" * n + "]" * n) for n in (MAX_NESTING - 1, MAX_NESTING, MAX_NESTING + 1, 500, 900, 950, 980, 990, 10_000)
] + [Raw('{"a":' * n + "1" + "}" * n) for n in (MAX_NESTING + 1, 985, 10_000)]
HUGE = [  # beyond float range, but they parse: integers of up to 4300 digits, floats that become inf
    Raw("1" + "0" * 400), Raw("1" * 4300), Raw("9" * 309), Raw("-1" + "0" * 4000), Raw("1e999"), Raw("-1e999"),
    Raw("1E400"), Raw("2" * 309 + ".5"), 2**1024, 10**400,
]  # fmt: skip
NUMBERS = HUGE + [
    Raw("1" + "0" * 5000), Raw("1" * 4301), Raw("1" + "0" * 308), Raw("-0"), Raw("-0.0"), Raw("0." + "0" * 400 + "1"),
    Raw("2.5e-324"), 1e308, -1e308, 5e-324, 2**53 + 1, -(2**63), 2**64, 2**1023, 0, -1, 0.1, 1e-9, 1e9, 10_000_000,
]  # fmt: skip
SURROGATES = [Raw('"\\ud800"'), Raw('"a\\udc00b"'), Raw('"B1\\udbff\\udbff"')]  # lone surrogates: valid JSON, not Unicode
ODD_TEXT = SURROGATES + [Raw('"\\u0000"'), MEGABYTE, "é" * (1 << 19), "\U0001f600" * 1000, "\u202e\u200b\ufeff"]


def values(doc: Any) -> st.SearchStrategy[Any]:
    """A replacement value: another type, an odd number, a deep or huge value, text, a value of *doc*."""
    existing = list(_strings(doc))
    return st.one_of(
        st.sampled_from([None, True, False, 0, 1, -1, 1.5, "", "x", [], {}, [1, "a"], {"a": 1}, [[]], {"": {}}]),
        st.sampled_from(NUMBERS),
        st.sampled_from(DEEP),
        st.sampled_from(ODD_TEXT),
        st.sampled_from(ODD_IDS + EXPRESSIONS + KEYS),
        st.sampled_from(existing or [""]),  # retarget a reference to another id/signal
        st.integers(),
        st.floats(allow_nan=False, allow_infinity=False),
        st.text(max_size=20),
        st.text(alphabet="speedmax01.<=>!&|()+-*/% _ex", max_size=40),  # expression-ish
        st.from_regex(r"[A-Za-z_][A-Za-z0-9_-]{0,70}", fullmatch=True),
        st.lists(st.integers(-3, 3), max_size=4),
    )


def same_type(doc: Any, old: Any) -> st.SearchStrategy[Any]:
    """A replacement of the same JSON type as *old*: odd but often still valid, so show/run get exercised."""
    if isinstance(old, bool):
        return st.booleans()
    if isinstance(old, (int, float)):
        small = st.floats(0, 100) | st.sampled_from([0, 0.01, 0.1, 1, 2.5, 30, 1e-300, 5e-324])
        return st.one_of(
            small, st.sampled_from(HUGE), st.sampled_from(NUMBERS), st.integers(), st.floats(allow_nan=False, allow_infinity=False)
        )
    if isinstance(old, str):
        existing = list(_strings(doc)) or [old]
        return st.one_of(
            st.sampled_from(existing),
            st.sampled_from(existing),  # twice: retargeting keeps more cases valid
            st.sampled_from(ODD_IDS + ODD_TEXT),
            st.sampled_from(EXPRESSIONS),
            st.sampled_from(SURROGATES),
            st.text(alphabet="speedmodbrakgt01.<=>!&|()+-*/% _e", min_size=1, max_size=40),
            st.text(min_size=1, max_size=20),
        )
    return values(doc)


def _strings(doc: Any) -> Iterator[str]:
    stack = [doc]
    while stack:
        v = stack.pop()
        if isinstance(v, str) and len(v) < 100:
            yield v
        elif isinstance(v, dict):
            stack.extend(v.values())
            stack.extend(k for k in v if len(k) < 100)
        elif isinstance(v, list):
            stack.extend(v)


# ---------------------------------------------------------------------------
# structure-aware mutations


def _paths(doc: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    yield path
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, (*path, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, (*path, i))


def _get(doc: Any, path: tuple[Any, ...]) -> Any:
    for part in path:
        doc = doc[part]
    return doc


class Mutant:
    """A JSON document under mutation, with raw-text values spliced in when dumped."""

    def __init__(self, doc: Any):
        self.doc = copy.deepcopy(doc)
        self.raws: list[str] = []
        self.log: list[str] = []

    def _hole(self, text: str) -> str:
        self.raws.append(text)
        return f"\x00raw{len(self.raws) - 1}\x00"

    def put(self, path: tuple[Any, ...], value: Any) -> None:
        value = self._hole(value.text) if isinstance(value, Raw) else value
        if path:
            _get(self.doc, path[:-1])[path[-1]] = value
        else:
            self.doc = value

    def text(self, ensure_ascii: bool) -> str:
        out = json.dumps(self.doc, ensure_ascii=ensure_ascii)
        for i in reversed(range(len(self.raws))):  # a later raw may contain an earlier hole
            out = out.replace(json.dumps(f"\x00raw{i}\x00"), self.raws[i])
        return out

    def dumps_object(self, obj: dict[str, Any], duplicate: str) -> str:
        """*obj* as JSON text with key *duplicate* written twice (json.dumps cannot)."""
        items = [*obj.items(), (duplicate, obj[duplicate])]
        return "{" + ", ".join(f"{json.dumps(k)}: {json.dumps(v)}" for k, v in items) + "}"


def gentle(doc: Any, old: Any) -> st.SearchStrategy[Any]:
    """A plausible replacement (small number, another string of the case): keeps many cases valid."""
    if isinstance(old, bool):
        return st.booleans()
    if isinstance(old, (int, float)):
        return st.sampled_from([0, 0.05, 0.1, 0.5, 1, 2, 3, 10, 25, 59.9]) | st.floats(0, 30) | st.integers(0, 30)
    if isinstance(old, str):
        return st.sampled_from(list(_strings(doc)) or [old])
    return st.just(old)


@st.composite
def mutants(draw: Any) -> tuple[bytes, list[str]]:
    m = Mutant(draw(st.sampled_from(BASES)))
    mild = draw(st.sampled_from([False, False, True]))  # a third of the cases: gentle mutations only
    m.log.append("gentle" if mild else "wild")
    for _ in range(draw(st.sampled_from([1, 1, 1, 2, 3, 4]))):
        paths = list(_paths(m.doc))[::-1]  # leaves first: hypothesis favours early elements
        want = draw(st.sampled_from([str, float, object]))  # numbers are few: aim at them a third of the time
        aimed = [p for p in paths if isinstance(_get(m.doc, p), want) or want is float and type(_get(m.doc, p)) is int]
        path = draw(st.sampled_from(aimed or paths))
        target = _get(m.doc, path)
        parent = _get(m.doc, path[:-1]) if path else None
        if mild:
            op = draw(st.sampled_from(["tweak", "tweak", "drop", "duplicate"]))
            m.log.append(f"gentle {op} {path!r}")
            if op == "tweak" or not path:
                m.put(path, draw(gentle(m.doc, target)))
            elif op == "drop":
                del parent[path[-1]]
            elif isinstance(parent, list):  # duplicate an item; an entry or criterion gets a fresh id
                twin = copy.deepcopy(target)
                if isinstance(twin, dict) and isinstance(twin.get("id"), str):
                    twin["id"] += f"_{len(parent)}"
                parent.insert(path[-1] + 1, twin)
            continue
        ops = ["tweak"] * 4 + ["replace", "swap", "wrap"]
        if isinstance(parent, list):
            ops += ["drop", "duplicate"]
        if isinstance(parent, dict):
            ops += ["drop", "rename", "duplicate key"]
        if isinstance(target, dict):
            ops += ["add"]
        op = draw(st.sampled_from(ops))
        m.log.append(f"{op} {path!r}")
        if op == "tweak":
            m.put(path, draw(same_type(m.doc, target)))
        elif op == "replace":
            m.put(path, draw(values(m.doc)))
        elif op == "swap":  # put a copy of another subtree here
            m.put(path, copy.deepcopy(_get(m.doc, draw(st.sampled_from(paths)))))
        elif op == "wrap":
            m.put(path, draw(st.sampled_from([[target], {"value": target}])))
        elif op == "drop":
            del parent[path[-1]]
        elif op == "duplicate":
            parent.insert(path[-1], copy.deepcopy(target))
        elif op == "duplicate key":  # the same key twice in one object: raw text
            m.put(path[:-1], Raw(m.dumps_object(parent, path[-1])))
        elif op == "rename":
            new = draw(st.sampled_from(KEYS) | st.text(max_size=8))
            parent[new] = parent.pop(path[-1])
        elif op == "add":
            key = draw(st.sampled_from(KEYS + ODD_IDS))
            target[key] = None
            m.put((*path, key), draw(values(m.doc)))
    data = m.text(ensure_ascii=draw(st.booleans())).encode("utf-8", "surrogatepass")
    raw_ops = ["truncate", "flip", "insert", "delete", "utf16", "bom"]
    raw_op = "none" if mild else draw(st.sampled_from(["none"] * 12 + raw_ops))
    m.log.append(f"text: {raw_op}")
    if raw_op != "none" and data:
        at = draw(st.integers(0, len(data) - 1))
        if raw_op == "truncate":
            data = data[:at]
        elif raw_op == "flip":
            data = data[:at] + bytes([data[at] ^ draw(st.integers(1, 255))]) + data[at + 1 :]
        elif raw_op == "insert":
            data = data[:at] + draw(st.binary(min_size=1, max_size=8)) + data[at:]
        elif raw_op == "delete":
            data = data[:at] + data[at + draw(st.integers(1, 64)) :]
        elif raw_op == "utf16":
            data = data.decode("utf-8", "surrogatepass").encode("utf-16", "surrogatepass")
        elif raw_op == "bom":
            data = b"\xef\xbb\xbf" + data
    return data, m.log


# ---------------------------------------------------------------------------
# running the CLI in-process


class Hang(BaseException):
    """Raised by the alarm; a BaseException so the CLI's ``except Exception`` cannot swallow it."""


@contextlib.contextmanager
def alarm(seconds: float) -> Iterator[None]:
    if not hasattr(signal, "setitimer"):  # Windows: no alarm, a hang is not cut
        yield
        return

    def ring(signum: int, frame: Any) -> None:
        raise Hang(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


@dataclass
class Result:
    code: int
    out: str
    err: bytes
    warnings: list[str]


def cli(*args: str) -> Result:
    """``main(args)`` with streams like a real process's: strict UTF-8 stdout, backslashreplace stderr."""
    out = io.TextIOWrapper(io.BytesIO(), encoding="utf-8", errors="strict")
    err = io.TextIOWrapper(io.BytesIO(), encoding="utf-8", errors="backslashreplace")
    with alarm(HANG_SECONDS), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
            warnings.catch_warnings(record=True) as caught:  # fmt: skip
        warnings.simplefilter("always")
        code = main(list(args))
    out.flush()
    err.flush()
    shown = [f"{w.category.__name__}: {w.message}" for w in caught if not issubclass(w.category, DeprecationWarning)]
    return Result(code, out.buffer.getvalue().decode("utf-8"), err.buffer.getvalue(), shown)  # type: ignore[attr-defined]


def _resolves(doc: Any, path: tuple[Any, ...]) -> bool:
    """*path* names a value of *doc*, or a missing key of an object of *doc* (a defaulted key)."""
    for i, part in enumerate(path):
        if isinstance(doc, dict) and isinstance(part, str) and part in doc:
            doc = doc[part]
        elif isinstance(doc, list) and isinstance(part, int) and 0 <= part < len(doc):
            doc = doc[part]
        else:
            return i == len(path) - 1 and isinstance(doc, dict)
    return True


def check_invalid(path: pathlib.Path, result: Result) -> None:
    """Exit 2: one ``FILE: /pointer: message`` line per problem on stderr, each pointer into the document."""
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(path)
    problems = info.value.problems
    assert problems
    expected = "".join(f"{p.render(str(path))}\n" for p in problems).encode("utf-8", "backslashreplace")
    assert result.err == expected
    lines = result.err.decode("utf-8").split("\n")[:-1]
    assert len(lines) == len(problems), "a problem took more than one line"
    simple = re.compile(rf"^{re.escape(str(path))}: /\S*: .+")
    for line, problem in zip(lines, problems):
        assert problem.message.strip() and problem.pointer.startswith("/")
        if not re.search(r"\s", problem.pointer):
            assert simple.match(line), line
    try:
        doc = load_json(path)
    except InvalidTestCase:
        assert [p.pointer for p in problems] == ["/"]
        return
    for problem in problems:
        assert _resolves(doc, problem.path), f"{problem.pointer} is not in the document"


def check_command(path: pathlib.Path, result: Result, allowed: set[int]) -> None:
    assert result.code in allowed, (result.code, result.err[-2000:])
    assert b"Traceback" not in result.err
    assert not result.warnings, result.warnings
    if result.code == 2:
        assert result.out == ""
        check_invalid(path, result)


def exercise(path: pathlib.Path) -> dict[str, int]:
    """Validate, show and maybe run *path*; check each; return the exit codes."""
    file = str(path)
    validated = cli("validate", file)
    check_command(path, validated, {0, 2})
    shown = cli("show", file, "-f", "json")
    check_command(path, shown, {0, 2})
    assert shown.code == validated.code, "show and validate disagree"
    codes = {"validate": validated.code, "show": shown.code}
    if validated.code == 0:
        assert validated.out.startswith(f"{file}: ok")
        json.loads(shown.out)
        case = btgen_pytrees.load(path)
        if case.timeout / case.tick > RUN_TICKS:
            return codes
    report = path.with_name("report.json")
    report.unlink(missing_ok=True)
    ran = cli("run", file, "--json", str(report))
    check_command(path, ran, {0, 1, 2})
    assert (ran.code == 2) == (validated.code == 2), "run and validate disagree"
    codes["run"] = ran.code
    if ran.code != 2:
        # exit 1 must be a verdict (fail/timeout), not a leaf that raised on a case the loader accepted
        summary = json.loads(report.read_text(encoding="utf-8"))
        assert summary["verdict"] != "error", summary["message"]
        assert (summary["verdict"] == "pass") == (ran.code == 0)
    return codes


def _seeded(test: Any) -> Any:
    return seed(int(os.environ["BTGEN_FUZZ_SEED"]))(test) if os.environ.get("BTGEN_FUZZ_SEED") else test


@_seeded
@FUZZ_SETTINGS
@given(mutant=mutants())
def test_fuzz_cli(tmp_path_factory: pytest.TempPathFactory, mutant: tuple[bytes, list[str]]) -> None:
    data, log = mutant
    path = tmp_path_factory.mktemp("fuzz") / "case.json"
    path.write_bytes(data)
    try:
        codes = exercise(path)
    except AssertionError as exc:
        raise AssertionError(f"{exc}\nmutations: {log}\nfile ({len(data)} bytes) starts: {data[:300]!r}") from None
    event(f"exit codes {codes}")  # see them with --hypothesis-show-statistics


def test_bases_are_valid_and_pass(tmp_path: pathlib.Path) -> None:
    for i, base in enumerate(BASES):
        path = tmp_path / f"base{i}.json"
        path.write_text(json.dumps(base))
        assert exercise(path) == {"validate": 0, "show": 0, "run": 0}, base["name"]


# ---------------------------------------------------------------------------
# what the fuzzer found (each was an exit 3 or worse before the fix)


def _fig1_with(old: str, new: str) -> str:
    text = json.dumps(FIG1)
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize(
    "text, pointer, words",
    [
        # OverflowError in the timeout/tick check (int beyond float range, < 4300 digits so it parses)
        (_fig1_with('"timeout": 60', '"timeout": 1' + "0" * 4000), "/timeout", "number too large"),
        (_fig1_with('"tick": 0.1', '"tick": 1' + "0" * 400), "/tick", "number too large"),
        # passed validation, then OverflowError while running (exit 1 "ERROR" instead of exit 2)
        (_fig1_with('"duration": 2', '"duration": 1' + "0" * 400), "/execute/2/params/duration", "number too large"),
        (_fig1_with('"speed": 0', '"speed": -1' + "0" * 400), "/signals/speed", "number too large"),
        # lone surrogate: UnicodeEncodeError when show/run printed the name
        (_fig1_with('"name": "fig1"', '"name": "fig\\ud8001"'), "/name", "lone surrogate '\\ud800' at character 3"),
        (_fig1_with('"name": "fig1"', '"name": "fig1", "\\udfff": 1'), "/", "key '\\udfff' has a lone surrogate"),
        # RecursionError while an error message showed a ~985-deep value (see also test_deep_values_from_a_shallow_stack)
        (_fig1_with('"relation": "&&"', '"relation": ' + "[" * 500 + "]" * 500), "/oracle/relation" + "/0" * 98, "nested more than 100"),
        (_fig1_with('"mode": 0', '"mode": ' + '{"a":' * 500 + "1" + "}" * 500), "/signals/mode" + "/a" * 98, "nested more than 100"),
        # hex literals were accepted (and escaped the 40-digit limit); "1or 2" printed a SyntaxWarning
        (_fig1_with('"speed <= 30"', '"speed <= 0x' + "f" * 900 + '"'), "/oracle/criteria/0/expect", "invalid number '0xfff"),
        (_fig1_with('"speed <= 30"', '"1or speed"'), "/oracle/criteria/0/expect", "invalid number '1or'"),
    ],
    ids=["timeout", "tick", "duration", "signal", "surrogate", "surrogate-key", "deep-array", "deep-object", "hex", "glued"],
)
def test_fuzz_findings(tmp_path: pathlib.Path, text: str, pointer: str, words: str) -> None:
    path = tmp_path / "case.json"
    path.write_text(text, encoding="utf-8")
    assert exercise(path) == {"validate": 2, "show": 2, "run": 2}
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(path)
    assert [(p.pointer, words in p.message) for p in info.value.problems] == [(pointer, True)], info.value.problems


_DEPTH_SCRIPT = """
import json, sys
from btgen_pytrees.cli import main
fig1 = json.dumps(json.load(open(sys.argv[1])))
for n in [*range(900, 1000, 4), 100_000]:
    for deep in ("[" * n + "]" * n, '{"a":' * n + "1" + "}" * n):
        open(sys.argv[2], "w").write(fig1.replace('"relation": "&&"', '"relation": ' + deep))
        print(n, main(["validate", sys.argv[2]]), file=sys.stderr)
"""


def test_deep_values_from_a_shallow_stack(tmp_path: pathlib.Path) -> None:
    """The ~985-deep crash needs the shallow stack of a real process (in pytest such values do not parse).

    Depths 900-1000 (and 100000) either do not parse ("nested too deeply" at /) or hit the nesting
    limit with a path; before the fix, a few depths just below the parser's limit
    ended in RecursionError (exit 3).
    """
    path = tmp_path / "case.json"
    command = [sys.executable, "-c", _DEPTH_SCRIPT, str(ROOT / "examples" / "fig1.json"), str(path)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    result = subprocess.run(command, capture_output=True, text=True, timeout=120, env=env)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr[-2000:]
    lines = result.stderr.splitlines()
    limit = re.compile(rf"{re.escape(str(path))}: /oracle/relation(/0|/a)+: nested more than 100 levels deep")
    too_deep = f"{path}: /: invalid JSON: nested too deeply"
    problems = [line for line in lines if not re.fullmatch(r"\d+ \d+", line)]
    assert all(limit.fullmatch(line) or line == too_deep for line in problems), problems
    assert [line.split()[1] for line in lines if re.fullmatch(r"\d+ \d+", line)] == ["2"] * 52
    assert any(limit.fullmatch(line) for line in problems) and too_deep in problems  # both sides of the parser's limit


def test_value_limits_apply_to_dicts_too() -> None:
    """``load(dict)`` skips the JSON reader; the value checks still run (no OverflowError/RecursionError)."""
    deep: Any = 1
    for _ in range(5000):
        deep = [deep]
    for data, pointer in [
        ({**FIG1, "timeout": 10**5000}, "/timeout"),  # too long even to repr
        ({**FIG1, "signals": {"s": deep}}, "/signals/s" + "/0" * (MAX_NESTING - 2)),
    ]:
        with pytest.raises(InvalidTestCase) as info:
            btgen_pytrees.load(data)
        assert [p.pointer for p in info.value.problems] == [pointer]


def test_nesting_up_to_the_limit_is_accepted_where_free_form() -> None:
    """Plugin params may nest; the limit is far above anything the format needs."""
    deep: Any = 1
    for _ in range(MAX_NESTING - 5):
        deep = [deep]
    data = {**MINIMAL, "execute": [{**MINIMAL["execute"][0], "params": {"duration": deep}}]}
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(data)
    assert [p.pointer for p in info.value.problems] == ["/execute/0/params/duration"]  # a type error, not a limit


# ---------------------------------------------------------------------------
# large files: refused before reading, in bounded memory


def _peak_bytes(fn: Any) -> int:
    tracemalloc.start()
    try:
        fn()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak


def test_50_mb_file_is_refused_in_bounded_memory(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "big.json"
    with open(path, "wb") as fh:  # a sparse 50 MB file: quick to make, would be 50 MB to read
        fh.write(b'{"name": "big", "description": "')
        fh.truncate(50 * 1024 * 1024)
    caught: list[InvalidTestCase] = []

    def load() -> None:
        try:
            btgen_pytrees.load(path)
        except InvalidTestCase as exc:
            caught.append(exc)

    with alarm(HANG_SECONDS):  # a liveness bound only: the memory peak shows the file was not read
        peak = _peak_bytes(load)
    assert peak < 1024 * 1024, f"peak {peak} bytes"
    [problem] = caught[0].problems
    assert problem.pointer == "/" and problem.cause == "limit"
    assert problem.message == f"file is {50 * 1024 * 1024} bytes; the limit is {MAX_FILE_BYTES}"
    result = cli("validate", str(path))
    assert result.code == 2 and result.err.decode().startswith(f"{path}: /: file is 52428800 bytes; the limit is")


def test_limit_boundary(tmp_path: pathlib.Path) -> None:
    """Exactly MAX_FILE_BYTES loads; one byte more is refused."""
    text = json.dumps(MINIMAL).encode()
    path = tmp_path / "edge.json"
    path.write_bytes(text + b" " * (MAX_FILE_BYTES - len(text)))
    assert path.stat().st_size == MAX_FILE_BYTES
    assert btgen_pytrees.load(path).name == "m"
    with open(path, "ab") as fh:
        fh.write(b" ")
    with pytest.raises(InvalidTestCase, match="the limit is") as info:
        btgen_pytrees.load(path)
    assert info.value.problems[0].cause == "limit"


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_endless_file_is_refused_unread() -> None:
    """A device whose size stat() cannot tell is not read at all (issue 13: only regular files are inputs)."""
    caught: list[InvalidTestCase] = []

    def load() -> None:
        try:
            btgen_pytrees.load("/dev/zero")
        except InvalidTestCase as exc:
            caught.append(exc)

    with alarm(HANG_SECONDS):  # reading it would never end; the bound only tells "ends" from "hangs"
        peak = _peak_bytes(load)
    assert peak < 1024 * 1024, f"peak {peak} bytes"  # not a byte of it was held: refused before reading
    assert caught[0].problems[0].message == "not a regular file (a device)"


def test_10_mb_files(tmp_path: pathlib.Path) -> None:
    """Under the limit: a padded valid case loads; a 10 MB description is one clear problem."""
    padded = tmp_path / "padded.json"
    text = json.dumps(FIG1)
    padded.write_text(text[:-1] + " " * (10 * 1024 * 1024) + "}")
    with alarm(HANG_SECONDS):  # liveness, not speed: anything quadratic in 10 MB would not end for hours
        assert len(btgen_pytrees.load(padded).entries) == 6
    long = tmp_path / "long.json"
    long.write_text(json.dumps({**FIG1, "description": "d" * (10 * 1024 * 1024)}))
    with alarm(HANG_SECONDS), pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(long)
    [problem] = info.value.problems
    assert problem.pointer == "/description" and "is too long" in problem.message and len(problem.message) <= 200


# ---------------------------------------------------------------------------
# found outside the loader, fixed


def test_newline_in_key_stays_on_one_problem_line(tmp_path: pathlib.Path) -> None:
    """Found by the fuzzer: a key's control characters are escaped when a problem is rendered."""
    path = tmp_path / "case.json"
    path.write_text(json.dumps({**FIG1, "a\nb": 1}))
    result = cli("validate", str(path))
    assert result.code == 2
    [line] = result.err.decode().splitlines()  # the list of allowed keys grows with the format
    assert line.startswith(f"{path}: /a\\x0ab: unknown key 'a\\nb' (allowed: $schema, description, execute, ")


def test_a_fifo_is_refused_without_waiting(tmp_path: pathlib.Path) -> None:
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(InvalidTestCase, match="not a regular file"):
        btgen_pytrees.load(fifo)


@pytest.mark.parametrize(
    "data, pointer",
    [
        ({**MINIMAL, "execute": [{**MINIMAL["execute"][0], "id": "A\n"}]}, "/execute/0/id"),
        ({**MINIMAL, "signals": {"s\n": 1}}, "/signals"),
        ({**MINIMAL, "execute": [{"id": "A", "kind": "behavior", "action": "set", "params": {"signal": "s\n", "value": 1}}]},
         "/execute/0/params/signal"),
    ],
    ids=["id", "signal-name", "signal-param"],
)  # fmt: skip
def test_trailing_newline_is_not_part_of_a_name(data: dict[str, Any], pointer: str) -> None:
    """Found by the fuzzer, fixed in the schema: Python's '$' also matched before a final newline."""
    with pytest.raises(InvalidTestCase) as info:
        btgen_pytrees.load(data)
    assert [p.pointer for p in info.value.problems] == [pointer]
