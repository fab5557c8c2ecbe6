import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


@pytest.fixture
def fig1_path() -> str:
    return str(ROOT / "examples" / "fig1.json")
