"""The live viewer: steps published as server-sent events, and the page that draws them."""

__all__: list[str] = []
