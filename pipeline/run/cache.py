"""The solver's tables on disk: a :class:`solver.store.ArrayStore` of ``.npz`` files.

The reduced air-bearing models (``quasi_static`` tables, ``linearized`` coefficients) are built once per
scene and key (:mod:`solver.rails.bearings`); with ``store=DiskStore()`` every later process, worker or
command reuses them.  Files live in ``HDI_CACHE_DIR`` (default ``~/.cache/hdi``), one ``KEY.npz`` per table,
written through a temporary file and ``os.replace`` so that a reader never sees half a file.  A cache that
cannot be read or written is not an error, only slower: the table is built again.
"""

from __future__ import annotations

import contextlib
import logging
import os
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)


def default_cache_dir() -> Path:
    """``HDI_CACHE_DIR``, or ``~/.cache/hdi``."""
    return Path(os.environ.get("HDI_CACHE_DIR", Path.home() / ".cache" / "hdi"))


class DiskStore:
    """Named arrays as ``<directory>/<key>.npz``; ``directory`` None: :func:`default_cache_dir` at each call."""

    def __init__(self, directory: str | Path | None = None) -> None:
        self.directory = None if directory is None else Path(directory)

    def path(self, key: str) -> Path:
        return (self.directory or default_cache_dir()) / f"{key}.npz"

    def get(self, key: str) -> dict[str, np.ndarray] | None:
        path = self.path(key)
        if not path.exists():
            return None
        try:
            with np.load(path) as f:
                return {k: f[k] for k in f.files}
        except (OSError, ValueError) as err:  # unreadable or truncated: build the table again
            log.info("could not read cached %s: %s", path, err)
            return None

    def put(self, key: str, arrays: dict[str, np.ndarray]) -> None:
        path = self.path(key)
        tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savez(tmp, **arrays)
            os.replace(tmp, path)
        except OSError as err:  # a read-only home is not an error, only slower
            log.info("could not cache %s: %s", path, err)
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)
