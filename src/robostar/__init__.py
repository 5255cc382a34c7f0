"""robostar: the Robostar N1 robot controller host protocol for Python."""

__version__ = "0.1.0"
