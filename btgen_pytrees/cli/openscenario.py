"""``convert SCENARIO.xosc --out-dir DIR`` and ``coverage DIR``: OpenSCENARIO files (docs/openscenario.md)."""

from __future__ import annotations

import argparse
import json
import os
import shutil
from typing import Any

from ..errors import ExitCode, UsageError
from ..openscenario import Options, ScenarioSweep, read_openscenario
from ..openscenario.coverage import coverage, markdown, table, to_json
from ..systems.sumo.roads import road_case, write_sumo_files
from ..writing import check_target, commit, emit
from .options import Parents

__all__ = ["add_parser", "add_convert", "cmd_coverage", "cmd_convert"]


def add_convert(sub: Any, parents: Parents) -> None:
    conv = sub.add_parser("convert", help="write an OpenSCENARIO scenario as a test-case JSON file, with its road and SUMO files")
    conv.add_argument("file", metavar="SCENARIO", help="an OpenSCENARIO scenario (.xosc)")
    conv.add_argument("--out-dir", required=True, metavar="DIR", help="where to write NAME.json, the road and the SUMO files")
    conv.add_argument("--ego", metavar="NAME", help="the entity the collision criterion is about (default: Ego, ego or hero)")
    conv.add_argument("--timeout", type=float, metavar="SECONDS", help="the case's timeout (default 600)")
    conv.add_argument("--oracle", metavar="FILE", help="a sidecar oracle file (default: SCENARIO.oracle.json beside it)")
    conv.set_defaults(func=cmd_convert)


def cmd_convert(args: argparse.Namespace) -> int:
    """The case JSON runs to the same report as the scenario, from any directory: its road is copied beside it."""
    if args.timeout is not None and not args.timeout > 0:
        raise UsageError(f"--timeout {args.timeout}: must be greater than 0")
    doc = read_openscenario(args.file, Options(ego=args.ego, timeout=args.timeout), oracle=args.oracle)
    if isinstance(doc, ScenarioSweep):
        raise UsageError(f"{args.file}: a ParameterValueDistribution converts variation by variation: "
                         "use 'expand' (one case per variation)")  # fmt: skip
    stem = os.path.splitext(os.path.basename(args.file))[0] or "scenario"
    road = os.path.join(os.path.dirname(os.path.abspath(args.file)), doc["system"]["road"])
    target = os.path.join(args.out_dir, stem + ".json")
    road_target = os.path.join(args.out_dir, os.path.basename(road))
    try:
        os.makedirs(args.out_dir, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out-dir {args.out_dir}: cannot be created: {exc.strerror or exc}") from None
    for path in (target, road_target):
        check_target(path, "--out-dir", [args.file, road])
    doc["system"]["road"] = os.path.basename(road)
    shutil.copyfile(road, road_target)
    written = commit([(target, json.dumps(doc, indent=2, ensure_ascii=False) + "\n")])
    try:  # SUMO's own files beside it, for plain 'sumo -c' (the case itself needs only the road)
        written += write_sumo_files(road_case(road_target, doc["system"]["entities"]), args.out_dir)
    except (OSError, ValueError) as exc:
        emit(f"{args.file}: the SUMO files were not written: {exc}\n")
    for path in [road_target, *written]:
        emit(f"written: {path}\n")
    return ExitCode.OK


def add_parser(sub: Any, parents: Parents) -> None:
    cov = sub.add_parser("coverage", help="which elements of which OpenSCENARIO (.xosc) files are supported")
    cov.add_argument("path", metavar="DIR", help="a directory (every .xosc file under it) or one .xosc file")
    cov.add_argument("--format", choices=("table", "json", "markdown"), default="table",
                     help="table (default), JSON (schemas/coverage.schema.json) or the Markdown table of the elements")  # fmt: skip
    cov.add_argument("--out", metavar="FILE", help="write there instead of standard output")
    cov.set_defaults(func=cmd_coverage)


def cmd_coverage(args: argparse.Namespace) -> int:
    """Exit 0 when every file converts, 1 when some do not (the table says which and why), 2 for a bad path."""
    if not os.path.exists(args.path):
        raise UsageError(f"{args.path}: no such file or directory")
    if args.out:
        check_target(args.out, "--out", [args.path])
    data = coverage(args.path)
    text = {"table": table, "json": to_json, "markdown": markdown}[args.format](data)
    if args.out:
        commit([(args.out, text)])
    else:
        emit(text)
    return ExitCode.OK if all(f["converts"] for f in data["files"]) else ExitCode.FAIL
