"""Every runnable block of the README and docs/ runs as written against a live service, in a
fresh shell without ``.venv`` activated, and prints what the page shows (the convention:
tests/docs_blocks.py and docs/architecture.md, "Docs that run").

A page gets its own ``python -m service`` (the memory store) on a free port: the blocks name
``localhost:8000``, which the runner points at it. A page's shell blocks are one session
(variables and the working folder carry from a block to the next, as in one terminal), started
in the repository; its Python blocks run with the project's interpreter in that session's
folder. No block may leave a file in the repository."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

from tests.docs_blocks import Block, blocks, compare, console_commands, json_values
from tests.service.conftest import free_port

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
RUNNABLE = [page for page in PAGES if any(block.runs for block in blocks(page))]
TIMEOUT = 300  # seconds a block may take (a cold numba cache compiles in the first ones)


@contextmanager
def service(folder: Path) -> Iterator[str]:
    """``python -m service`` on 127.0.0.1 and a free port, as ``make run`` starts it."""
    port = free_port()
    log = folder / "service.log"
    env = {**os.environ, "PLANNER_HOST": "127.0.0.1", "PLANNER_PORT": str(port)}
    with log.open("wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "service"], env=env, cwd=ROOT, stdout=out, stderr=out
        )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + TIMEOUT
        while True:
            assert process.poll() is None, log.read_text()
            assert time.monotonic() < deadline, f"not ready: {log.read_text()[-2000:]}"
            try:
                if httpx.get(f"{url}/readyz", timeout=5, trust_env=False).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            time.sleep(0.1)
        yield url
    finally:
        process.terminate()
        process.wait(timeout=30)


class Session:
    """A page's terminal: bash runs each command after the previous one's variables and folder
    (kept in a file), with ``set -e -o pipefail``; the PATH has no ``.venv/bin``."""

    def __init__(self, folder: Path, url: str) -> None:
        self.url = url
        self.state = folder / "state.sh"
        self.state.write_text(f"cd {ROOT}\n")
        venv_bin = str(Path(sys.prefix) / "bin")
        path = os.pathsep.join(
            p for p in os.environ.get("PATH", "").split(os.pathsep) if p and p != venv_bin
        )
        home = folder / "home"
        home.mkdir()
        self.env = {"PATH": path, "HOME": str(home), "LANG": "C.UTF-8", "TMPDIR": str(folder)}
        self.env["PYTHONPATH"] = str(ROOT)  # as the editable install of `make` puts it
        if "NUMBA_CACHE_DIR" in os.environ:
            self.env["NUMBA_CACHE_DIR"] = os.environ["NUMBA_CACHE_DIR"]

    def _here(self, text: str) -> str:
        """The block's text with the service's address in place of the docs' 8000."""
        for host in ("localhost:8000", "127.0.0.1:8000"):
            text = text.replace(host, self.url.removeprefix("http://"))
        return text

    def folder(self) -> Path:
        return Path(self.state.read_text().splitlines()[-1].removeprefix("cd ").strip("'"))

    def shell(self, command: str) -> subprocess.CompletedProcess[str]:
        script = (
            f"source {self.state}\nset -a -e -o pipefail\n"
            f'trap \'{{ export -p; printf "cd %q\\n" "$PWD"; }} > {self.state}\' EXIT\n'
            f"{self._here(command)}"
        )
        return subprocess.run(
            ["bash", "-c", script], env=self.env, capture_output=True, text=True, timeout=TIMEOUT
        )

    def python(self, code: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-c", self._here(code)],
            env=self.env, cwd=self.folder(), capture_output=True, text=True, timeout=TIMEOUT,
        )  # fmt: skip


def _check(block: Block, command: str, ran: subprocess.CompletedProcess[str], shown: str) -> None:
    """The command succeeded and printed what is shown; a console command that fails may only
    show what it prints, stderr included (an error the page sets out to show)."""
    where = f"{block.where}: {command.strip()[:200]}"
    printed = ran.stdout
    failing = block.lang == "console" and shown and ran.returncode != 0
    if failing:
        printed += ran.stderr
    else:
        assert ran.returncode == 0, f"{where}\nexit {ran.returncode}\n{ran.stdout}\n{ran.stderr}"
    if shown:
        errors = compare(shown, printed)
        assert not errors, f"{where}\n" + "\n".join(errors[:12])
        return
    # Nothing shown: an error answer nobody sees is a broken example all the same.
    for value in json_values(ran.stdout, shown=False) or []:
        assert not (isinstance(value, dict) and {"code", "detail"} <= value.keys()), (
            f"{where}\nanswered an error: {value}"
        )


def _untracked() -> set[str]:
    listed = subprocess.run(
        ["git", "status", "--porcelain", "--untracked-files=all"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    )  # fmt: skip
    return set(listed.stdout.splitlines())


@pytest.mark.parametrize("page", RUNNABLE, ids=lambda p: p.name)
def test_the_page_runs_as_written(page: Path, tmp_path: Path) -> None:
    assert (ROOT / ".venv" / "bin" / "python").exists(), "no .venv: `make` makes it"
    before = _untracked()
    with service(tmp_path) as url:
        _run(page, Session(tmp_path, url))
    assert _untracked() == before, f"{page.name} left files in the repository"


def _run(page: Path, session: Session) -> None:
    for block in blocks(page):
        if not block.runs:
            continue
        shown = block.output.text.strip("\n") if block.output else ""
        if block.lang == "console":
            for command, printed in console_commands(block.text):
                _check(block, command, session.shell(command), printed)
        elif block.lang == "python":
            _check(block, block.text, session.python(block.text), shown)
        else:
            _check(block, block.text, session.shell(block.text), shown)
