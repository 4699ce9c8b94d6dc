"""``/docs`` and ``/redoc`` work with no network: every asset comes from the service, and each
page, rendered by Chromium that can reach nothing but 127.0.0.1, shows the step operation."""

from __future__ import annotations

import re
import time

import httpx
import pytest

from tests.service.browser import dump_dom

PAGES = ["/docs", "/redoc"]
STEP = "/plan/{plan_id}/step"


@pytest.mark.parametrize("page", PAGES)
def test_the_page_names_no_outside_url_and_its_assets_answer(live_url: str, page: str) -> None:
    with httpx.Client(base_url=live_url, trust_env=False) as client:
        r = client.get(page)
        assert r.status_code == 200
        assert r.headers["content-type"].startswith("text/html")
        html = r.text
        assert not re.search(r"(https?:)?//[a-z0-9]", html, re.IGNORECASE), "an outside URL"
        links = re.findall(r"""\b(?:src|href)\s*=\s*["']([^"']+)""", html)
        scripts = re.findall(r"""<script\s+src="([^"]+)""", html)
        assert scripts, "no script: the page cannot render"
        for link in links:
            assert link.startswith("/"), link
            asset = client.get(link)
            assert asset.status_code == 200, link
            assert asset.content
        # What the page's script then fetches: the schema, which holds the step operation.
        assert STEP in client.get("/openapi.json").json()["paths"]
        assert STEP not in html  # so only a page whose script ran can show it


def test_the_oauth2_redirect_page_is_served_too(live_url: str) -> None:
    r = httpx.get(f"{live_url}/docs/oauth2-redirect", trust_env=False)
    assert r.status_code == 200
    assert not re.search(r"https?://", r.text)


@pytest.mark.parametrize("page", PAGES)
def test_the_page_renders_the_step_operation_offline_in_chromium(live_url: str, page: str) -> None:
    began = time.monotonic()
    dom = dump_dom(f"{live_url}{page}", budget_ms=20_000)
    assert time.monotonic() - began < 25
    assert STEP in dom
    assert "Report the dynamic obstacles; get the move to make now" in dom  # its summary
