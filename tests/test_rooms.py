"""The codebase stays one a newcomer can carry: small modules, no import cycle between the
folders of a package, and no private name imported from another module."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("planner", "service", "schemas")
MAX_LINES = 450


def _modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def _room(module: str) -> str:
    """A module's room: its package's sub-folder or top-level module (``planner.plans``,
    ``service.errors``), or the package itself for its ``__init__``."""
    parts = module.split(".")
    if len(parts) < 2:
        return parts[0]
    base = ROOT / parts[0] / parts[1]
    return ".".join(parts[:2]) if base.is_dir() or base.with_suffix(".py").is_file() else parts[0]


def _imports(path: Path) -> list[tuple[str, list[str]]]:
    """(module, names) for every absolute import of a project module in ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.module, [alias.name for alias in node.names]))
        elif isinstance(node, ast.Import):
            found.extend((alias.name, []) for alias in node.names)
    return [(m, names) for m, names in found if m.split(".")[0] in PACKAGES]


def _name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_stay_small(path: Path) -> None:
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_LINES, f"{path.relative_to(ROOT)} has {lines} lines"


def test_no_import_cycle_between_rooms() -> None:
    edges: dict[str, set[str]] = {}
    for path in _modules():
        room = _room(_name(path))
        for module, names in _imports(path):
            targets = {_room(module)}
            if module in PACKAGES:  # `from planner import plans`: the sub-folder itself
                targets = {_room(f"{module}.{n}") for n in names}
            edges.setdefault(room, set()).update(t for t in targets if t != room)

    def reaches(start: str, goal: str) -> bool:
        seen, todo = {start}, [start]
        while todo:
            for nxt in edges.get(todo.pop(), ()):
                if nxt == goal:
                    return True
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        return False

    cycles = sorted({tuple(sorted((a, b))) for a in edges for b in edges[a] if reaches(b, a)})
    # A package's __init__ re-exports its rooms; a room importing the package's public names
    # from it is the one road the public surface gives, not a cycle of rooms.
    cycles = [c for c in cycles if not set(c) & set(PACKAGES)]
    assert cycles == []


def test_no_private_name_crosses_a_folder() -> None:
    crossings = []
    for path in _modules():
        here = _name(path).rsplit(".", 1)[0] if path.name != "__init__.py" else _name(path)
        for module, names in _imports(path):
            folder = (
                module if (ROOT / module.replace(".", "/")).is_dir() else module.rsplit(".", 1)[0]
            )
            private = [n for n in names if n.startswith("_")]
            if module.rsplit(".", 1)[-1].startswith("_") and module.split(".")[-1] != "__init__":
                private.append(module)
            if private and folder != here:
                crossings.append(f"{path.relative_to(ROOT)} imports {private} from {module}")
    assert crossings == []


# Modules still importing private names from a module beside them (none now: keep it so).
KNOWN_PRIVATE_IMPORTS: frozenset[str] = frozenset()


def test_no_private_name_crosses_a_module() -> None:
    crossings = []
    for path in _modules():
        for module, names in _imports(path):
            private = [n for n in names if n.startswith("_")]
            if module.rsplit(".", 1)[-1].startswith("_") and module.split(".")[-1] != "__init__":
                private.append(module)
            if private and module != _name(path):
                crossings.append(f"{path.relative_to(ROOT)} imports {private} from {module}")
    unknown = [c for c in crossings if c.split(" imports ")[0] not in KNOWN_PRIVATE_IMPORTS]
    assert unknown == []
    stale = KNOWN_PRIVATE_IMPORTS - {c.split(" imports ")[0] for c in crossings}
    assert stale == set(), "known exceptions that no longer import a private name"


def test_the_engine_and_the_stores_know_no_http_schema() -> None:
    """``service/work`` and ``service/stores`` take plain values: what a body's fields mean is
    decided above them (``service/resources``), so they serve any front, not only HTTP's."""
    found = [
        f"{path.relative_to(ROOT)} imports {module}"
        for room in ("work", "stores")
        for path in sorted((ROOT / "service" / room).rglob("*.py"))
        for module, _ in _imports(path)
        if module.split(".")[0] == "schemas"
    ]
    assert found == []
