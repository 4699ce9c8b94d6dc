"""The baseline of the HTTP benchmark: a bare FastAPI endpoint that echoes its JSON body."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI

app = FastAPI()


@app.post("/echo")
async def echo(body: dict[str, Any]) -> dict[str, Any]:
    return body
