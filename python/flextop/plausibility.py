"""Plausibility of a scene's sections and continuum members: values that run but are almost
surely a slip of units.

flextop works in SI units throughout (metres, kilograms, seconds, pascals). A value far
outside what any structural material or member has — ``E = 70`` meant as 70 GPa, a
diameter of 20 meant in millimetres — builds and runs, and gives absurd answers quietly
(the arm with ``E = 70`` deflects 1.2 m at the tip of a 2 m arm). :func:`check` warns about
each such value with a :class:`~flextop.errors.PlausibilityWarning` naming the entry, its
value and the plausible range; the run goes on, since a study may mean it. A static scene
of the linear analysis (``analysis = "linear"`` in its ``[simulation]`` table) is the same
in any consistent units (its displacements scale as F/E): its material properties are not
judged, so the 88-line code's E = 1 under a unit load is no slip.

The ranges (the plausible span of solids used in structures, with a margin):

========================  =============================  ==========================================
quantity                  plausible                      outside it
========================  =============================  ==========================================
``E``                     1e6 Pa to 1.2e12 Pa            soft elastomers to diamond
``G`` (when given)        3e5 Pa to 6e11 Pa              the same, over 2(1 + ν)
``rho``                   10 kg/m³ to 23,000 kg/m³       rigid foams to osmium
``diameter``              at most the model's size       a section wider than the mechanism
``thickness`` (members)   at most the model's size       a plate thicker than the mechanism is wide
========================  =============================  ==========================================
"""

from __future__ import annotations

import warnings
from typing import Any

from .checks import real
from .errors import PlausibilityWarning

RANGES: dict[str, tuple[float, float, str]] = {
    "E": (1e6, 1.2e12, "Pa"),
    "G": (3e5, 6e11, "Pa"),
    "rho": (10.0, 23000.0, "kg/m³"),
}
"""Per material property of a section or a member: the plausible ``(low, high, unit)``."""


def check(spec: dict[str, Any], size: float) -> None:
    """Warns about every section's and continuum member's material property of ``spec``
    outside its plausible range, every solid circle wider than ``size`` (the model's
    extent, m) and every member thicker than it; the properties not in a scene of the linear
    analysis, which has no units of its own."""
    simulation = spec.get("simulation")
    linear = spec.get("analysis") == "static" and isinstance(simulation, dict) and simulation.get("analysis") == "linear"
    ranges = {} if linear else RANGES
    for name, section in (spec.get("sections") or {}).items():
        if isinstance(section, dict):
            _check_entry(f"sections.{name}", section, "diameter", size, ranges)
    for k, member in enumerate(spec.get("members") or []):
        if isinstance(member, dict):
            _check_entry(f"members[{k}] ({member.get('name')})", member, "thickness", size, ranges)


def _check_entry(path: str, entry: dict[str, Any], width: str, size: float, ranges: dict[str, tuple[float, float, str]]) -> None:
    """The material properties of the scene's entry at ``path`` in ``ranges``, and its
    ``width`` (a section's diameter, a member's thickness) against the model's ``size``."""
    for key, (low, high, unit) in ranges.items():
        value = real(entry.get(key))
        if value is not None and not low <= value <= high:
            _warn(f"{path}.{key} = {value:g} {unit} is outside the plausible {low:g}–{high:g} {unit} of "
                  f"structural solids (SI units throughout: aluminium is E = 70e9 Pa, rho = 2700 kg/m³)")
    value = real(entry.get(width))
    if value is not None and size > 0 and value > size:
        _warn(f"{path}.{width} = {value:g} m is wider than the whole mechanism ({size:.3g} m across): "
              f"a {width} is in metres")


def _warn(message: str) -> None:
    warnings.warn(PlausibilityWarning(message), stacklevel=5)
