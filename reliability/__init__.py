"""Reliability harness: fuzz targets, the fault matrix and the soak, shared by CI and long runs.

``tests/reliability`` runs short slices of each in CI; ``python reliability/run.py`` runs the
long ones (a million fuzz inputs, the full matrix, a million-exchange soak) and writes JSON.
"""
