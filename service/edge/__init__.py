"""What a request meets before any route: body limits and timeouts, the JSON depth check, API
keys and tenants, and cancellation when its client goes away."""

__all__: list[str] = []
