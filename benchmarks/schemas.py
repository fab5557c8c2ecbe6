"""Schema validation alternatives, timed on the benchmark's own input.

Loading is dominated by JSON Schema validation (see ``docs/performance.md``),
so this module times the candidates on the same document, with each
validator built once beforehand (as the loader caches its own):

* ``jsonschema`` ``iter_errors`` with the loader's own validator - what the
  loader does today (it keeps every error with its path, which the loader
  turns into messages) - and with the schema as shipped, for reference;
* ``jsonschema`` ``is_valid`` - the same engine stopping at the first error;
  jsonschema has no ahead-of-time compilation, so this is its fastest mode;
* ``fastjsonschema`` - compiles the schema to Python source (first error only);
* ``jsonschema-rs`` ``is_valid`` and ``iter_errors`` - a Rust validator with
  a Python binding (every error, with paths).

Both the test-case schema (the whole document at once) and the per-entry
``params`` schemas (one call per entry, as the semantic stage does) are timed.
Speed is worth nothing if a candidate accepts what the shipped validator
rejects, so each candidate is also run on a handful of broken documents and
must reject every one (``agrees``).

The alternatives are optional: a missing one is reported as such (install
with ``pip install fastjsonschema jsonschema-rs`` to compare them).
"""

from __future__ import annotations

import copy
import gc
from typing import Any, Callable, Iterable, Mapping

import jsonschema

from btgen_pytrees.load import case_validator, schema as case_schema
from btgen_pytrees.leaves import default_registry

from . import timelines
from .measure import CLOCKS

__all__ = ["measure_schemas", "broken_documents"]

Check = Callable[[Any], bool]
"""True when the document is valid."""


def _raises(func: Callable[[Any], Any]) -> Check:
    def check(document: Any) -> bool:
        try:
            func(document)
        except Exception:
            return False
        return True

    return check


LOADER = "jsonschema, the loader's validator"
"""The baseline row: whatever validator the loader uses today, ``iter_errors`` as it calls it."""


def _loader_validator() -> Any:
    """The loader's own cached test-case validator, or ``None`` if it has none we can reach.

    Read defensively: the loader may change how it builds its validator (it did:
    ``$ref``s inlined), and the baseline must follow it.
    """
    make = case_validator
    try:
        return make() if callable(make) else None
    except Exception:
        return None


def _candidates(schema: Mapping[str, Any], used: Any = None) -> dict[str, Check | str]:
    """Each candidate's validity check for *schema*, or why it is unavailable.

    *used* is the jsonschema validator the loader applies to *schema* (the
    baseline); without it the schema as shipped stands in for it.
    """
    out: dict[str, Check | str] = {}
    shipped = jsonschema.validators.validator_for(schema, default=jsonschema.Draft202012Validator)(schema)
    used = used if used is not None else shipped
    out[LOADER] = lambda doc: not list(used.iter_errors(doc))
    out["jsonschema, schema as shipped"] = lambda doc: not list(shipped.iter_errors(doc))
    out["jsonschema is_valid, the loader's validator"] = used.is_valid
    try:
        import fastjsonschema  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except ImportError:
        out["fastjsonschema"] = "not installed"
    else:
        try:
            out["fastjsonschema"] = _raises(fastjsonschema.compile(dict(schema)))
        except Exception as exc:  # an unsupported schema feature is a result too
            out["fastjsonschema"] = f"cannot compile the schema: {type(exc).__name__}: {exc}"
    try:
        import jsonschema_rs  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except ImportError:
        out["jsonschema-rs is_valid"] = out["jsonschema-rs iter_errors"] = "not installed"
    else:
        rs = jsonschema_rs.validator_for(dict(schema))
        out["jsonschema-rs is_valid"] = rs.is_valid
        out["jsonschema-rs iter_errors"] = lambda doc: not list(rs.iter_errors(doc))
    return out


def broken_documents(document: Mapping[str, Any]) -> list[Any]:
    """Copies of *document* with one schema violation each (needs 3+ entries)."""
    broken = []
    for mutate in (
        lambda d: d["execute"][1].__setitem__("id", "1st"),  # pattern
        lambda d: d["execute"][2].__setitem__("extra", 1),  # additionalProperties
        lambda d: d["execute"][0].__setitem__("kind", "step"),  # enum
        lambda d: d["execute"][1].__setitem__("after", "E0"),  # type
        lambda d: d.__setitem__("tick", 0),  # exclusiveMinimum
        lambda d: d["execute"][2].pop("action"),  # required
    ):
        doc = copy.deepcopy(dict(document))
        doc["execute"] = doc["execute"][:3]
        mutate(doc)
        broken.append(doc)
    return broken


def _best(check: Check, documents: Iterable[Any], repeats: int, now: Callable[[], float]) -> float:
    items = list(documents)
    best = float("inf")
    for _ in range(repeats):
        gc.collect()
        t0 = now()
        for doc in items:
            check(doc)
        best = min(best, now() - t0)
    return best


def measure_schemas(n: int, repeats: int, emit: Callable[[dict[str, Any]], None], *, clock: str = "cpu") -> None:
    """Time every candidate on the ``random`` case of *n* entries; emit one row per candidate.

    Each row: ``document`` seconds (test-case schema), ``params`` seconds (all
    entries' params, one call each), ``agrees`` (rejects every broken
    document, accepts the real one), or ``unavailable`` with the reason.
    """
    now = CLOCKS[clock]
    document = timelines.build("random", n)
    registry = default_registry()
    per_action = {}
    for entry in document["execute"]:
        leaf = registry.get(entry["kind"], entry["action"])
        if leaf is not None and leaf.params_schema is not None and entry["action"] not in per_action:
            per_action[entry["action"]] = _candidates(leaf.params_schema, leaf.params_validator)
    broken = broken_documents(document)
    for name, check in _candidates(case_schema(), _loader_validator()).items():
        emit({"stage": name})
        if isinstance(check, str):
            emit({"row": {"candidate": name, "unavailable": check}})
            continue
        agrees = check(document) and not any(check(doc) for doc in broken)
        row: dict[str, Any] = {"candidate": name, "document": _best(check, [document], repeats, now), "agrees": agrees}
        param_checks = {action: checks.get(name) for action, checks in per_action.items()}
        if all(callable(c) for c in param_checks.values()):
            calls = [(param_checks[e["action"]], e.get("params", {})) for e in document["execute"]]
            row["params"] = _best(lambda pair: pair[0](pair[1]), calls, repeats, now)  # type: ignore[misc, operator]
        emit({"row": row})
