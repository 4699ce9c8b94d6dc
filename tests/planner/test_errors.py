"""``planner.quote``: what an error message quotes of a received value, bounded whatever it is."""

from __future__ import annotations

import sys
import tracemalloc
from typing import Any

import pytest

from planner import quote
from planner.errors import QUOTE_LIMIT


def _shared(levels: int) -> list[Any]:
    """A YAML alias bomb as composed: ``levels`` lists of 9 references to the one below,
    9**levels strings once expanded, a few kilobytes in memory."""
    value: list[Any] = ["lol"] * 9
    for _ in range(levels - 1):
        value = [value] * 9
    return value


def _deep(depth: int) -> list[Any]:
    value: list[Any] = []
    for _ in range(depth):
        value = [value]
    return value


@pytest.mark.parametrize(
    "value",
    [
        list(range(10**7)),
        _shared(12),
        {"a": _shared(12), "b": "x" * 10**7},
        _deep(100_000),
        (b"\x00" * 10**7,),
        {i: i for i in range(10**6)},
        {frozenset(range(10**5))},
    ],
    ids=["1e7-list", "alias-bomb", "dict", "deep", "bytes", "1e6-dict", "set"],
)
def test_quote_is_bounded_in_size_and_work(value: object) -> None:
    """The repr is never built whole: the quote is short, and quoting allocates a few
    kilobytes (a full repr of these is 10**7 characters and more, or never ends)."""
    tracemalloc.start()
    try:
        text = quote(value)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(text) <= QUOTE_LIMIT + 20, text
    assert "..." in text, text
    assert peak < 200_000, peak


def test_quote_of_small_values_is_their_repr() -> None:
    for value in [1, -2.5, None, True, "a'b", b"\x00", [1, [2, (3,)]], {"k": {1, 2}}, (), {}]:
        assert quote(value) == repr(value)


def test_a_huge_integer_is_named_not_converted() -> None:
    assert sys.get_int_max_str_digits() < 10**6  # repr would raise ValueError
    assert quote(10**10**6) == "<an integer of 3321929 bits>"


def test_long_strings_say_their_length() -> None:
    text = quote("x" * 10**7)
    assert text.endswith("... (10000000 ch)")
    assert len(text) < 110
