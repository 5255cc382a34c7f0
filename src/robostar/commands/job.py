"""Commands of the job group (being written)."""

__all__: list[str] = []
