"""Unit quaternions as the spatial engine stores a node's rotation: ``(w, x, y, z)``, the
scalar first."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def rotations(quaternions: np.ndarray) -> np.ndarray:
    """Rotation matrices of unit quaternions ``(w, x, y, z)``, shape ``(..., 3, 3)``."""
    q = np.asarray(quaternions, dtype=float)
    flat = Rotation.from_quat(q.reshape(-1, 4)[:, [1, 2, 3, 0]]).as_matrix()  # scipy's (x, y, z, w)
    return flat.reshape(*q.shape[:-1], 3, 3)
