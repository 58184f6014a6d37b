"""Filters on the densities of continuum members' cells, against checkerboards and mesh
dependence (Sigmund 2007; the 88-line code, Andreassen et al. 2011).

Both weigh a cell's neighbours within ``radius`` (m, so that the design's resolution does not
change with the mesh; or ``radius_cells``, in cells as the 88-line code's ``rmin``) by ``Hₑᵢ = max(0, 1 − |cₑ − cᵢ|/r)`` between reference centres (the
88-line code's ``r − |cₑ − cᵢ|`` over ``r``: the same filters, and no underflow of a tiny
radius), within the same member, over the cells that are design variables; a bar's variable is
left alone. A radius no longer than a member's cells reaches no neighbour in that direction:
warned (:class:`~flextop.errors.SettingsWarning`), as the design there is then mesh-dependent
(a radius below every cell's size leaves each cell its own density).

The designs they are handed are checked as the simulation checks one
(:meth:`~flextop.Simulation.checked_design`): a :class:`~flextop.errors.DesignError` names a
variable that is NaN or outside ``[x_min, 1]``.

* :class:`DensityFilter` (Bruns and Tortorelli): the simulation sees the physical densities
  ``x̃ = W x``, ``W = diag(1/Σᵢ Hₑᵢ) H``, and the gradients follow by the chain rule
  ``df/dx = (df/dx̃) W``: exact derivatives of what the optimizer is told.
* :class:`SensitivityFilter` (Sigmund): the simulation sees ``x`` and the objective's
  gradient is replaced by ``H(x ⊙ ∂f/∂x)/(Σᵢ Hₑᵢ · max(10⁻³, x))``, a heuristic that is not a
  derivative: the KKT residual the driver reports is then that of the filtered problem.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import scipy.sparse as sparse
from scipy.spatial import cKDTree

from ..checks import number
from ..errors import DesignError, SettingsError, SettingsWarning


def _neighbourhoods(simulation: Any, radius: float) -> sparse.csr_matrix:
    """``H`` over the design variables (identity on those that are no cells), ``radius``
    checked by :func:`_radius` first."""
    cells = simulation.model.cells()
    variable = np.asarray(cells["variable"])
    designed = variable >= 0
    if not designed.any():
        raise SettingsError("the scene has no designed cells of continuum members: nothing to filter")
    centre, member, variable = cells["centre"][designed], np.asarray(cells["member"])[designed], variable[designed]
    pairs = cKDTree(centre).sparse_distance_matrix(cKDTree(centre), radius, output_type="coo_matrix")
    # Pairs of distinct cells of one member (the distance matrix may or may not hold a cell
    # with itself), then each cell's own weight 1.
    same = (member[pairs.row] == member[pairs.col]) & (pairs.row != pairs.col)
    rows, cols = variable[pairs.row[same]], variable[pairs.col[same]]
    weights = np.concatenate([1.0 - pairs.data[same] / radius, np.ones(variable.size)])
    rows, cols = np.concatenate([rows, variable]), np.concatenate([cols, variable])
    _warn_if_unfiltered(simulation, radius)
    n = simulation.n_design
    others = np.setdiff1d(np.arange(n), variable)
    rows, cols = np.concatenate([rows, others]), np.concatenate([cols, others])
    weights = np.concatenate([weights, np.ones(others.size)])
    return sparse.csr_matrix((weights, (rows, cols)), shape=(n, n))


def _radius(filter: str, simulation: Any, radius: Any, radius_cells: Any) -> float:
    """The filter's radius in m: ``radius`` (m) or ``radius_cells`` times the side of the
    designed members' cells (the longer side, the same on every designed member), exactly
    one of them given; a SettingsError naming what is wrong."""
    if (radius is None) == (radius_cells is None):
        raise SettingsError(f"{filter}: give the radius in m (radius) or in cells (radius_cells), one of them")
    if radius is not None:
        return number(f"{filter}: radius (m)", radius, 0.0)
    cells = number(f"{filter}: radius_cells", radius_cells, 0.0)
    return cells * _cell_size(filter, simulation)


def _cell_size(filter: str, simulation: Any) -> float:
    """The longer side (m) of the designed members' cells, or a SettingsError where they
    differ from member to member (a radius in cells would then mean several lengths)."""
    table = simulation.model.cells()
    designed = {table["members"][m] for m, v in zip(table["member"], table["variable"]) if v >= 0}
    sizes = {m["name"]: max(m["length"] / m["nx"], m["height"] / m["ny"]) for m in simulation.spec.get("members", [])
             if m["name"] in designed}
    if not sizes:
        raise SettingsError("the scene has no designed cells of continuum members: nothing to filter")
    if not np.allclose(list(sizes.values()), next(iter(sizes.values())), rtol=1e-12, atol=0.0):
        listed = ", ".join(f"{name} {size:.4g} m" for name, size in sizes.items())
        raise SettingsError(f"{filter}: radius_cells needs cells of one size, and the members' differ ({listed}): give radius in m")
    return next(iter(sizes.values()))


def _gradient(name: str, values: Any, n: int) -> np.ndarray:
    """``values``, gradients of shape ``(n,)`` or ``(m, n)``, as a float array, or a
    DesignError naming ``name``: real numbers of that shape, finite."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise DesignError(f"{name} must be real numbers, got {type(values).__name__}") from None
    if array.ndim not in (1, 2) or array.shape[-1] != n:
        raise DesignError(f"{name} must be of shape ({n},) or (m, {n}), one entry per design variable, got {array.shape}")
    if not np.isfinite(array).all():
        raise DesignError(f"{name} holds {array[~np.isfinite(array)][0]} at entry {np.argwhere(~np.isfinite(array))[0].tolist()}: "
                          "gradients must be finite")
    return array


