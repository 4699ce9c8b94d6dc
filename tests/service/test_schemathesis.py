"""Schemathesis against ``/openapi.json`` over ASGI: no 5xx, and every answer fits the schema."""

from __future__ import annotations

from typing import Any

import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from service.config import Settings
from service.main import create_app

app = create_app(Settings(pool_size=2, max_map_cells=10_000, max_body_bytes=1 << 20))
schema = schemathesis.openapi.from_asgi("/openapi.json", app)

CHECKS = [
    not_a_server_error,
    status_code_conformance,
    content_type_conformance,
    response_schema_conformance,
]


@schema.parametrize()
@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
def test_api_answers_every_generated_request_within_its_schema(
    case: schemathesis.Case[Any],
) -> None:
    case.call_and_validate(checks=CHECKS)
