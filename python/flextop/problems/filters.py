"""Filters on the densities of continuum members' cells, against checkerboards and mesh
dependence (Sigmund 2007; the 88-line code, Andreassen et al. 2011).

Both weigh a cell's neighbours within ``radius`` (m, so that the design's resolution does not
change with the mesh) by ``Hₑᵢ = max(0, r − |cₑ − cᵢ|)`` between reference centres, within the
same member, over the cells that are design variables; a bar's variable is left alone.

* :class:`DensityFilter` (Bruns and Tortorelli): the simulation sees the physical densities
  ``x̃ = W x``, ``W = diag(1/Σᵢ Hₑᵢ) H``, and the gradients follow by the chain rule
  ``df/dx = (df/dx̃) W``: exact derivatives of what the optimizer is told.
* :class:`SensitivityFilter` (Sigmund): the simulation sees ``x`` and the objective's
  gradient is replaced by ``H(x ⊙ ∂f/∂x)/(Σᵢ Hₑᵢ · max(10⁻³, x))``, a heuristic that is not a
  derivative: the KKT residual the driver reports is then that of the filtered problem.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sparse
from scipy.spatial import cKDTree

from ..errors import SettingsError


def _neighbourhoods(simulation: Any, radius: float) -> sparse.csr_matrix:
    """``H`` over the design variables (identity on those that are no cells)."""
    if not (np.isfinite(radius) and radius > 0):
        raise SettingsError(f"filter radius must be a positive length in m, got {radius}")
    cells = simulation.model.cells()
    variable = np.asarray(cells["variable"])
    designed = variable >= 0
    if not designed.any():
        raise SettingsError("the scene has no designed cells of continuum members: nothing to filter")
    centre, member, variable = cells["centre"][designed], np.asarray(cells["member"])[designed], variable[designed]
    pairs = cKDTree(centre).sparse_distance_matrix(cKDTree(centre), radius, output_type="coo_matrix")
    # Pairs of distinct cells of one member (the distance matrix may or may not hold a cell
    # with itself), then each cell's own weight r.
    same = (member[pairs.row] == member[pairs.col]) & (pairs.row != pairs.col)
    rows, cols = variable[pairs.row[same]], variable[pairs.col[same]]
    weights = np.concatenate([radius - pairs.data[same], np.full(variable.size, radius)])
    rows, cols = np.concatenate([rows, variable]), np.concatenate([cols, variable])
    n = simulation.n_design
    others = np.setdiff1d(np.arange(n), variable)
    rows, cols = np.concatenate([rows, others]), np.concatenate([cols, others])
    weights = np.concatenate([weights, np.ones(others.size)])
    return sparse.csr_matrix((weights, (rows, cols)), shape=(n, n))


class DensityFilter:
    """Physical densities ``x̃ = W x`` of the cells (see the module), radius ``radius`` in m."""

    def __init__(self, simulation: Any, radius: float) -> None:
        h = _neighbourhoods(simulation, radius)
        self.radius = float(radius)
        self.weights = sparse.diags(1.0 / np.asarray(h.sum(axis=1)).ravel()) @ h
        self.x_min = simulation.x_min

    def physical(self, x: np.ndarray) -> np.ndarray:
        """``x̃ = W x`` (a mean of densities in ``[x_min, 1]``, kept there against round-off)."""
        return np.clip(self.weights @ np.asarray(x, dtype=float), self.x_min, 1.0)

    def chain(self, dfdx_physical: np.ndarray) -> np.ndarray:
        """``df/dx = (df/dx̃) W`` for gradients of shape ``(n,)`` or ``(m, n)``."""
        return np.asarray((self.weights.T @ np.asarray(dfdx_physical).T).T)


class SensitivityFilter:
    """Sigmund's filter of the objective's gradient (see the module), radius in m."""

    def __init__(self, simulation: Any, radius: float) -> None:
        self.radius = float(radius)
        self.h = _neighbourhoods(simulation, radius)
        self.sums = np.asarray(self.h.sum(axis=1)).ravel()

    def filtered(self, x: np.ndarray, dfdx: np.ndarray) -> np.ndarray:
        """``H(x ⊙ ∂f/∂x) / (Σᵢ Hₑᵢ · max(10⁻³, x))``."""
        x = np.asarray(x, dtype=float)
        return (self.h @ (x * dfdx)) / self.sums / np.maximum(1e-3, x)
