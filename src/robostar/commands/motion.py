"""Commands of the motion group (being written)."""

__all__: list[str] = []
