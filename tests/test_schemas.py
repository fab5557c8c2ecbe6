"""The JSON the project writes and reads has the schema it names (issue 23 item 17).

A sweep's ``--json`` report has its own schema (schemas/sweep-report.schema.json),
``run --help`` names both, and ``schema`` prints a test-case schema that accepts
the project's own sweep files (``"$param"`` where a number is expected) while it
still rejects a word or a malformed reference there.
"""

from __future__ import annotations

import json
import pathlib
from typing import Any

import jsonschema
import pytest

from btgen_pytrees.cli import main

ROOT = pathlib.Path(__file__).resolve().parent.parent
SCHEMAS = ROOT / "schemas"
SWEEPS = [ROOT / "examples" / "fig1_sweep.json", ROOT / "examples" / "sumo" / "cut_in_sweep.json"]


def schema(name: str) -> dict[str, Any]:
    loaded = json.loads((SCHEMAS / name).read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(loaded)
    return loaded  # type: ignore[no-any-return]


def test_a_sweep_report_has_its_own_schema(tmp_path: pathlib.Path) -> None:
    sweep_out, single_out = tmp_path / "sweep.json", tmp_path / "single.json"
    assert main(["run", str(SWEEPS[0]), "--json", str(sweep_out)]) == 1  # some variations fail
    assert main(["run", str(ROOT / "examples" / "fig1.json"), "--json", str(single_out)]) == 0
    sweep, single = (json.loads(p.read_text(encoding="utf-8")) for p in (sweep_out, single_out))
    jsonschema.validate(sweep, schema("sweep-report.schema.json"))
    jsonschema.validate(single, schema("report.schema.json"))
    with pytest.raises(jsonschema.ValidationError):  # what run --help used to name for both
        jsonschema.validate(sweep, schema("report.schema.json"))
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(single, schema("sweep-report.schema.json"))
    assert sweep["variations"] == len(sweep["rows"]) == 28 and sum(sweep["counts"].values()) == 28


def test_run_help_names_both_schemas(capsys: Any) -> None:
    assert main(["run", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "schemas/report.schema.json" in text and "schemas/sweep-report.schema.json" in text
    assert (ROOT / "btgen_pytrees" / "schemas" / "sweep-report.schema.json").is_file()  # shipped in the package


def printed_schema(capsys: Any) -> dict[str, Any]:
    assert main(["schema"]) == 0
    return json.loads(capsys.readouterr().out)  # type: ignore[no-any-return]


@pytest.mark.parametrize("path", SWEEPS, ids=lambda p: p.name)
def test_schema_accepts_the_projects_sweep_files(path: pathlib.Path, capsys: Any) -> None:
    validator = jsonschema.Draft202012Validator(printed_schema(capsys))
    document = json.loads(path.read_text(encoding="utf-8"))
    assert [e.message for e in validator.iter_errors(document)] == []


def test_schema_still_rejects_what_is_not_a_parameter(capsys: Any) -> None:
    validator = jsonschema.Draft202012Validator(printed_schema(capsys))
    base = json.loads(SWEEPS[0].read_text(encoding="utf-8"))
    for path, value in ((("execute", 2, "params", "to"), "fast"), (("execute", 2, "params", "to"), "$1x"),
                        (("tick",), "$"), (("require_complete",), "$flag")):  # fmt: skip
        document = json.loads(json.dumps(base))
        node = document
        for part in path[:-1]:
            node = node[part]
        node[path[-1]] = value
        assert list(validator.iter_errors(document)), (path, value)
    every_example = sorted(p for p in (ROOT / "examples").rglob("*.json") if not p.name.endswith(".oracle.json"))  # not sidecars
    for example in every_example:
        assert [e.message for e in validator.iter_errors(json.loads(example.read_text(encoding="utf-8")))] == [], example
