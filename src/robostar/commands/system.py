"""Commands of the system group (being written)."""

__all__: list[str] = []
