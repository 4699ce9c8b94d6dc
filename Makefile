# Task runner. Every target bootstraps .venv itself; `make run` and `make test` are the quick start.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
BENCH_STAMP := $(VENV)/.bench-installed

.PHONY: run serve demo test lint typecheck unit scen-all bench lock clean

# The pinned versions of requirements-dev.lock (hashes checked), then the project itself.
$(STAMP): pyproject.toml requirements-dev.lock
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet --require-hashes -r requirements-dev.lock
	$(PY) -m pip install --quiet --no-deps -e .
	touch $(STAMP)

UV_COMPILE := $(PY) -m uv pip compile pyproject.toml --python-version 3.11 --universal --generate-hashes --quiet

lock: $(STAMP)  ## re-pin requirements.lock (runtime), requirements-dev.lock and requirements-bench.lock from pyproject's ranges
	$(PY) -m pip install --quiet uv
	$(UV_COMPILE) --upgrade -o requirements.lock
	$(UV_COMPILE) --upgrade --extra dev -c requirements.lock -o requirements-dev.lock
	$(UV_COMPILE) --upgrade --extra bench -c requirements-dev.lock -o requirements-bench.lock

run: serve  ## the main job: the service on 127.0.0.1:8000, in-memory store (docs at /docs)

serve: $(STAMP)  ## the HTTP service on PLANNER_HOST:PLANNER_PORT, 127.0.0.1:8000 (docs at /docs)
	$(PY) -m service

demo: $(STAMP)  ## plan on the bundled example map, printed and explained
	$(PY) -m planner demo

test: lint typecheck unit  ## the whole suite: ruff, mypy, pytest

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .

typecheck: $(STAMP)
	$(PY) -m mypy

# On every CPU (pytest-xdist), a module's tests on one worker (they share its servers); a
# progress line per test file as it ends.
unit: $(STAMP)
	$(PY) -m pytest -n auto --dist loadfile -o addopts="--doctest-modules" -r fE

scen-all: $(STAMP)  ## every line of every Moving AI scenario file in MOVINGAI=folder (slow: minutes)
	@test -n "$(MOVINGAI)" || { echo "usage: make scen-all MOVINGAI=folder-of-movingai-map-and-scen-files"; exit 2; }
	for f in $(MOVINGAI)/*.scen; do $(PY) -m planner scen "$$f" || exit 1; done

# The bench extra's pinned versions (requirements-bench.lock, constrained by the dev lock).
$(BENCH_STAMP): $(STAMP) requirements-bench.lock
	$(PY) -m pip install --quiet --require-hashes -r requirements-bench.lock
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)  ## side-by-side benchmarks, issue 14's targets on top; writes benchmarks/RESULTS.md (BENCH_ARGS=--quick: faster)
	$(PY) benchmarks/run.py $(BENCH_ARGS)

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
