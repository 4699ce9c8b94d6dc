# Task runner. Every target bootstraps .venv itself; `make run` and `make test` are the quick start.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
# As in the Dockerfile: idle keep-alive connections closed after 5 s, at most 4096 at once.
UVICORN_LIMITS := --timeout-keep-alive 5 --limit-concurrency 4096 --backlog 4096 --no-server-header

.PHONY: run serve demo test lint typecheck unit scen-all bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

run: serve  ## the main job: the service on 127.0.0.1:8000, in-memory store (docs at /docs)

serve: $(STAMP)  ## the HTTP service on 127.0.0.1:8000 (API docs at /docs)
	$(PY) -m uvicorn service.main:app --host 127.0.0.1 --port 8000 $(UVICORN_LIMITS)

demo: $(STAMP)  ## plan on the bundled example map, printed and explained
	$(PY) -m planner demo

test: lint typecheck unit  ## the whole suite: ruff, mypy, pytest

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .

typecheck: $(STAMP)
	$(PY) -m mypy

unit: $(STAMP)
	$(PY) -m pytest

scen-all: $(STAMP)  ## every line of every Moving AI scenario file in ../shared (slow: minutes)
	for f in ../shared/maps/movingai/*.scen; do $(PY) -m planner scen "$$f" || exit 1; done

bench: $(STAMP)  ## side-by-side benchmarks; writes benchmarks/RESULTS.md
	$(PY) -m pip install --quiet -e '.[dev,bench]'
	$(PY) benchmarks/run.py

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
