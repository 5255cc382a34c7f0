"""Commands of the control group (being written)."""

__all__: list[str] = []
