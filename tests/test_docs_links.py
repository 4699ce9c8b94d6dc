"""The README is a front door and ``docs/`` the manual: the README stays short and links every
page, every relative link (and ``#anchor``) in them resolves, and nothing outside ``tests/``
points to files outside the repository."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
PAGES = [
    "api.md",
    "robot-maps.md",
    "deploying.md",
    "operations.md",
    "algorithm.md",
    "performance.md",
    "architecture.md",
    "experiment.md",
    "zones.md",
    "live.md",
]
MARKDOWN = [README, *sorted(DOCS.glob("*.md"))]

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)
HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*#*\s*$", re.MULTILINE)


def _prose(text: str) -> str:
    """The Markdown without its fenced code blocks and inline code spans."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: markup dropped, lower case, punctuation other than ``-``
    and ``_`` removed, each space a hyphen."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link: its text
    text = re.sub(r"<[^>]+>", "", text).replace("`", "")  # tags and code marks
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every anchor of a page, repeated headings numbered as GitHub numbers them."""
    seen: dict[str, int] = {}
    found = set()
    for heading in HEADING.findall(FENCE.sub("", path.read_text(encoding="utf-8"))):
        base = slug(heading)
        count = seen.get(base, 0)
        seen[base] = count + 1
        found.add(base if count == 0 else f"{base}-{count}")
    return found


def links(path: Path) -> list[str]:
    return LINK.findall(_prose(path.read_text(encoding="utf-8")))


def test_the_slug_rule() -> None:
    assert slug("Where the project departs from the paper") == (
        "where-the-project-departs-from-the-paper"
    )
    assert slug("`wide` and Eq. (3): the decision") == "wide-and-eq-3-the-decision"
    assert slug("Limits, keys and tenants") == "limits-keys-and-tenants"


def test_the_readme_is_a_front_door() -> None:
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200
    long = [(n, len(line)) for n, line in enumerate(lines, 1) if len(line) > 120]
    assert long == [], f"README lines over 120 characters: {long}"


@pytest.mark.parametrize("page", PAGES)
def test_every_page_exists_and_the_readme_links_it(page: str) -> None:
    assert (DOCS / page).is_file(), page
    targets = {unquote(t.split("#", 1)[0]) for t in links(README)}
    assert f"docs/{page}" in targets, f"README.md does not link docs/{page}"


@pytest.mark.parametrize("source", MARKDOWN, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(source: Path) -> None:
    broken = []
    for target in links(source):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.IGNORECASE):  # http:, mailto: ...
            continue
        path, _, anchor = target.partition("#")
        resolved = (source.parent / unquote(path)).resolve() if path else source
        if not resolved.is_relative_to(ROOT):
            broken.append(f"{target}: outside the repository")
        elif not resolved.exists():
            broken.append(f"{target}: no {resolved.relative_to(ROOT)}")
        elif anchor and (resolved.suffix != ".md" or unquote(anchor) not in anchors(resolved)):
            broken.append(f"{target}: no heading #{anchor} in {resolved.relative_to(ROOT)}")
    assert broken == [], f"{source.relative_to(ROOT)}: {broken}"


def _product_files() -> list[Path]:
    """The files outside tests/ whose text could point somewhere: code, docs, build and
    deployment files."""
    skip = {"tests", ".venv", ".git", ".mypy_cache", ".ruff_cache", ".pytest_cache", "build"}
    files = [ROOT / "Makefile", ROOT / "Dockerfile"]
    for top in ROOT.iterdir():
        if top.name in skip or not top.is_dir():
            continue
        if top.name in ("docker", ".ci"):
            files += top.rglob("*")
        else:
            files += [p for ext in ("py", "md", "toml") for p in top.rglob(f"*.{ext}")]
    files += [p for ext in ("py", "md", "toml") for p in ROOT.glob(f"*.{ext}")]
    return sorted(p for p in files if p.is_file())


def test_nothing_outside_tests_points_outside_the_repository() -> None:
    outside = re.compile(r"\.\./shared|shared/API\.md|API\.md|ALGORITHM\.md")
    found = [
        f"{path.relative_to(ROOT)}:{n}: {line.strip()}"
        for path in _product_files()
        for n, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1)
        if outside.search(line)
    ]
    assert found == []
