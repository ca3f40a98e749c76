"""Provenance: package version, git commit, timestamps."""

from __future__ import annotations

import datetime as _dt
import functools
import subprocess
from pathlib import Path

from . import __version__

PROJECT_ROOT = Path(__file__).resolve().parent.parent


@functools.cache
def git_commit() -> str:
    """HEAD commit of the project checkout ('+dirty' if a tracked file outside results/ is modified), or 'unknown'.

    results/ is left out: regenerating the canonical outputs rewrites its tracked files, and a study that runs after
    another in the same checkout would otherwise call its own code modified.
    """
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=PROJECT_ROOT, capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)results"],
            cwd=PROJECT_ROOT,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
        return head + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def now() -> str:
    return _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def base_attrs(title: str) -> dict[str, str]:
    """CF global attributes shared by every file this project writes."""
    return {
        "Conventions": "CF-1.8",
        "title": title,
        "institution": "hdi-slider",
        "source": f"hdi-slider {__version__} (git {git_commit()})",
        "history": f"{now()} created by hdi-slider {__version__}",
        "package_version": __version__,
        "git_commit": git_commit(),
    }
