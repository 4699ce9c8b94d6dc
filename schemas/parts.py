"""The multipart/form-data parts of a map_server map, ``yaml`` and ``image``: a map upload's
and a keepout mask's (never in a JSON body, so not in the JSON schema)."""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import BaseModel, field_validator
from pydantic.json_schema import SkipJsonSchema

__all__ = ["MapParts", "multipart_form"]


class MapParts(BaseModel):
    """``yaml`` and ``image``, as bytes from a multipart upload; ``parts_of`` names the map they
    make in the error a JSON value for them gets."""

    parts_of: ClassVar[str] = "a ROS map"

    yaml: SkipJsonSchema[bytes | None] = None
    """multipart/form-data only: the ``yaml`` part."""
    image: SkipJsonSchema[bytes | None] = None
    """multipart/form-data only: the ``image`` part."""

    @field_validator("yaml", "image", mode="before")
    @classmethod
    def _parts_only(cls, value: Any) -> Any:
        if value is not None and not isinstance(value, bytes):
            msg = f"{cls.parts_of} comes as multipart/form-data parts 'yaml' and 'image'"
            raise ValueError(msg)
        return value


def multipart_form(*, yaml: str, image: str, **fields: str) -> dict[str, Any]:
    """The ``multipart/form-data`` schema, for ``/docs``, of a request with the parts ``yaml``
    and ``image`` (each described as given) and text ``fields`` (name: description)."""
    binary = {"type": "string", "format": "binary"}
    return {
        "type": "object",
        "required": ["yaml", "image"],
        "properties": {
            "yaml": {**binary, "description": yaml},
            "image": {**binary, "description": image},
            **{name: {"type": "string", "description": text} for name, text in fields.items()},
        },
    }
