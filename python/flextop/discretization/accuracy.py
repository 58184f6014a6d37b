"""Accuracy presets: named tolerances of :mod:`flextop.discretization.tolerance`.

``Simulation(scene, accuracy=NAME)`` is ``Simulation(scene, rtol=PRESETS[NAME])``: every run
without an explicit ``h`` chooses the elements per bar and the step so that the estimated
error of its responses is within the tolerance (and their gradients within five times it).
What that gives, measured over 22 designs of two scenes against converged references, is in
BENCHMARKS.md ("Tolerances across designs", ``python benches/tolerance.py``).
"""

from __future__ import annotations

import copy
import math

from ..checks import number
from ..errors import SettingsError
from .members import split_members
from .tolerance import check_tolerance

PRESETS: dict[str, float] = {"fast": 3e-2, "balanced": 1e-2, "accurate": 3e-3}
"""Preset name → ``rtol``."""


def preset(name: str) -> float:
    """The tolerance called ``name``."""
    try:
        return PRESETS[name]
    except KeyError:
        raise SettingsError(f"accuracy must be one of {', '.join(PRESETS)}; got {name!r}") from None


def rtol_of(accuracy: str | None, rtol: float | None, atol: float) -> float | None:
    """The ``rtol`` a simulation holds: a preset's by name, ``rtol`` as given (checked with
    ``atol``), or ``None``; a :class:`SettingsError` where both are given."""
    number("atol", atol, 0.0, math.inf, "[)")  # checked where no rtol reads it too
    if accuracy is not None:
        if rtol is not None:
            raise SettingsError("give accuracy (a named tolerance) or rtol, not both")
        rtol = preset(accuracy)
    if rtol is not None:
        check_tolerance(rtol, atol)
    return rtol


def run_tolerance(own: tuple[float | None, float], rtol: float | None, atol: float | None,
                  h: float | None) -> tuple[float, float] | None:
    """The tolerance ``(rtol, atol)`` a run is made to, given the simulation's ``own``, or
    ``None`` for a run on a fixed step: an explicit ``h`` wins over the simulation's
    tolerance, and cannot be given with a run's own."""
    if h is not None and rtol is not None:
        raise SettingsError("give h (a fixed step) or rtol (steps chosen to meet it), not both")
    if atol is not None:
        number("atol", atol, 0.0, math.inf, "[)")
    wanted = own[0] if rtol is None else rtol
    if h is not None or wanted is None:
        return None
    atol = own[1] if atol is None else atol
    check_tolerance(wanted, atol)
    return wanted, atol


def split_by(spec: dict, factor: int) -> dict:
    """A copy of the scene dict with ``factor`` times the elements of every frame bar: the
    ``split`` of every ground structure and beam, and of every bar given its own in
    ``splits``. A truss bar stays one element (its axial behaviour is exact with one, and
    more would be a mechanism). Every continuum member's cells ``factor × factor`` times
    the elements, its rings and edge supports carried along
    (:func:`~flextop.discretization.members.split_members`)."""
    spec = copy.deepcopy(spec)
    split_members(spec, factor)
    trusses = set()
    for k, beam in enumerate(spec.get("beams", [])):
        if beam.get("kind") == "truss":
            trusses.add(beam.get("name") or f"beams[{k}]")
        else:
            beam["split"] = int(beam.get("split", 1)) * factor
    for g in spec.get("ground_structures", []):
        if g.get("kind") == "truss":
            trusses.add(f"{g['name']}/")
        else:
            g["split"] = int(g.get("split", 1)) * factor

    def truss(bar: str) -> bool:
        return bar in trusses or any(bar.startswith(t) for t in trusses if t.endswith("/"))

    if "splits" in spec:
        spec["splits"] = {bar: int(n) * (1 if truss(bar) else factor) for bar, n in spec["splits"].items()}
    return spec
