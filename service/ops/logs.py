"""JSON log lines, one object per line on stdout: the request lines of
:class:`service.ops.observe.Observe`, the start-up lines, and uvicorn's own messages.

``python -m service`` installs :func:`log_config` with :func:`configure` (uvicorn's plain-text
access line is off: the service writes its own). Fields of a line beyond ``time``,
``level``, ``logger`` and ``message`` are passed as ``extra={"fields": {...}}``.
"""

from __future__ import annotations

import logging
import logging.config
import time
from contextvars import ContextVar
from typing import Any

import orjson

__all__ = ["ACCESS", "LOG", "REQUEST_ID", "JsonFormatter", "configure", "log_config"]

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

    _second = -1
    _stamp = ""

    def format(self, record: logging.LogRecord) -> str:
        second = int(record.created)
        if second != self._second:  # the date and time to the second change once a second
            self._second = second
            self._stamp = time.strftime("%Y-%m-%dT%H:%M:%S.", time.gmtime(second))
        line: dict[str, Any] = {
            "time": f"{self._stamp}{int((record.created - second) * 1000):03d}Z",
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
