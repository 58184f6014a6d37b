"""Accuracy presets: points on the work–precision Pareto front (benches/work_precision.py).

A preset refines a scene relative to its own settings — at least ``split`` elements per
bar, the scene's step size divided by ``step_divisor`` — and sets the Newton tolerance.
Measured errors against converged references (BENCHMARKS.md, "Work–precision"):

============  =====  ===========  =======  ========================================  ========================================
preset        split  step         tol      robot arm (h = 0.02 s): run / run + ∇,     spun beam (h = 0.005 s): run / run + ∇,
                                           error of d, ∇d, tip trajectory             error of d, ∇d, tip trajectory
============  =====  ===========  =======  ========================================  ========================================
``fast``      ≥ 1    h            1e-6     11 ms / 15 ms; 0.55 %, 2.8 %, 6.8 mm       1.4 ms / 1.8 ms; 0.25 %, 5.6 %, 1.9 mm
``balanced``  ≥ 2    h / 2        1e-6     41 ms / 55 ms; 0.23 %, 1.2 %, 1.9 mm       4.3 ms / 5.8 ms; 0.07 %, 1.4 %, 0.48 mm
``accurate``  ≥ 4    h / 4        1e-10    213 ms / 316 ms; 0.07 %, 0.35 %, 0.52 mm   20 ms / 25 ms; 0.02 %, 0.27 %, 0.10 mm
============  =====  ===========  =======  ========================================  ========================================

Consistent inertia and ρ∞ = 0.8 throughout: lumped inertia was never on the front (its
error in d is ten times larger at equal cost), and ρ∞ between 0.5 and 1 changes little.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass


@dataclass(frozen=True)
class Preset:
    """Refinement of a scene and of its run settings."""

    split: int
    step_divisor: int
    tol: float


PRESETS: dict[str, Preset] = {
    "fast": Preset(split=1, step_divisor=1, tol=1e-6),
    "balanced": Preset(split=2, step_divisor=2, tol=1e-6),
    "accurate": Preset(split=4, step_divisor=4, tol=1e-10),
}


def preset(name: str) -> Preset:
    """The preset called ``name``."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"accuracy must be one of {', '.join(PRESETS)}; got {name!r}") from None


def refine(spec: dict, p: Preset) -> dict:
    """A copy of the scene dict with at least ``p.split`` elements per bar and the default
    step size divided by ``p.step_divisor``."""
    spec = copy.deepcopy(spec)
    for entry in spec.get("ground_structures", []) + spec.get("beams", []):
        entry["split"] = max(int(entry.get("split", 1)), p.split)
    simulation = spec.get("simulation", {})
    if "h" in simulation:
        simulation["h"] = simulation["h"] / p.step_divisor
    return spec


def split_by(spec: dict, factor: int) -> dict:
    """A copy of the scene dict with ``factor`` times the elements per bar of every ground
    structure and beam."""
    spec = copy.deepcopy(spec)
    for entry in spec.get("ground_structures", []) + spec.get("beams", []):
        entry["split"] = int(entry.get("split", 1)) * factor
    return spec
