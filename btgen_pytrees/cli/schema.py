"""``schema``: print the test case JSON Schema, with the params of every registered action."""

from __future__ import annotations

import argparse
import json
from typing import Any

from ..errors import ExitCode
from ..load import schema_for
from ..writing import emit
from .options import Parents, registry

__all__ = ["add_parser", "cmd_schema"]


def add_parser(sub: Any, parents: Parents) -> None:
    schema = sub.add_parser("schema", parents=[parents.plugin],
                            help="print the test case JSON Schema, with the params of every registered action")
    schema.set_defaults(func=cmd_schema)


def cmd_schema(args: argparse.Namespace) -> int:
    emit(json.dumps(schema_for(registry(args)), indent=2, ensure_ascii=False) + "\n")
    return ExitCode.OK
