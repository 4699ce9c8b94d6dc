# syntax=docker/dockerfile:1
# The planner service: one uvicorn process per container; scale out with replicas sharing Redis
# (docker/docker-compose.yml). Build from the repository root: docker build -t planner .

FROM python:3.11-slim AS build
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1
RUN python -m venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH
WORKDIR /src
# Dependencies in a layer of their own, at the versions requirements.lock pins (hashes checked):
# rebuilt only when the lock or pyproject.toml changes.
COPY pyproject.toml requirements.lock ./
RUN pip install --require-hashes -r requirements.lock
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
# python -m service listens on PLANNER_HOST:PLANNER_PORT and logs JSON lines on stdout.
ENV PLANNER_HOST=0.0.0.0 \
    PLANNER_PORT=8000
EXPOSE 8000
# Liveness: /healthz answers 200 while the process serves, whether or not Redis does (a replica
# is not restarted for Redis's sake; /readyz tells whether it can serve). The port is the
# container's PLANNER_PORT, whatever it is set to.
HEALTHCHECK --interval=10s --timeout=5s --start-period=60s --retries=3 \
    CMD python -c "import os, urllib.request; urllib.request.urlopen('http://127.0.0.1:%s/healthz' % os.environ['PLANNER_PORT'], timeout=4)"
CMD ["python", "-m", "service"]
