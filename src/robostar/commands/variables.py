"""Commands of the variables group (being written)."""

__all__: list[str] = []
