"""Schemathesis against ``/openapi.json`` over ASGI: no 5xx, and every answer fits the schema.

A quick run by default; ``SCHEMATHESIS_CASES=20000`` asks for that many cases in all, shared out
among the operations (those with few distinct inputs run fewer; the count of cases run and of
5xx answers is printed at the end of the session with ``-s``).
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Iterator
from typing import Any

import pytest
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


OPERATIONS = 8
"""The API's operations (10 routes and methods) that the cases are shared among, less two:
``/healthz`` takes no input, and a few others run out of distinct cases early."""
EXAMPLES = max(25, -(-int(os.environ.get("SCHEMATHESIS_CASES", "0")) // OPERATIONS))
COUNTS: Counter[str] = Counter()


@pytest.fixture(scope="module", autouse=True)
def tally() -> Iterator[None]:
    yield
    if os.environ.get("SCHEMATHESIS_CASES"):
        print(f"\nschemathesis: {COUNTS['cases']} cases, {COUNTS['5xx']} answered 5xx")


@schema.parametrize()
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
def test_api_answers_every_generated_request_within_its_schema(
    case: schemathesis.Case[Any],
) -> None:
    COUNTS["cases"] += 1
    response = case.call()
    COUNTS["5xx"] += response.status_code >= 500
    case.validate_response(response, checks=CHECKS)
