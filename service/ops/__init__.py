"""Operating the service: request ids and JSON logs, Prometheus metrics, offline docs."""

__all__: list[str] = []
