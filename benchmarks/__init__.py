"""Benchmarks: ``python -m benchmarks`` (or ``quadsim bench``) runs the suite
(:mod:`benchmarks.suite`); the others run as ``python -m benchmarks.<name>``
from the repository root."""
