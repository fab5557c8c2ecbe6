"""errors.ExitCode: the one list of exit codes (the CLI's, a batch file's, a sweep's), printed as numbers."""

from __future__ import annotations

import json
import pickle

from btgen_pytrees import batch, cli
from btgen_pytrees.errors import ExitCode
from btgen_pytrees.sweep import command


def test_the_codes_docs_limits_md_lists() -> None:
    assert [int(c) for c in ExitCode] == [0, 1, 2, 3, 130]
    assert (cli.EXIT_OK, cli.EXIT_FAIL, cli.EXIT_INVALID, cli.EXIT_INTERNAL) == tuple(ExitCode)[:4]
    assert (command.EXIT_OK, command.EXIT_FAIL, command.EXIT_INVALID) == tuple(ExitCode)[:3]
    assert batch.EXIT_ERROR is ExitCode.FAIL and batch.NOT_RUN is ExitCode.INTERRUPTED


def test_a_code_prints_as_its_number() -> None:
    code = ExitCode.INTERRUPTED
    assert str(code) == f"{code}" == "{}".format(code) == json.dumps(code) == "130"
    assert pickle.loads(pickle.dumps(code)) is code  # crosses to pool and Dask workers as itself


def test_a_batch_word_is_found_by_the_plain_number_too() -> None:
    assert batch.Outcome("f.json", 2, "x").word == batch.Outcome("f.json", ExitCode.INVALID, "x").word == "INVALID"
    assert batch.Outcome("f.json", ExitCode.INTERRUPTED, "x").word == "130"