def _warn_if_unfiltered(simulation: Any, radius: float) -> None:
    """A :class:`SettingsWarning` for each member whose cells are as long (or as high) as
    the radius or more: no neighbour along that direction falls within it, so the filter
    leaves designs there as fine as the mesh (the 88-line code's radius is 1.5 cells and
    more)."""
    for member in simulation.spec.get("members", []):
        sizes = {"length": member["length"] / member["nx"], "height": member["height"] / member["ny"]}
        short = [f"{along} {size:.4g} m" for along, size in sizes.items() if radius <= size]
        if short:
            warnings.warn(f"filter radius {radius:g} m reaches no neighbouring cell of member '{member['name']}' along its "
                          f"{' and '.join(short)} (its cells' size): there the design is as fine as the mesh and changes "
                          "with it; take a radius of 1.5 cells or more", SettingsWarning, stacklevel=4)


class DensityFilter:
    """Physical densities of the cells (see the module), radius ``radius`` in m or
    ``radius_cells`` in cells (times the side of the designed members' cells, the longer
    side where they are not square; the 88-line code's ``rmin``): ``x̃ = W x``,
    or with a projection of sharpness ``beta`` about the threshold ``eta`` (Wang, Lazarov and
    Sigmund 2011), ``x̄ = (tanh βη + tanh β(x̃ − η)) / (tanh βη + tanh β(1 − η))`` mapped onto
    ``[x_min, 1]``, which pushes the filtered densities towards void and solid as β grows. ``beta`` may be raised between
    iterations (continuation, e.g. doubled every 50 from 1 to 16); the gradients are exact
    for the β of each evaluation. A bar's variable passes unchanged."""

    def __init__(self, simulation: Any, radius: float | None = None, *, radius_cells: float | None = None,
                 beta: float | None = None, eta: float = 0.5) -> None:
        self.radius = _radius("DensityFilter", simulation, radius, radius_cells)
        self.eta = number("DensityFilter: projection threshold eta", eta, 0.0, 1.0, "()")
        self.beta = beta
        h = _neighbourhoods(simulation, self.radius)
        self.simulation = simulation
        self.weights = sparse.diags(1.0 / np.asarray(h.sum(axis=1)).ravel()) @ h
        self.x_min = simulation.x_min
        cells = np.asarray(simulation.model.cells()["variable"])
        self.cells = np.zeros(simulation.n_design, bool)
        self.cells[cells[cells >= 0]] = True

    @property
    def beta(self) -> float | None:
        """The projection's sharpness, ``None`` without projection."""
        return self._beta

    @beta.setter
    def beta(self, value: float | None) -> None:
        self._beta = None if value is None else number("DensityFilter: projection sharpness beta", value, 0.0)

    def _projected(self, filtered: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``x̄`` and ``dx̄/dx̃`` on the cells' variables (identity elsewhere)."""
        if self._beta is None:
            return filtered, np.ones_like(filtered)
        b, e = self._beta, self.eta
        scale = np.tanh(b * e) + np.tanh(b * (1 - e))
        t = np.tanh(b * (filtered - e))
        # Onto [x_min, 1], the densities a design may take.
        span = 1.0 - self.x_min
        projected = np.where(self.cells, self.x_min + span * (np.tanh(b * e) + t) / scale, filtered)
        slope = np.where(self.cells, span * b * (1 - t**2) / scale, 1.0)
        return projected, slope

    def physical(self, x: np.ndarray) -> np.ndarray:
        """``x̄`` (or ``x̃`` without projection), kept in ``[x_min, 1]`` against round-off."""
        projected, _ = self._projected(self.weights @ self.simulation.checked_design(x))
        return np.clip(projected, self.x_min, 1.0)

    def to_dict(self) -> dict[str, Any]:
        """What rebuilds this filter on the same scene (for checkpoints): β as it stands."""
        return {"kind": "density", "radius": self.radius, "beta": self._beta, "eta": self.eta}

    def chain(self, x: np.ndarray, dfdx_physical: np.ndarray) -> np.ndarray:
        """``df/dx = (df/dx̄ ⊙ dx̄/dx̃) W`` at ``x``, for gradients of shape ``(n,)`` or
        ``(m, n)``."""
        x = self.simulation.checked_design(x)
        _, slope = self._projected(self.weights @ x)
        return np.asarray((self.weights.T @ (_gradient("dfdx_physical", dfdx_physical, x.size) * slope).T).T)


class SensitivityFilter:
    """Sigmund's filter of the objective's gradient (see the module), radius in m
    (``radius``) or in cells (``radius_cells``, as :class:`DensityFilter`)."""

    def __init__(self, simulation: Any, radius: float | None = None, *, radius_cells: float | None = None) -> None:
        self.radius = _radius("SensitivityFilter", simulation, radius, radius_cells)
        self.h = _neighbourhoods(simulation, self.radius)
        self.simulation = simulation
        self.sums = np.asarray(self.h.sum(axis=1)).ravel()

    def to_dict(self) -> dict[str, Any]:
        """What rebuilds this filter on the same scene (for checkpoints)."""
        return {"kind": "sensitivity", "radius": self.radius}

    def filtered(self, x: np.ndarray, dfdx: np.ndarray) -> np.ndarray:
        """``H(x ⊙ ∂f/∂x) / (Σᵢ Hₑᵢ · max(10⁻³, x))``."""
        x = self.simulation.checked_design(x)
        return (self.h @ (x * _gradient("dfdx", dfdx, x.size))) / self.sums / np.maximum(1e-3, x)


def from_dict(simulation: Any, data: dict[str, Any] | None) -> DensityFilter | SensitivityFilter | None:
    """The filter that ``to_dict`` described, on ``simulation`` (``None`` for none)."""
    if data is None:
        return None
    if data["kind"] == "density":
        return DensityFilter(simulation, data["radius"], beta=data["beta"], eta=data["eta"])
    if data["kind"] == "sensitivity":
        return SensitivityFilter(simulation, data["radius"])
    raise ValueError(f"unknown filter kind {data['kind']!r}")
