"""Commands of the io group (being written)."""

__all__: list[str] = []
