"""A typed Python client of the planner's HTTP API, on httpx.

>>> from service.client import PlannerClient
>>> with PlannerClient("http://127.0.0.1:8000") as planner:  # doctest: +SKIP
...     info = planner.upload_map(rows=["....", ".@@.", "...."], start=[0, 0], goal=[2, 3])
...     step = planner.step(info.plan.plan_id, [[1, 0]], seq=0)
...     step.position, step.move
([0, 1], 'E')

:class:`PlannerClient` and :class:`AsyncPlannerClient` have the same methods. Results are the
API's response models from :mod:`schemas` themselves (``Plan`` is ``schemas.PlanPublic``, ...),
decoded by one function: they have every field of this version's answers (a newer server's extra
fields are left out); :class:`MapInfo` adds ``created``. Every error answer raises an
:class:`APIError`:

APIError                 .status_code, .code, .detail, .field, .response
├── BadRequestError      400
├── NotFoundError        404  unknown map or plan (NOT_FOUND)
├── ConflictError        409  a step's seq out of order (SEQUENCE_CONFLICT)
├── PayloadTooLargeError 413  body or map over the service's limits (TOO_LARGE)
├── ValidationError      422  a bad request (INVALID_INPUT)
│   └── NoValidPathError 422  the goal cannot be reached (NO_VALID_PATH)
├── TooManyRequestsError 429  the key's cap of plans or streams (TOO_MANY_PLANS, ...)
├── UnavailableError     503  the store is out of reach (STORE_UNAVAILABLE); .retry_after
└── ServerError          other 5xx

``upload_map(yaml=...)`` raises :class:`MapFileError` (a ``ValueError``; ``.path``) before
sending anything when the YAML, or the image it names, cannot be read.

Network failures stay httpx's own (``httpx.TransportError``); a success answer that is not its
model's shape (a server of another version) raises ``pydantic.ValidationError``. This module
imports neither FastAPI nor the service's app: a client machine needs httpx and pydantic.
"""

from service.client import clients, errors
from service.client.clients import *  # noqa: F403
from service.client.errors import *  # noqa: F403

__all__ = [*clients.__all__, *errors.__all__]
