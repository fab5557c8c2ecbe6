"""btgen_pytrees.text: the one "did you mean" and the one shortening every message uses."""

from __future__ import annotations

from btgen_pytrees.errors import shorten as errors_shorten
from btgen_pytrees.text import MAX_MESSAGE, closest, did_you_mean, shorten


def test_did_you_mean_names_the_closest_candidate_or_nothing() -> None:
    assert did_you_mean("sped", ["gap", "speed"]) == " (did you mean 'speed'?)"
    assert did_you_mean("zzz", ["gap", "speed"]) == ""
    assert closest("sped", iter(["speed"])) == "speed"  # any iterable, read once
    assert closest("zzz", ["speed"]) is None


def test_ties_do_not_depend_on_the_candidates_order() -> None:
    assert closest("ab", ["ac", "ad"]) == closest("ab", ["ad", "ac"])


def test_similar_length_compares_only_candidates_of_about_the_same_length() -> None:
    # "speed_limit" is close enough for difflib, but 6 characters longer than "speed" (slack 3)
    assert closest("speed", ["speed_limit"]) == "speed_limit"
    assert closest("speed", ["speed_limit"], similar_length=True) is None
    assert did_you_mean("sped", ["speed"], similar_length=True) == " (did you mean 'speed'?)"


def test_shorten_cuts_the_middle_or_the_end() -> None:
    text = "x" * 300 + " is too long"
    assert shorten("short") == "short"
    assert shorten("y" * MAX_MESSAGE) == "y" * MAX_MESSAGE
    cut = shorten(text)
    assert len(cut) == MAX_MESSAGE and cut.endswith("… is too long"[-12:]) and "…" in cut
    end = shorten(text, keep_end=False)
    assert len(end) == MAX_MESSAGE and end == "x" * (MAX_MESSAGE - 1) + "…"
    assert shorten("abcdefghij", 5) == "ab…ij"
    assert errors_shorten is shorten  # errors.shorten is the same function
