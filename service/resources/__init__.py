"""What the endpoints do, one module a resource: maps, plans and steps, simulations."""

__all__: list[str] = []
