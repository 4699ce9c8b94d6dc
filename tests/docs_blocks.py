"""The code blocks of the README and docs/ as tests/test_docs_run.py runs them, and how what a
page shows is compared with what the commands print (the convention: docs/architecture.md,
"Docs that run").

- A block in ``sh``, ``bash``, ``console`` or ``python`` runs, unless its info string says
  ``notest`` (```` ```sh notest ````).
- A ``json`` or ``text`` block right after a runnable one (blank lines between at most) is what
  it prints. In a ``console`` block, the lines of a command start with ``$ `` (its further
  lines follow until the command is whole, as bash reads it), and the lines up to the next
  ``$ `` are what it prints.
- JSON is compared value by value: ``"…"`` stands for any value (a list's element: any number of
  elements), a member ``"…": "…"`` for any further members, a string ending in ``…`` for any
  string so beginning; the values of ids (``id`` and keys ending in ``_id``) are skipped; a
  number matches to the decimals shown. Text is compared line by line, ``…`` standing for any
  text in a line and a line of its own for any lines.
"""

from __future__ import annotations

import json
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ELLIPSIS = "…"
RUNNABLE = ("sh", "bash", "console", "python")
OUTPUTS = ("json", "text")
FENCE = re.compile(r"^```(\S*)[ \t]*(.*)$")


@dataclass(frozen=True)
class Block:
    """A fenced block: its page, the line of its opening fence, language, info tags and text,
    and for a runnable block the output block after it, if any."""

    page: Path
    line: int
    lang: str
    tags: tuple[str, ...]
    text: str
    output: Block | None = None

    @property
    def runs(self) -> bool:
        return self.lang in RUNNABLE and "notest" not in self.tags

    @property
    def where(self) -> str:
        return f"{self.page.name}:{self.line}"


def blocks(page: Path) -> list[Block]:
    """Every fenced block of ``page`` in order, each runnable one with its output block."""
    lines = page.read_text(encoding="utf-8").splitlines()
    found: list[tuple[Block, int]] = []  # (block, index of its closing fence)
    i = 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
        text = "\n".join(lines[i + 1 : end]) + "\n"
        found.append((Block(page, i + 1, opening[1], tuple(opening[2].split()), text), end))
        i = end + 1
    result: list[Block] = []
    for k, (block, end) in enumerate(found):
        if block.runs and k + 1 < len(found):
            after, _ = found[k + 1]
            between = lines[end + 1 : after.line - 1]
            if after.lang in OUTPUTS and not any(line.strip() for line in between):
                block = Block(block.page, block.line, block.lang, block.tags, block.text, after)
        result.append(block)
    return result


def _whole(command: str) -> bool:
    """Whether bash reads ``command`` as complete (no open quote, no trailing ``\\``)."""
    checked = subprocess.run(["bash", "-n"], input=command, capture_output=True, text=True)
    return checked.returncode == 0 and not command.rstrip("\n").endswith("\\")


