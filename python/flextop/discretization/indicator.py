"""Where a bar needs more elements: the a-priori indicator, each bar's own lowest bending
frequency, and the refinement it grades.

A two-node element with the exact static stiffness (``src/mechanism/element/beam.rs``)
has no internal dynamics: a bar whose own modes lie far above the motion is exact with
one element, and a bar whose own modes fall in the band needs more, whatever the others
do. The engine gives each bar's lowest clamped–clamped frequency ``f_b`` from its length,
section, density and material laws (``Model.bar_frequencies``, within 0.03 % of a modal
analysis of the bar alone for ``L/r ≥ 50``) and its mass ``M_b`` (``Model.bar_masses``).
Under the default mass law ``f_b`` is lowest near ``x = 0.1`` (mass linear above,
stiffness ``x³``), a tenth of the solid bar's.

A bar's internal dynamics enter a response through its end forces, about
``M_b ω² u (f/f_b)²`` below its own frequency, and the element's error in them falls like
``1/m²`` (a clamped bar's frequency error: 1.5 %, 0.39 %, 0.098 % at 8, 16, 32
elements). A bar's share of the error is thus about ``η_b/m_b²`` with its **need**
``η_b = M_b / f_b²``, and the fewest elements for a given total error give each bar
``m_b ∝ η_b^(1/3)``. A refinement ``r`` of a dynamic scene is graded so: the bars of the
largest need get ``r`` times their elements, and each factor 8 of need below halves that,
down to one.

Measured on the robot arm (each bar refined alone against all bars at once, 1088 steps):
the bars' shares add up (7.63e-3 against 7.76e-3 on d), 6 bars of 148 carry half the
change of ∇d and 14 carry 80 %, and they are the bars of the largest need: on the arm
solid but for its 1.0 m diagonal at x = 0.1, the four solid 1 m chords (90 Hz, 0.85 kg)
first, then the diagonal (9 Hz, 0.085 kg). On the designs an optimizer passes through
(iterations 5, 10, 20 and 40 of both objectives under both mass laws, rtol = 1e-2 on
values), the graded grids met the tolerance with 2–5× fewer unknowns than uniform
refinement, in 40 % less time (BENCHMARKS.md, "Refinement bar by bar").

A static scene has no band: its refinement stays uniform.

**The a-posteriori indicator** (:func:`shares`): each bar's share of the change of a
response when the frame bars' elements are split in two, from one run of the split scene
on the same steps and two adjoint sweeps of the scene as it is. The split run's values at
the scene's nodes satisfy the scene's own scheme but for a residual that is a sum over the
bars (each bar's terms on its nodes, minus its halves'); weighted by the adjoint (the
trapezoidal rule, the adjoint linearized about both runs), it is the change to third order
(``src/sensitivity/shares.rs``). Measured (``python benches/refinement.py --dual``): the
shares add up to the measured change within 0.7 % on the stayed frame, the spun beam and
four of five arm designs, and a bar's share is within 10 % of the change its splitting
alone makes on the five bars that matter most where the bars act alone (0.90–1.07; 0.81 at
the arm's uniform 0.4, whose bars split one by one sum to 1.28 times the change); on the arm
at uniform 0.1, where every bar is near
its own frequency and the bars' changes do not add (splitting them one by one sums to −1.8
times splitting all), the sum is 1.32 times the change. The coarse run's adjoint alone gets
even the sign wrong on the stayed frame's stay.
``refine="shares"`` refines by them (:func:`flextop.discretization.refinement.marks`).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .. import _core
from ..errors import SettingsError


def bar_factors(model: _core.Model, x: np.ndarray | None, refinement: int, dynamic: bool = True) -> np.ndarray:
    """Each bar's factor on its elements at ``refinement`` (a power of two) for the design
    ``x``: ``refinement`` on the bars of the largest need ``η = M_b / f_b²``, halved for
    each factor 8 of need below it, at least 1; ``refinement`` on every bar of a static
    scene or one whose bars have no need (no mass, or no finite frequency)."""
    return graded(model.bar_frequencies(x), model.bar_masses(x), refinement, dynamic)


def graded(frequencies: Any, masses: Any, refinement: int, dynamic: bool = True) -> np.ndarray:
    """Each bar's factor on its elements at ``refinement`` from its own ``frequencies`` (Hz)
    and ``masses`` (kg): :func:`bar_factors`'s rule, for a planar scene's bars or a spatial
    scene's beams."""
    frequencies, masses = np.asarray(frequencies, dtype=float), np.asarray(masses, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(np.isfinite(frequencies) & (frequencies > 0), masses / frequencies**2, 0.0)
    factors = np.full(len(need), refinement, dtype=np.int64)
    if not dynamic or not (need > 0).any():
        return factors
    with np.errstate(divide="ignore"):
        octaves = np.floor(np.log2(need.max() / need) / 3)
    halvings = np.minimum(octaves, 63).astype(np.int64)
    return np.maximum(1, factors >> halvings)


def refined_spec(spec: dict[str, Any], bars: _core.BarTable, factors: np.ndarray) -> dict[str, Any]:
    """A copy of the scene dict in which each frame bar has ``factors`` times the elements it
    has in ``bars`` (the built scene's), through the scene's ``splits`` table; a truss bar
    stays one element."""
    spec = copy.deepcopy(spec)
    splits = spec.setdefault("splits", {})
    for name, elements, factor, kind in zip(bars["name"], bars["elements"], factors, bars["kind"]):
        if factor != 1 and kind != "truss":
            splits[name] = int(elements) * int(factor)
    return spec


class _Runs(Protocol):
    """What :func:`shares` reads of a :class:`flextop.Simulation`."""

    model: _core.Model
    levels: Any

    @property
    def analysis(self) -> str: ...

    def run_fixed(self, xv: np.ndarray | None, settings: dict[str, Any], *, steps: np.ndarray | None = None) -> Any: ...


@dataclass(frozen=True)
class Shares:
    """Each bar's share of the change of each response when every frame bar's elements are
    split in two (:func:`shares`): ``shares[name]`` over the bars ``bars`` (a truss bar's is
    zero: it stays one element), the values ``coarse`` and ``fine`` of both runs, and their
    measured ``change``. What the shares do not hold, ``unattributed``, is the response's own
    reading of split bars (a strain energy's or a stress's) and the linearization's error."""

    bars: tuple[str, ...]
    shares: dict[str, np.ndarray]
    coarse: dict[str, float]
    fine: dict[str, float]

    @property
    def change(self) -> dict[str, float]:
        """``fine − coarse`` of each response."""
        return {name: self.fine[name] - self.coarse[name] for name in self.coarse}

    @property
    def unattributed(self) -> dict[str, float]:
        """The measured change less the sum of the shares, of each response."""
        return {name: self.change[name] - float(self.shares[name].sum()) for name in self.coarse}


def shares(simulation: _Runs, x: np.ndarray, names: list[str], settings: dict[str, Any], steps: np.ndarray,
           split: Any = None) -> Shares:
    """Each bar's share of the change of responses ``names`` for design ``x`` from the scene
    as it is to the scene with twice the elements of every frame bar, both on ``steps``
    (dual-weighted residuals: the module's docstring). ``split``: that finer scene's run of
    ``x`` on ``steps``, if one was made (a run to a tolerance's space companion); else it is
    made here with ``settings``."""
    if simulation.analysis != "dynamic":
        raise SettingsError("bar shares are measured on a dynamic run; a static scene's refinement is uniform")
    run = split if split is not None else simulation.levels[2].run_fixed(x, settings, steps=steps)
    fine, raw = run.simulation, run.raw
    out = _core.bar_shares(simulation.model, fine.model, x, names, settings, [float(h) for h in steps],
                           raw["q"], raw["qdot"], raw["qddot"], raw["lam"])
    return Shares(bars=tuple(simulation.model.bars()["name"]),
                  shares={name: out["shares"][k] for k, name in enumerate(names)},
                  coarse={name: float(out["values"][k]) for k, name in enumerate(names)},
                  fine={name: float(run.response(name)) for name in names})
