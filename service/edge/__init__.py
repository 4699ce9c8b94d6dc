"""What a request meets before any route: the one edge middleware (request id, API key, body
limit, deadline, metrics), the JSON depth check, and cancellation when its client goes away."""

__all__: list[str] = []
