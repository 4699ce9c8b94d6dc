"""The one shape of every error answer."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["ErrorPublic"]


class ErrorPublic(BaseModel):
    """FastAPI's ``{"detail": ...}`` with the field at fault and a stable code beside it."""

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "detail": "start [3, 0] is outside the 3 x 3 map",
                    "field": "start",
                    "code": "INVALID_INPUT",
                },
                {
                    "detail": "goal: NO_VALID_PATH: goal [1, 1] cannot be reached from [0, 0]",
                    "field": "goal",
                    "code": "NO_VALID_PATH",
                },
            ]
        }
    )

    detail: str = Field(description="What was wrong, naming the field and the value received.")
    field: str | None = Field(default=None, description="The input at fault, e.g. `params.alpha`.")
    code: str = Field(
        description="`INVALID_INPUT`, `NO_VALID_PATH`, `SEQUENCE_CONFLICT`, `NOT_FOUND`, "
        "`TOO_LARGE`, `UNAUTHORIZED`, `BODY_TIMEOUT`, `BUSY`, `TIMED_OUT`, `STORE_FULL` or "
        "`STORE_UNAVAILABLE`."
    )
