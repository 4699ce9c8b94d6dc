"""JSON log lines on stdout, one object a line: request lines (buffered, without a ``LogRecord``:
the one kind written thousands of times a second), start-up lines and uvicorn's own messages."""

from __future__ import annotations

import asyncio
import atexit
import logging
import logging.config
import sys
import time
from contextvars import ContextVar
from typing import Any

import orjson

__all__ = [
    "ACCESS",
    "LOG",
    "REQUEST_ID",
    "REQUEST_LINES",
    "JsonFormatter",
    "RequestLines",
    "configure",
    "log_config",
]

LOG = logging.getLogger("service")
"""The service's own lines (start-up, shut-down)."""
ACCESS = logging.getLogger("service.access")
"""One line per request."""
REQUEST_ID: ContextVar[str | None] = ContextVar("planner_request_id", default=None)
"""The id of the request being served: lines logged while serving it carry it."""


class JsonFormatter(logging.Formatter):
    """A record as one JSON object: ``time`` (UTC, ISO 8601), ``level``, ``logger``,
    ``message``, then the record's ``fields``.

    >>> record = logging.LogRecord("service", logging.INFO, "", 0, "hi", None, None)
    >>> record.created = 0.0
    >>> record.fields = {"port": 8000}
    >>> JsonFormatter().format(record)
    '{"time":"1970-01-01T00:00:00.000Z","level":"info","logger":"service","message":"hi","port":8000}'
    """

    def format(self, record: logging.LogRecord) -> str:
        line: dict[str, Any] = {
            "time": _time(record.created),
            "level": record.levelname.lower(),
            "logger": record.name,
            "message": record.getMessage(),
        }
        request_id = REQUEST_ID.get()
        if request_id is not None:
            line["request_id"] = request_id
        line.update(getattr(record, "fields", None) or {})
        if record.exc_info:
            line["exception"] = self.formatException(record.exc_info)
        return orjson.dumps(line, default=str).decode()


_stamp: tuple[int, str] = (-1, "")
"""The second last written and its date and time (one tuple: threads read it whole)."""


def _time(created: float) -> str:
    """``created`` (seconds since the epoch) as UTC ISO 8601 to the millisecond, ``Z``."""
    global _stamp
    second, stamp = int(created), _stamp
    if stamp[0] != second:  # the date and time to the second change once a second
        stamp = _stamp = (second, time.strftime("%Y-%m-%dT%H:%M:%S.", time.gmtime(second)))
    return f"{stamp[1]}{int((created - second) * 1000):03d}Z"


class RequestLines:
    """The request lines of the ``service.access`` logger, as :class:`JsonFormatter` writes a
    record of it (``time``, ``level``, ``logger``, ``message``, then the fields), written to
    ``sys.stdout`` without a ``LogRecord`` and buffered, as nginx's ``access_log ... buffer=
    flush=`` does: out when ``max_lines`` are pending, ``flush_seconds`` after the first line
    pending (on the running event loop; at once without one), and at exit. A request costs the
    keeping of its time and fields: the lines are made together when they go out (~15 us a
    request less than through ``logging``, a few less than made one at a time). The logger's level
    still decides whether they are written (``PLANNER_LOG_LEVEL``)."""

    def __init__(self, *, max_lines: int = 256, flush_seconds: float = 1.0) -> None:
        self.max_lines = max_lines
        self.flush_seconds = flush_seconds
        self._pending: list[tuple[float, dict[str, Any]]] = []
        atexit.register(self.flush)

    def write(self, fields: dict[str, Any]) -> None:
        """Write one request line with ``fields`` (``request_id`` first among them)."""
        pending = self._pending
        pending.append((time.time(), fields))
        if len(pending) == 1:
            try:
                asyncio.get_running_loop().call_later(self.flush_seconds, self.flush)
            except RuntimeError:  # no event loop: nothing would flush it later
                self.flush()
        elif len(pending) >= self.max_lines:
            self.flush()

    def flush(self) -> None:
        """Write out the pending lines now (a stdout that is gone loses them, as a
        ``logging.StreamHandler`` would, without failing the request)."""
        if not self._pending:
            return
        pending, self._pending = self._pending, []
        head = {"level": "info", "logger": ACCESS.name, "message": "request"}
        data = b"".join(
            orjson.dumps({"time": _time(at), **head, **fields}, default=str) + b"\n"
            for at, fields in pending
        )
        try:
            sys.stdout.flush()  # logging's lines written before these go out first
            out = getattr(sys.stdout, "buffer", None)
            if out is None:
                sys.stdout.write(data.decode())
            else:
                out.write(data)
            sys.stdout.flush()
        except (OSError, ValueError):  # closed or broken: as logging.Handler.handleError
            pass


REQUEST_LINES = RequestLines()
"""The process's request lines (:class:`service.ops.observe.Recorder` writes them)."""


def configure(level: str = "info") -> dict[str, Any]:
    """Install :func:`log_config` for this process (and return it, for uvicorn), with what no
    line carries not recorded: the caller's file and line, thread and process names (the
    logging HOWTO's "Optimization"; a request line costs a third less)."""
    logging.logThreads = False
    logging.logProcesses = False
    logging.logMultiprocessing = False
    logging._srcfile = None  # the documented switch: no caller looked up
    config = log_config(level)
    logging.config.dictConfig(config)
    return config


def log_config(level: str = "info") -> dict[str, Any]:
    """``logging.config.dictConfig`` input (and uvicorn's ``log_config``): every line JSON on
    stdout; uvicorn's access logger silenced."""
    upper = level.upper()
    return {
        "version": 1,
        "disable_existing_loggers": False,
        "formatters": {"json": {"()": JsonFormatter}},
        "handlers": {
            "stdout": {
                "class": "logging.StreamHandler",
                "formatter": "json",
                "stream": "ext://sys.stdout",
            }
        },
        "loggers": {
            "service": {"handlers": ["stdout"], "level": upper, "propagate": False},
            "uvicorn": {"handlers": ["stdout"], "level": upper, "propagate": False},
            "uvicorn.error": {"level": upper},
            "uvicorn.access": {"handlers": [], "level": "CRITICAL", "propagate": False},
        },
    }
