"""Checkpoints of ``flextop optimize``: what rebuilds a run, written atomically and sealed
with a SHA-256 checksum, so that a resume refuses a file that is corrupt, edited, of
another version, holding a design outside its bounds, or of a run that has converged.

The file is JSON: ``{"flextop_checkpoint": VERSION, "sha256": ..., "data": {...}}`` with
``data`` holding the scene, the accuracy, the problem, the optimizer's options, the start
design, its state after the last iteration, and ``finished`` (the status the run stopped
with, once it has stopped); a spatial scene's has ``spatial`` true and no accuracy (``None``).
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

from ..errors import CheckpointError

VERSION = 2
"""Format of the checkpoint files written; other versions are refused."""

KEYS = ("scene", "accuracy", "problem", "optimizer", "x0", "state")
"""What ``data`` must hold."""


def write_atomically(path: Path, text: str) -> None:
    """Writes ``text`` to ``path`` through a temporary file renamed over it, so that an
    interrupted run never leaves half a file."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _digest(data: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


def save(path: Path, data: dict[str, Any]) -> None:
    """Writes the checkpoint ``data`` (see the module's docstring) to ``path``."""
    write_atomically(path, json.dumps({"flextop_checkpoint": VERSION, "sha256": _digest(data), "data": data}))


def load(path: Path) -> dict[str, Any]:
    """The ``data`` of the checkpoint at ``path``, or a :class:`CheckpointError` saying why
    it cannot be resumed (missing, unreadable, not a checkpoint, corrupt)."""
    try:
        sealed = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CheckpointError(f"no checkpoint to resume: {path} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise CheckpointError(f"{path} cannot be read as a checkpoint: {error}") from None
    if not isinstance(sealed, dict) or "flextop_checkpoint" not in sealed:
        raise CheckpointError(f"{path} is not a flextop checkpoint")
    if sealed["flextop_checkpoint"] != VERSION:
        raise CheckpointError(f"{path} is a checkpoint of format {sealed['flextop_checkpoint']!r}; this flextop reads format {VERSION}")
    data = sealed.get("data")
    if not isinstance(data, dict) or sealed.get("sha256") != _digest(data):
        raise CheckpointError(f"{path} is corrupt: its contents do not match their checksum")
    missing = [key for key in KEYS if key not in data]
    if missing:
        raise CheckpointError(f"{path} lacks {', '.join(missing)}")
    return data
