"""The robostar benchmarks (figures, never tests): run them all with ``python bench/run.py``."""
