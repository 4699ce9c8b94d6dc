"""The deployment files agree with each other and with docs/deploying.md's "Deploying" and
"Configuration" sections.

Docker cannot run here, so this reads them: the compose file (YAML), ``docker/nginx.conf``, the
``Dockerfile`` and ``.dockerignore``, and from docs/deploying.md the services table, the settings
table and the ``docker compose`` commands.
"""

from __future__ import annotations

import fnmatch
import re
import shlex
from pathlib import Path
from typing import Any

import pytest
import yaml

from service.config import Settings
from tests.service.conftest import ROOT

README = ROOT / "docs" / "deploying.md"
COMPOSE = ROOT / "docker" / "docker-compose.yml"


def _section(text: str, title: str) -> str:
    """The lines of the Markdown section ``title`` (its subsections included)."""
    match = re.search(rf"^(#+) {re.escape(title)}\s*$", text, re.MULTILINE)
    assert match, f"no section {title!r}"
    level = len(match.group(1))
    rest = text[match.end() :]
    end = re.search(rf"^#{{1,{level}}} ", rest, re.MULTILINE)
    return rest[: end.start()] if end else rest


def _table(text: str, first_header: str) -> list[dict[str, str]]:
    """The rows of the Markdown table whose header starts with ``first_header``, each cell's
    text stripped of its backticks."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {first_header} |"))
    header = [h.strip() for h in lines[start].strip("|").split("|")]
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip().replace("`", "") for c in line.strip().strip("|").split("|")]
        rows.append(dict(zip(header, cells, strict=True)))
    return rows


@pytest.fixture(scope="module")
def deploying() -> str:
    return _section(README.read_text(encoding="utf-8"), "Deploying")


@pytest.fixture(scope="module")
def configuration() -> str:
    return _section(README.read_text(encoding="utf-8"), "Configuration")


@pytest.fixture(scope="module")
def compose() -> dict[str, Any]:
    data: dict[str, Any] = yaml.safe_load(COMPOSE.read_text(encoding="utf-8"))
    return data


def _dockerfile() -> list[tuple[str, str]]:
    """The Dockerfile's instructions as (KEYWORD, arguments), continuation lines joined."""
    text = re.sub(r"\\\n", " ", (ROOT / "Dockerfile").read_text(encoding="utf-8"))
    lines = [line.strip() for line in text.splitlines()]
    return [
        (line.split(None, 1)[0].upper(), line.split(None, 1)[1])
        for line in lines
        if line and not line.startswith("#")
    ]


def test_the_services_table_matches_the_compose_file(
    deploying: str, compose: dict[str, Any]
) -> None:
    services = compose["services"]
    rows = _table(deploying, "service")
    assert [r["service"] for r in rows] == list(services)
    for row in rows:
        service = services[row["service"]]
        if "build" in service:
            build = service["build"]
            assert row["image"] == f"built from {build['dockerfile']}"
            assert (COMPOSE.parent / build["context"] / build["dockerfile"]).resolve() == (
                ROOT / "Dockerfile"
            )
        else:
            assert row["image"] == service["image"]
        assert int(row["replicas"]) == service.get("deploy", {}).get("replicas", 1)
        published = [str(p).split(":")[0] for p in service.get("ports", [])]
        assert published == ([row["published port"]] if row["published port"] else [])
    assert services["planner"]["deploy"]["replicas"] >= 2
    assert services["redis"]["image"].startswith("redis:")


def test_the_published_port_is_nginx_and_the_readme_says_so(
    deploying: str, compose: dict[str, Any]
) -> None:
    (port,) = compose["services"]["nginx"]["ports"]
    outside, inside = str(port).split(":")
    assert f"http://localhost:{outside}" in deploying
    nginx = (ROOT / "docker" / "nginx.conf").read_text(encoding="utf-8")
    assert re.search(rf"^\s*listen {inside};", nginx, re.MULTILINE)
    # nginx forwards to the planner service on the port its image serves and checks.
    (upstream,) = re.findall(r"^\s*server (\S+?):(\d+)\b", nginx, re.MULTILINE)
    assert upstream[0] in compose["services"]
    instructions = _dockerfile()
    env = dict(
        pair.split("=", 1) for kind, args in instructions if kind == "ENV" for pair in args.split()
    )
    assert env["PLANNER_PORT"] == upstream[1]
    assert env["PLANNER_HOST"] == "0.0.0.0"
    assert dict(instructions)["CMD"] == '["python", "-m", "service"]'
    # The healthcheck asks liveness on the port the environment names.
    healthcheck = dict(instructions)["HEALTHCHECK"]
    assert "http://127.0.0.1:%s/healthz" in healthcheck
    assert "os.environ['PLANNER_PORT']" in healthcheck
    for volume in compose["services"]["nginx"]["volumes"]:
        assert (COMPOSE.parent / volume.split(":")[0]).is_file()


def test_the_settings_table_matches_settings_and_the_compose_environment(
    configuration: str, compose: dict[str, Any]
) -> None:
    rows = {r["variable"]: r for r in _table(configuration, "variable")}
    fields = Settings.model_fields
    assert set(rows) == {f"PLANNER_{name.upper()}" for name in fields}
    defaults = Settings()
    for name, field in fields.items():
        documented = rows[f"PLANNER_{name.upper()}"]["default"]
        if field.default_factory is None:
            value = getattr(defaults, name)
            assert documented == str(value) or float(documented) == value, name
    environment = compose["services"]["planner"]["environment"]
    assert environment == {v: r["compose"] for v, r in rows.items() if r["compose"]}
    assert Settings(store_url=environment["PLANNER_STORE_URL"]).store_url.startswith("redis://")


