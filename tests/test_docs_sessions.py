"""The shell sessions of the README and docs/ write no file where they are pasted (the
repository, usually): a block that writes one (``tee``, ``curl -o``, ``>``) first moves to a
temporary folder, ``cd "$(mktemp -d)"``, or an earlier block of the page did (a page's blocks
are one session, as tests/test_docs_run.py runs them)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```(?:sh|bash|console|shell)\n(.*?)^```", re.DOTALL | re.MULTILINE)
WRITE = re.compile(r"\btee\s+(?!-)\S|\s-o\s+(?!/dev/null)\S|(?<![0-9&])>\s*(?!/dev/null)[\w./$]")
MOVE = 'cd "$(mktemp -d)"'


def _blocks(page: Path) -> list[str]:
    return BLOCK.findall(page.read_text(encoding="utf-8"))


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_a_session_that_writes_files_writes_them_in_a_temporary_folder(page: Path) -> None:
    """A page's blocks are one terminal session: a block may write after an earlier one moved."""
    moved = False
    for block in _blocks(page):
        lines = [line.split("#", 1)[0] for line in block.splitlines()]  # comments aside
        writes = [i for i, line in enumerate(lines) if WRITE.search(line)]
        moves = [i for i, line in enumerate(lines) if MOVE in line]
        if writes and not moved:
            assert moves, f"{page.name}: a block writes files where it is pasted:\n{block[:300]}"
            assert moves[0] < writes[0], f"{page.name}: it writes before {MOVE}:\n{block[:300]}"
        moved = moved or bool(moves)


def test_the_check_sees_the_sessions_that_write() -> None:
    api = "\n".join(_blocks(ROOT / "docs" / "api.md"))
    assert WRITE.search(api), "docs/api.md's session writes map.json: the pattern must see it"
    assert not WRITE.search("curl -s -o /dev/null -w '%{http_code}' localhost:8000/x 2>&1")
