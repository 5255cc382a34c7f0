"""Commands of the files group (being written)."""

__all__: list[str] = []