def test_the_commands_name_the_compose_file_and_its_services(
    deploying: str, compose: dict[str, Any]
) -> None:
    commands = [
        shlex.split(line)
        for line in re.findall(r"^(docker compose .+?)\s*(?:#.*)?$", deploying, re.MULTILINE)
    ]
    assert ["up", "--build"] in [c[4:] for c in commands]
    scaled = []
    for command in commands:
        assert command[:4] == ["docker", "compose", "-f", "docker/docker-compose.yml"]
        assert (ROOT / command[3]).resolve() == COMPOSE
        scaled += [command[i + 1].split("=")[0] for i, a in enumerate(command) if a == "--scale"]
    assert scaled == ["planner"]
    # A scaled service publishes no port of its own: its replicas would collide on it.
    assert "ports" not in compose["services"]["planner"]
    assert "make serve" in deploying


def test_the_dockerfile_copies_files_that_exist_and_are_not_ignored() -> None:
    ignored = [
        line.strip()
        for line in (ROOT / ".dockerignore").read_text(encoding="utf-8").splitlines()
        if line.strip() and not line.startswith("#")
    ]
    copies = [args.split() for kind, args in _dockerfile() if kind in ("COPY", "ADD")]
    local = [args for args in copies if not args[0].startswith("--from=")]
    assert local
    for args in local:
        for source in args[:-1]:
            assert (ROOT / source).exists(), source
            parts = Path(source).parts
            prefixes = ["/".join(parts[: i + 1]) for i in range(len(parts))]
            assert not any(fnmatch.fnmatch(p, pattern) for p in prefixes for pattern in ignored), (
                f"{source} is excluded by .dockerignore"
            )
    # Every package the wheel holds goes into the image.
    assert {"planner", "schemas", "service"} <= {a[0] for a in local}


def test_the_dockerfile_installs_dependencies_first_and_compiles_as_the_runtime_user() -> None:
    instructions = _dockerfile()
    kinds = [kind for kind, _ in instructions]
    bases = [args.split()[0] for kind, args in instructions if kind == "FROM"]
    assert len(bases) >= 2
    assert set(bases) == {"python:3.11-slim"}
    sources = [(i, a.split()[0]) for i, (kind, a) in enumerate(instructions) if kind == "COPY"]
    pyproject = next(i for i, s in sources if s == "pyproject.toml")
    first_package = next(i for i, s in sources if s in ("planner", "service", "schemas"))
    assert any(
        kind == "RUN" and "pip install" in args
        for kind, args in instructions[pyproject:first_package]
    )
    runtime = max(i for i, kind in enumerate(kinds) if kind == "FROM")
    final = instructions[runtime:]
    user = next(i for i, (kind, _) in enumerate(final) if kind == "USER")
    assert final[user][1] not in ("root", "0")
    cache = next(args for kind, args in final[:user] if kind == "ENV" and "NUMBA_CACHE_DIR" in args)
    cache_dir = re.search(r"NUMBA_CACHE_DIR=(\S+)", cache)
    assert cache_dir
    assert cache_dir.group(1).startswith(f"/home/{final[user][1]}/")
    assert any(kind == "RUN" and "planner.warm_up()" in args for kind, args in final[user + 1 :]), (
        "the kernels are compiled after USER, as the runtime user"
    )
    assert kinds.count("HEALTHCHECK") == 1
    assert kinds[-1] == "CMD"


def test_redis_runs_with_a_password_from_an_env_file_and_a_memory_bound(
    compose: dict[str, Any],
) -> None:
    redis = compose["services"]["redis"]
    command = " ".join(redis["command"])
    assert '--requirepass "$$REDIS_PASSWORD"' in command
    assert "--maxmemory " in command
    assert "--maxmemory-policy noeviction" in command
    # The password is nowhere in the compose file: it comes from docker/.env, which git ignores;
    # docker/.env.example names the variables and sets no password.
    assert redis["env_file"] == ".env"
    example = (COMPOSE.parent / ".env.example").read_text(encoding="utf-8")
    variables = dict(
        line.split("=", 1) for line in example.splitlines() if line and not line.startswith("#")
    )
    assert variables["REDIS_PASSWORD"] == ""
    assert variables["REDIS_MAXMEMORY"]
    assert "docker/.env" in (ROOT / ".gitignore").read_text(encoding="utf-8").split()
    assert redis["environment"]["REDISCLI_AUTH"].startswith("${REDIS_PASSWORD:?")
    url = compose["services"]["planner"]["environment"]["PLANNER_STORE_URL"]
    assert url.startswith("redis://:${REDIS_PASSWORD}@redis:")


def test_uvicorn_runs_with_keep_alive_and_concurrency_limits() -> None:
    # The container and `make run` both start `python -m service`, which sets the limits.
    assert "service" in dict(_dockerfile())["CMD"]
    assert "-m service" in (ROOT / "Makefile").read_text(encoding="utf-8")
    main = (ROOT / "service" / "__main__.py").read_text(encoding="utf-8")
    for setting in (
        "timeout_keep_alive=settings.keep_alive_seconds",
        "limit_concurrency=settings.max_connections",
        "h11_max_incomplete_event_size=settings.max_header_bytes",
    ):
        assert setting in main
