"""What the benchmark scripts share: the repository's root, the shared ROS maps beside it, a
free port on 127.0.0.1, and a server in a child process."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
TICK = os.sysconf("SC_CLK_TCK")


def ros_maps() -> Path:
    """The shared ROS maps (``shared/maps/ros``): beside the repository or beside the folder
    holding it; exits naming both when neither has them."""
    for base in (ROOT.parent, ROOT.parent.parent):
        candidate = base / "shared" / "maps" / "ros"
        if candidate.is_dir():
            return candidate
    raise SystemExit(
        f"the shared ROS maps are not in {ROOT.parent}/shared or {ROOT.parent.parent}/shared"
    )


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Process:
    """A child process serving on a free 127.0.0.1 port, stopped on exit."""

    def __init__(self, argv: list[str], port: int, env: dict[str, str] | None = None) -> None:
        self.port = port
        self.url = f"http://127.0.0.1:{port}"
        self.process = subprocess.Popen(
            argv,
            cwd=ROOT,
            env={**os.environ, **(env or {})},
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )

    def wait(self, path: str, timeout: float = 300) -> None:
        deadline = time.monotonic() + timeout
        while True:
            try:
                httpx.get(self.url + path, timeout=5)
                return
            except httpx.TransportError:
                if self.process.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"{self.url} did not start") from None
                time.sleep(0.05)

    def cpu_seconds(self) -> float:
        """Its CPU time so far, user and system (``/proc/PID/stat``, Linux)."""
        fields = Path(f"/proc/{self.process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / TICK

    def __enter__(self) -> Process:
        return self

    def __exit__(self, *exc: object) -> None:
        self.process.terminate()
        self.process.wait(timeout=30)


def service(env: dict[str, str]) -> Process:
    """The service as its container runs it (``python -m service``), configured by ``env``."""
    port = free_port()
    env = {"PLANNER_HOST": "127.0.0.1", "PLANNER_PORT": str(port), **env}
    return Process([sys.executable, "-m", "service"], port, env)
