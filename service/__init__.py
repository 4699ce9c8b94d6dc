"""The HTTP service of ``shared/API.md`` over the planner: ``uvicorn service.main:app``.

Importing the package builds nothing: ``Settings`` and ``create_app`` are loaded on first use, so
``service.client`` imports without FastAPI.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from service.config import Settings
    from service.main import create_app

__all__ = ["Settings", "create_app"]

_LAZY = {"Settings": "service.config", "create_app": "service.main"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'service' has no attribute {name!r}")