def console_commands(text: str) -> list[tuple[str, str]]:
    """A ``console`` block's (command, what it prints) pairs."""
    pairs: list[tuple[str, str]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if not lines[i].startswith("$ "):
            raise ValueError(f"a console block's line is not a command: {lines[i]!r}")
        command = lines[i][2:] + "\n"
        i += 1
        while not _whole(command) and i < len(lines):
            command += lines[i] + "\n"
            i += 1
        shown = []
        while i < len(lines) and not lines[i].startswith("$ "):
            shown.append(lines[i])
            i += 1
        pairs.append((command, "\n".join(shown).strip("\n")))
    return pairs


class _Shown(float):
    """A number as a page shows it: it matches any value that rounds to it."""

    decimals: int

    def __new__(cls, literal: str) -> _Shown:
        number = super().__new__(cls, literal)
        mantissa = literal.lower().split("e")[0]
        number.decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
        number.decimals -= int(literal.lower().split("e")[1]) if "e" in literal.lower() else 0
        return number


def json_values(text: str, *, shown: bool) -> list[Any] | None:
    """The JSON values in ``text`` one after another (curl prints no newline), or None when it
    is not all JSON. ``shown``: numbers as shown (:class:`_Shown`)."""
    decoder = json.JSONDecoder(parse_float=_Shown) if shown else json.JSONDecoder()
    values = []
    i = 0
    text = text.strip()
    while i < len(text):
        try:
            value, i = decoder.raw_decode(text, i)
        except json.JSONDecodeError:
            return None
        values.append(value)
        while i < len(text) and text[i].isspace():
            i += 1
    return values


def _is_id(key: str) -> bool:
    return key == "id" or key.endswith("_id")


def _compare(shown: Any, live: Any, path: str, errors: list[str]) -> None:
    if shown == ELLIPSIS:
        return
    if isinstance(shown, str) and shown.endswith(ELLIPSIS):
        if not (isinstance(live, str) and live.startswith(shown[:-1])):
            errors.append(f"{path}: shown {shown!r}, live {live!r}")
        return
    if isinstance(shown, dict):
        if not isinstance(live, dict):
            errors.append(f"{path}: shown an object, live {json.dumps(live)[:80]}")
            return
        missing = [key for key in shown if key != ELLIPSIS and key not in live]
        extra = [key for key in live if key not in shown] if ELLIPSIS not in shown else []
        if missing or extra:
            errors.append(f"{path}: keys shown but not live {missing}, live but not shown {extra}")
        for key in shown:
            if key != ELLIPSIS and key in live and not _is_id(key):
                _compare(shown[key], live[key], f"{path}.{key}", errors)
        return
    if isinstance(shown, list):
        if not isinstance(live, list):
            errors.append(f"{path}: shown a list, live {json.dumps(live)[:80]}")
            return
        _compare_list(shown, live, path, errors)
        return
    if isinstance(shown, _Shown):
        ok = isinstance(live, int | float) and not isinstance(live, bool)
        if not ok or abs(live - shown) > 0.5 * 10.0**-shown.decimals * (1 + 1e-9) + 1e-12:
            errors.append(f"{path}: shown {shown}, live {live!r}")
        return
    if type(shown) is not type(live) or shown != live:
        errors.append(f"{path}: shown {json.dumps(shown)}, live {json.dumps(live)[:80]}")


def _compare_list(shown: list[Any], live: list[Any], path: str, errors: list[str]) -> None:
    """Elements in order; a ``"…"`` element stands for any number of live ones."""
    if ELLIPSIS not in shown:
        if len(shown) != len(live):
            errors.append(f"{path}: {len(shown)} elements shown, {len(live)} live")
            return
        for i, (s, v) in enumerate(zip(shown, live, strict=True)):
            _compare(s, v, f"{path}[{i}]", errors)
        return
    cut = shown.index(ELLIPSIS)
    head, tail = shown[:cut], shown[cut + 1 :]
    if ELLIPSIS in tail:
        raise ValueError(f"{path}: one '…' a list at most")
    if len(live) < len(head) + len(tail):
        errors.append(f"{path}: at least {len(head) + len(tail)} elements shown, {len(live)} live")
        return
    for i, s in enumerate(head):
        _compare(s, live[i], f"{path}[{i}]", errors)
    for k, s in enumerate(tail):
        i = len(live) - len(tail) + k
        _compare(s, live[i], f"{path}[{i}]", errors)


def _compare_text(shown: str, live: str, errors: list[str]) -> None:
    """Line by line; ``…`` any text in a line, a line of its own any lines."""
    patterns = [line.rstrip() for line in shown.splitlines()]
    lines = [line.rstrip() for line in live.splitlines()]

    def fits(p: int, v: int) -> bool:
        if p == len(patterns):
            return v == len(lines)
        if patterns[p].strip() in (ELLIPSIS, "..."):
            return any(fits(p + 1, w) for w in range(v, len(lines) + 1))
        pattern = ".*".join(re.escape(part) for part in patterns[p].split(ELLIPSIS))
        return v < len(lines) and re.fullmatch(pattern, lines[v]) is not None and fits(p + 1, v + 1)

    if not fits(0, 0):
        errors.append(f"shown:\n{shown}\nlive:\n{live}")


def compare(shown: str, live: str) -> list[str]:
    """What differs between what a page shows and what the command printed: JSON value by value
    (the values one after another), anything else line by line."""
    expected = json_values(shown, shown=True)
    if expected is None:
        errors: list[str] = []
        _compare_text(shown, live, errors)
        return errors
    actual = json_values(live, shown=False)
    if actual is None:
        return [f"shown JSON, live not JSON:\n{live[:400]}"]
    if len(expected) != len(actual):
        return [f"{len(expected)} JSON values shown, {len(actual)} live:\n{live[:400]}"]
    errors = []
    for i, (s, v) in enumerate(zip(expected, actual, strict=True)):
        _compare(s, v, f"answer {i + 1}", errors)
    return errors
