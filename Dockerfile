# syntax=docker/dockerfile:1
# The planner service: one uvicorn process per container; scale out with replicas sharing Redis
# (docker/docker-compose.yml). Build from the repository root: docker build -t planner .

FROM python:3.11-slim AS build
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1
RUN python -m venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH
WORKDIR /src
# Dependencies in a layer of their own: rebuilt only when pyproject.toml changes.
COPY pyproject.toml ./
RUN python -c "import tomllib; print('\n'.join(tomllib.load(open('pyproject.toml', 'rb'))['project']['dependencies']))" > requirements.txt \
    && pip install -r requirements.txt
COPY README.md ./
COPY planner planner
COPY schemas schemas
COPY service service
RUN pip install --no-deps .

FROM python:3.11-slim AS runtime
RUN useradd --create-home --uid 10001 planner
COPY --from=build /opt/venv /opt/venv
# Numba writes its compiled kernels here; the runtime user owns it.
ENV PATH=/opt/venv/bin:$PATH \
    NUMBA_CACHE_DIR=/home/planner/numba-cache \
    PYTHONUNBUFFERED=1
USER planner
WORKDIR /home/planner
# Compile every kernel now, as the runtime user into NUMBA_CACHE_DIR, so that the first plan a
# container serves loads them instead of compiling (numba's cache is per CPU model: a host of
# another CPU model compiles once at start).
RUN python -c "import planner; planner.warm_up()"
EXPOSE 8000
# 200 while the store answers, 503 (unhealthy) while it does not: see /healthz.
HEALTHCHECK --interval=10s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/healthz', timeout=4)"]
# Idle keep-alive connections closed after 5 s; beyond 4096 connections and requests at once, new
# ones get 503 at once rather than queueing (slow bodies are cut by PLANNER_BODY_TIMEOUT_SECONDS).
CMD ["uvicorn", "service.main:app", "--host", "0.0.0.0", "--port", "8000", "--timeout-keep-alive", "5", "--limit-concurrency", "4096", "--backlog", "4096", "--timeout-graceful-shutdown", "10", "--no-server-header"]
