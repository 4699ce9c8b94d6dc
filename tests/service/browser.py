"""Debian's headless Chromium, with no network beyond 127.0.0.1, for the tests of pages."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile

import pytest

__all__ = ["chromium", "dump_dom"]

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    # No network: every host name but the loopback address fails to resolve.
    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
]


def chromium() -> str:
    """Chromium's path; skips without it, but fails in CI, whose ``.ci/run`` installs it."""
    path = shutil.which("chromium")
    if path is None:
        msg = "chromium is not on PATH (apt-get install chromium; .ci/run does so)"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    return path


def dump_dom(url: str, *, budget_ms: int) -> str:
    """The page's DOM after its scripts ran for ``budget_ms`` of virtual time, in a fresh
    profile."""
    with tempfile.TemporaryDirectory(prefix="chromium-") as profile:
        args = [chromium(), *FLAGS, f"--user-data-dir={profile}"]
        args += [f"--virtual-time-budget={budget_ms}", "--dump-dom", url]
        done = subprocess.run(args, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout
