"""Dependencies of the routers, as ``Annotated`` aliases, and the JSON-decoding route class."""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Annotated, Any, cast

import numpy as np
import orjson
from fastapi import Depends, Query, Request, Response
from fastapi.routing import APIRoute

from service.config import Settings
from service.engine import Engine
from service.errors import TooLarge
from service.guards import check_depth

__all__ = ["PNG_RESPONSE", "CellQuery", "EngineDep", "MapRoute", "OrjsonRoute", "get_engine"]


async def get_engine(request: Request) -> Engine:
    # async: FastAPI runs a plain def dependency in its threadpool, a needless hop per request
    return cast(Engine, request.app.state.engine)


EngineDep = Annotated[Engine, Depends(get_engine)]

CellQuery = Annotated[
    int | None,
    Query(
        ge=1,
        le=64,
        description="Pixels per map cell (default: about 800 pixels across, 1 to 10 a cell); "
        "the picture may be at most 8192 pixels wide.",
    ),
]

PNG_RESPONSE: dict[int | str, dict[str, Any]] = {
    200: {"content": {"image/png": {}}, "description": "A PNG picture."}
}


class _OrjsonRequest(Request):
    async def json(self) -> Any:
        if not hasattr(self, "_json"):
            # orjson.JSONDecodeError subclasses json.JSONDecodeError, which FastAPI turns
            # into a 422; it also refuses integers beyond 64 bits that numpy could not hold.
            self._json = orjson.loads(await self.body())
        return self._json


class OrjsonRoute(APIRoute):
    """Decodes request bodies with orjson: several times faster than ``json`` on big maps."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def route_handler(request: Request) -> Response:
            request = _OrjsonRequest(request.scope, request.receive)
            if request.method in ("POST", "PUT", "PATCH"):
                check_depth(await request.body())
            await self.check_body(request)
            return await handler(request)

        return route_handler

    async def check_body(self, request: Request) -> None:
        """A look at the raw body before it is parsed (errors raised here reach the handlers)."""


# Every cell of a map is one byte of the body: a Moving AI letter in `rows`, a 0 or a 1 in
# `grid`. Counting those bytes bounds the cells from above; a valid body's other fields (start,
# goal, preset, params) hold at most a few hundred of them, hence the slack.
_CELL_BYTES = np.zeros(256, dtype=bool)
_CELL_BYTES[np.frombuffer(b".GS@OTW01", dtype=np.uint8)] = True
CELL_SLACK = 4096


class MapRoute(OrjsonRoute):
    """Refuses a map over ``PLANNER_MAX_MAP_CELLS`` from its raw bytes, before they become
    Python objects (the engine checks the exact shape after parsing)."""

    async def check_body(self, request: Request) -> None:
        if request.method != "POST":
            return
        body = await request.body()
        cells = int(np.count_nonzero(_CELL_BYTES[np.frombuffer(body, dtype=np.uint8)]))
        limit = cast(Settings, request.app.state.settings).max_map_cells
        if cells > limit + CELL_SLACK:
            msg = (
                f"map: the body holds about {cells} map cells; PLANNER_MAX_MAP_CELLS is {limit} "
                "(refused before parsing)"
            )
            raise TooLarge(msg, field="map")
