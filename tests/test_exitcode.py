"""errors.ExitCode: the one list of exit codes (the CLI's, a batch file's, a sweep's), printed as numbers."""

from __future__ import annotations

import json
import pickle

import pathlib

from btgen_pytrees.errors import ExitCode
from btgen_pytrees.parallel import Outcome

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "btgen_pytrees"


def test_the_codes_docs_limits_md_lists() -> None:
    assert [int(c) for c in ExitCode] == [0, 1, 2, 3, 130]



def test_no_module_keeps_its_own_copy_of_the_codes() -> None:
    """The CLI, the sweep and the batch once had their own ``EXIT_*`` names for these codes; ExitCode is the only list."""
    copies = [f"{p.relative_to(PACKAGE)}: {line.strip()}" for p in sorted(PACKAGE.rglob("*.py"))
              for line in p.read_text(encoding="utf-8").splitlines() if line.startswith(("EXIT_", "NOT_RUN"))]  # fmt: skip
    assert copies == []


def test_a_code_prints_as_its_number() -> None:
    code = ExitCode.INTERRUPTED
    assert str(code) == f"{code}" == "{}".format(code) == json.dumps(code) == "130"
    assert pickle.loads(pickle.dumps(code)) is code  # crosses to pool and Dask workers as itself


def test_a_batch_word_is_found_by_the_plain_number_too() -> None:
    assert Outcome("f.json", 2, "x").word == Outcome("f.json", ExitCode.INVALID, "x").word == "INVALID"
    assert Outcome("f.json", ExitCode.INTERRUPTED, "x").word == "130"
