"""Natural frequencies that meet a tolerance against the converged structure, whatever the
elements per bar of the dynamic model.

With one element per bar a bar's own bending modes do not exist in the model, and a thin
bar's mode can be the structure's second (the issue's random arm: 5.35 Hz true, 8.92 Hz at
one element). So the eigen-analysis refines every bar by ``r`` = 1, 2, 4, … (the same
design variables), solves each level in the engine (shift-invert Lanczos over the sparse
``LDLᵀ``, a Sturm count proving that no mode below the last one was skipped), and
extrapolates in ``r``. The frequencies converge at second order in the element length
(measured: the change quarters with each doubling once in range), so the Richardson value
of two levels, ``E(r) = (4 f(2r) − f(r))/3``, is returned. The extrapolated values
converge at fourth order (measured across the arm's design family: the change from one
to the next falls 16× per doubling), so the error of the latest is estimated as its
change from the previous one over 15 (measured: 1.0 to 1.3 times the true error). Refinement stops
when that estimate meets ``rtol`` on every frequency asked for.

The returned gradients are exact derivatives of the returned (extrapolated) frequencies:
the same combination of the levels' exact gradients. At a repeated frequency the single
derivatives are not defined; :func:`ks_lowest` aggregates the lowest frequencies into a
smooth lower bound whose gradient is well defined there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _core
from .errors import SettingsError, ToleranceError

Levels = Callable[[int], Any]
"""The engine model of a scene with ``r`` times its elements per bar."""

MAX_FREQUENCIES = 200
"""Most frequencies one call computes."""

MAX_MODAL_REFINEMENT = 128
"""Largest factor on the scene's elements per bar that the eigen-analysis refines to."""

ORDER = 2
"""Convergence order of the frequencies in the element length (measured, BENCHMARKS.md);
their Richardson values converge at ``ORDER + 2``."""


@dataclass(frozen=True)
class Modes:
    """The lowest natural frequencies (Hz) of a structure with its drives locked, their
    design gradients ``∂f/∂x`` (``n × n_design``), each one's estimated relative error
    against the converged structure, the refinement used (the finest level, a factor on
    the scene's elements per bar), and the Sturm proof at that level: ``below``
    frequencies lie under ``bound`` (Hz), and all of them were found."""

    frequencies: np.ndarray
    gradients: np.ndarray
    errors: np.ndarray
    refinement: int
    bound: float
    below: int

    def __repr__(self) -> str:
        freqs = ", ".join(f"{f:.4g}" for f in self.frequencies)
        if np.isnan(self.errors).all():
            return f"Modes([{freqs}] Hz, of the model as meshed)"
        return f"Modes([{freqs}] Hz, error ≤ {self.errors.max():.1e}, {self.refinement}× elements per bar)"


def natural_modes(levels: Levels, n: int, x: np.ndarray | None, rtol: float | None, settings: dict[str, Any]) -> Modes:
    """The ``n`` lowest modes at design ``x`` of the structure whose model at refinement
    ``r`` is ``levels(r)``: of the model as meshed when ``rtol`` is None, else of the
    converged structure to ``rtol``."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_FREQUENCIES:
        raise SettingsError(f"n: the number of frequencies must be an integer from 1 to {MAX_FREQUENCIES}, got {n!r}")
    if rtol is None:
        level = _level_modes(levels, 1, n, x, settings)
        return Modes(level["frequencies"], level["gradients"], np.full(n, np.nan), 1, level["bound"], level["below"])
    if not (isinstance(rtol, (int, float)) and 1e-8 <= rtol < 1):
        raise SettingsError(f"rtol: the frequencies' relative tolerance must lie in [1e-8, 1), got {rtol!r}")
    r = 1
    while _unknowns(levels, r) < n and r < MAX_MODAL_REFINEMENT:
        r *= 2
    solved = [_level_modes(levels, r, n, x, settings), _level_modes(levels, 2 * r, n, x, settings)]
    previous = None
    r *= 2
    while True:
        r *= 2
        if r > MAX_MODAL_REFINEMENT:
            raise ToleranceError(f"the frequencies do not meet rtol = {rtol:g} at {MAX_MODAL_REFINEMENT}× the scene's elements per bar")
        solved.append(_level_modes(levels, r, n, x, settings))
        if previous is None:
            previous = _extrapolate(solved[-3], solved[-2])
        current = _extrapolate(solved[-2], solved[-1])
        errors = np.abs(current[0] - previous[0]) / (2.0 ** (ORDER + 2) - 1) / np.abs(current[0])
        if np.all(errors <= rtol):
            finest = solved[-1]
            return Modes(current[0], current[1], errors, r, finest["bound"], finest["below"])
        previous = current


def _extrapolate(coarse: _core.NaturalModes, fine: _core.NaturalModes) -> tuple[np.ndarray, np.ndarray]:
    """Richardson's value of two levels a factor 2 apart, and its exact gradient."""
    c = 2.0**ORDER
    return ((c * fine["frequencies"] - coarse["frequencies"]) / (c - 1),
            (c * fine["gradients"] - coarse["gradients"]) / (c - 1))


def _unknowns(levels: Levels, r: int) -> int:
    """DOFs less constraint rows at refinement ``r``: an upper bound on its modes."""
    model = levels(r)
    return model.n_dofs - model.n_constraints


def _level_modes(levels: Levels, r: int, n: int, x: np.ndarray | None, settings: dict[str, Any]) -> _core.NaturalModes:
    return _core.natural_modes(levels(r), n, x, None, settings)


def ks_lowest(modes: Modes, scale: float, rho: float = 50.0) -> tuple[float, np.ndarray]:
    """A smooth lower bound of the lowest frequency over the frequencies of ``modes``,
    ``KS = −(s/ρ) ln Σ exp(−ρ f_j/s)`` with a fixed frequency ``scale`` s (Hz, e.g. the
    floor of a constraint), and its gradient (Hz per unit of x). A symmetric function of
    the frequencies: differentiable where the lowest ones coincide, where each one alone is
    not. ``f_1 − s ln(n)/ρ ≤ KS ≤ f_1``."""
    return ks_lowest_of(modes.frequencies, modes.gradients, scale, rho)


def ks_lowest_of(f: np.ndarray, g: np.ndarray, scale: float, rho: float = 50.0) -> tuple[float, np.ndarray]:
    """:func:`ks_lowest` of frequencies ``f`` (Hz) with their gradients ``g`` (one row each)."""
    if not (scale > 0 and rho > 0):
        raise SettingsError(f"ks_lowest: scale and rho must be positive, got {scale!r}, {rho!r}")
    z = -rho * f / scale
    w = np.exp(z - z.max())
    ks = -scale / rho * (np.log(w.sum()) + z.max())
    weights = w / w.sum()
    return float(ks), weights @ g
