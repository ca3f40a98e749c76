"""The ledger: one JSON file per finished run, written atomically as the run arrives.

A study's runs live in a folder (by default ``<output folder>/.ledger/<study name>/``),
one file ``<run id>.json`` per run, where the run id hashes every scene
parameter and the package version.  A file is written to a temporary name in
the same folder and moved into place with ``os.replace``, so a kill at any
moment leaves either the complete record or none.  Running a study again
reads the folder and computes only the runs that are missing or failed;
the dataset is always assembled from the ledger, so an interrupted and
resumed study gives the same dataset as an uninterrupted one.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

FAILED = -1


class Ledger:
    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)

    def path(self, run_id: str) -> Path:
        return self.folder / f"{run_id}.json"

    def get(self, run_id: str) -> dict[str, Any] | None:
        """The record of a run, or None if it has none (or an unreadable one, which is then recomputed)."""
        try:
            return json.loads(self.path(run_id).read_text(), object_hook=_decode)
        except (FileNotFoundError, json.JSONDecodeError):
            return None

    def finished(self, run_id: str) -> dict[str, Any] | None:
        """The record of a run that does not need computing again (any status but failed)."""
        record = self.get(run_id)
        if record is None or record.get("status", FAILED) == FAILED:
            return None
        return record

    def put(self, record: dict[str, Any]) -> Path:
        path = self.path(record["run_id"])
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=self.folder)
        try:
            with os.fdopen(fd, "w") as fh:
                json.dump(_encode(record), fh, indent=1, sort_keys=True)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
        return path

    def __len__(self) -> int:
        return sum(1 for _ in self.folder.glob("*.json"))


def _encode(obj: Any) -> Any:
    """JSON has no NaN/inf: store them as tagged strings."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return {"__float__": repr(obj)}
    if isinstance(obj, dict):
        return {k: _encode(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_encode(v) for v in obj]
    return obj


def _decode(obj: dict[str, Any]) -> Any:
    if set(obj) == {"__float__"}:
        return float(obj["__float__"])
    return obj
