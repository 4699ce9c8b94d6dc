"""The benchmark scripts under ``benchmarks/`` loaded as modules, for tests of what they
compute (they are scripts, not a package)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load_benchmark(name: str) -> Any:
    """``benchmarks/{name}.py`` as the module ``{name}``, the name it has when run from
    ``benchmarks/`` (numba caches its kernels under it)."""
    if str(BENCHMARKS) not in sys.path:  # their shared helpers (benchmarks/common.py)
        sys.path.append(str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it is executed
    spec.loader.exec_module(module)
    return module
