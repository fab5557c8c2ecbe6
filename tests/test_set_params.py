"""Parameters from the command line: ``--set NAME=VALUE`` and ``--params FILE.json`` (docs/sweeps.md).

``run``/``show``/``expand`` of a sweep with them work on one variation, named
after the values it ran with; a bad name or value is exit 2 with "did you mean".
"""

from __future__ import annotations

import json
import pathlib

import pytest

from btgen_pytrees.cli import main

ROOT = pathlib.Path(__file__).resolve().parent.parent
SWEEP = str(ROOT / "examples" / "fig1_sweep.json")


def cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_set_runs_one_variation_and_the_report_names_its_parameters(capsys: pytest.CaptureFixture[str],
                                                                    tmp_path: pathlib.Path) -> None:  # fmt: skip
    code, out, _ = cli(capsys, "run", SWEEP, "--set", "limit=25", "--set", "top_speed=30", "--json", str(tmp_path / "r.json"))
    assert code == 1  # one run, not the sweep's 28: the ramp to 30 breaks the limit 25
    assert "fig1_sweep[top_speed=30,limit=25,ramp_time=2]: FAIL after 1.7 s (18 ticks) - R1 failed" in out
    assert "speed <= 25 false by 0.5 at 1.7 s" in out and "variations" not in out
    assert json.loads((tmp_path / "r.json").read_text())["test"] == "fig1_sweep[top_speed=30,limit=25,ramp_time=2]"
    code, out, _ = cli(capsys, "run", SWEEP, "--set", "top_speed=30")  # the others at their defaults (limit 30)
    assert code == 0 and "fig1_sweep[top_speed=30,limit=30,ramp_time=2]: PASS" in out


def test_a_value_outside_the_variations_and_a_fraction(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = cli(capsys, "run", SWEEP, "--set", "top_speed=12.5", "--set", "ramp_time=0.5")
    assert code == 0 and "fig1_sweep[top_speed=12.5,limit=30,ramp_time=0.5]: PASS" in out


def test_params_file_and_set_wins(capsys: pytest.CaptureFixture[str], tmp_path: pathlib.Path) -> None:
    (tmp_path / "p.json").write_text('{"limit": 40, "top_speed": 45}')
    code, out, _ = cli(capsys, "run", SWEEP, "--params", str(tmp_path / "p.json"))
    assert code == 1 and "fig1_sweep[top_speed=45,limit=40,ramp_time=2]: FAIL" in out
    code, out, _ = cli(capsys, "run", SWEEP, "--params", str(tmp_path / "p.json"), "--set", "top_speed=35")
    assert code == 0 and "fig1_sweep[top_speed=35,limit=40,ramp_time=2]: PASS" in out


def test_unknown_names_get_did_you_mean(capsys: pytest.CaptureFixture[str], tmp_path: pathlib.Path) -> None:
    code, out, err = cli(capsys, "run", SWEEP, "--set", "limt=25", "--set", "top_sped=3")
    assert code == 2 and out == ""
    assert err.splitlines() == ["btgen_pytrees: --set limt=25: unknown parameter 'limt' (did you mean 'limit'?)",
                                "btgen_pytrees: --set top_sped=3: unknown parameter 'top_sped' (did you mean 'top_speed'?)"]  # fmt: skip
    (tmp_path / "p.json").write_text('{"rampt_time": 1}')
    code, _, err = cli(capsys, "run", SWEEP, "--params", str(tmp_path / "p.json"))
    assert code == 2 and f"{tmp_path / 'p.json'}: /rampt_time: unknown parameter 'rampt_time' (did you mean 'ramp_time'?)" in err
    code, _, err = cli(capsys, "run", str(ROOT / "examples" / "fig1.json"), "--set", "x=1")
    assert code == 2 and "unknown parameter 'x' (the case declares no parameters)" in err


def test_types_are_checked_as_in_the_sweep_file(capsys: pytest.CaptureFixture[str], tmp_path: pathlib.Path) -> None:
    for given, message in [("top_speed=true", "parameter 'top_speed' must be a number, like its default (20)"),
                           ("top_speed=fast", "'fast' is not a number, true or false"),
                           ("top_speed=NaN", "'NaN' is not a number, true or false"),
                           ("top_speed", "expected NAME=VALUE")]:  # fmt: skip
        code, out, err = cli(capsys, "run", SWEEP, "--set", given)
        assert code == 2 and out == "" and message in err, (given, err)
    flag = {"name": "f", "parameters": {"on": True, "d": 1},
            "execute": [{"id": "A", "kind": "behavior", "action": "hold", "params": {"duration": "$d"}}]}  # fmt: skip
    (tmp_path / "f.json").write_text(json.dumps(flag))
    code, _, err = cli(capsys, "run", str(tmp_path / "f.json"), "--set", "on=1")
    assert code == 2 and "parameter 'on' must be true or false, like its default (true)" in err
    code, out, _ = cli(capsys, "run", str(tmp_path / "f.json"), "--set", "on=false", "--set", "d=0.2")
    assert code == 0 and "f[on=false,d=0.2]: PASS after 0.2 s" in out
    (tmp_path / "list.json").write_text("[1]")
    code, _, err = cli(capsys, "run", SWEEP, "--params", str(tmp_path / "list.json"))
    assert code == 2 and "list.json: /: expected a JSON object of parameter values" in err


def test_a_value_that_makes_the_case_invalid_names_the_json_path(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", SWEEP, "--set", "ramp_time=-1")
    assert code == 2 and "fig1_sweep.json: /execute/2/params/duration:" in err


def test_show_and_expand_take_the_same(capsys: pytest.CaptureFixture[str], tmp_path: pathlib.Path) -> None:
    code, out, _ = cli(capsys, "show", SWEEP, "--set", "top_speed=12", "--format", "json")
    tree = json.loads(out)
    assert code == 0 and tree["name"] == "fig1_sweep[top_speed=12,limit=30,ramp_time=2]"
    assert "speed <= 30" in out and "'to': 12" in out or '"to": 12' in out
    code, out, _ = cli(capsys, "expand", SWEEP, "--set", "limit=20", "--out-dir", str(tmp_path / "out"))
    assert code == 0 and out == f"1 case written to {tmp_path / 'out'}\n"
    (written,) = (tmp_path / "out").iterdir()
    assert written.name == "fig1_sweep[top_speed=20,limit=20,ramp_time=2].json"
    doc = json.loads(written.read_text())
    assert "variations" not in doc and "parameters" not in doc and doc["oracle"]["criteria"][0]["expect"] == "speed <= 20"


def test_one_file_only(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = cli(capsys, "run", str(ROOT / "examples"), "--set", "limit=1")
    assert code == 2 and "--set/--params choose one variation of one file" in err
    code, _, err = cli(capsys, "run", SWEEP, SWEEP, "--set", "limit=1")
    assert code == 2 and "--set/--params choose one variation of one file" in err
    code, _, err = cli(capsys, "run", SWEEP, "--set", "limit=1", "--set", "limit=2")
    assert code == 2 and "--set limit: given twice" in err
