"""Orchestration: scene and study files, runs, datasets, figures, command line.

Never imports numba; the numerics live in :mod:`solver`.
"""

__version__ = "0.1.0"
