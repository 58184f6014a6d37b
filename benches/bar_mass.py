"""The mass of a split bar: consistent (linear interpolation), lumped, and ``bar_lumped``
(lumped, its end nodes coupled so that its rigid motion keeps its exact inertia).

1. A 1 m bar of the arm's section clamped at both ends, at x = 1 and 0.1: the error of its
   first frequency against the same mass at 256 elements.
2. The stayed frame (``flextop.scenes.stayed_frame``), solid but for its stay at x = 0.1,
   the stay alone split in m, 1920 steps: the errors of d and ∇d against the stay at 256
   elements with the same mass, and the unknowns against the one-element model.
3. The same frame run to rtol = 1e-2 (gradients held), against the stay at 256 elements on
   twice the steps.
4. The arm, every bar split alike (1 to 16), 544 steps: the error of d against 32
   elements per bar with the consistent mass, on four designs (does ``bar_lumped`` lose
   what the consistent mass is good at?).

    python benches/bar_mass.py      # → benches/results/bar_mass.md (about 3 min)
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))

import flextop  # noqa: E402
from test_bar_mass import stay_design as design  # noqa: E402
from test_bar_mass import stayed_frame as stayed  # noqa: E402
from test_refinement import bar_alone  # noqa: E402

KINDS = ("consistent", "lumped", "bar_lumped")


def clamped_bar() -> list[str]:
    lines = ["| x | mass | 2 | 4 | 8 | 16 | 32 elements |", "|---|---|---|---|---|---|---|"]
    for x in (1.0, 0.1):
        for kind in KINDS:
            f = {m: bar_alone(1.0, m).modes(1, np.array([x]), rtol=None, mass=kind).frequencies[0] for m in (2, 4, 8, 16, 32, 256)}
            lines.append(f"| {x:g} | {kind} | " + " | ".join(f"{f[m] / f[256] - 1:+.1e}" for m in (2, 4, 8, 16, 32)) + " |")
    return lines


def stay() -> list[str]:
    one = stayed(1).model.n_dofs
    lines = ["| mass | stay elements | unknowns | error of d | error of ∇d |", "|---|---|---|---|---|"]
    for kind in KINDS:
        runs = {}
        for m in (1, 2, 4, 8, 16, 32, 64, 256):
            sim = stayed(m)
            runs[m] = sim.run_with_sensitivities(design(sim), "tip_deflection", h=0.6 / 1920, mass=kind), sim.model.n_dofs
        ref = runs[256][0]
        for m in (1, 2, 4, 8, 16, 32, 64):
            out, n = runs[m]
            grad = np.linalg.norm(out.gradients - ref.gradients) / np.linalg.norm(ref.gradients)
            lines.append(f"| {kind} | {m} | {n / one:.2f}× | {abs(out.values[0] / ref.values[0] - 1):.1e} | {grad:.1e} |")
    return lines


def stay_to_tolerance() -> list[str]:
    sim = stayed(1)
    x = design(sim)
    lines = ["| mass | grid accepted | unknowns | s | error of d (est.) | error of ∇d (est.) |", "|---|---|---|---|---|---|"]
    for kind in ("consistent", "bar_lumped"):
        clock = time.perf_counter()
        out = sim.run_with_sensitivities(x, "tip_deflection", rtol=1e-2, mass=kind)
        seconds = time.perf_counter() - clock
        ref = stayed(256).run_with_sensitivities(x, "tip_deflection", h=0.6 / (2 * out.discretization.steps), mass=kind)
        grad = np.linalg.norm(out.gradients - ref.gradients) / np.linalg.norm(ref.gradients)
        unknowns = sim.levels.at(out.discretization, x).model.n_dofs / sim.model.n_dofs
        lines.append(f"| {kind} | {out.discretization} | {unknowns:.2f}× | {seconds:.1f} | {abs(out.values[0] / ref.values[0] - 1):.1e} "
                     f"({out.errors['tip_deflection']:.1e}) | {grad:.1e} ({out.gradient_errors['tip_deflection']:.1e}) |")
    return lines


def arm() -> list[str]:
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    n = sim.n_design
    designs = {"uniform 0.4": np.full(n, 0.4), "uniform 1": np.ones(n), "uniform 0.1": np.full(n, 0.1),
               "random #0": np.random.default_rng(0).uniform(sim.x_min, 1.0, n)}
    lines = ["| design | mass | 1 | 2 | 4 | 8 | 16 elements per bar |", "|---|---|---|---|---|---|---|"]
    for label, x in designs.items():
        ref = sim.levels[32].run(x, h=1.3 / 544, mass="consistent").tip_deflection()
        for kind in KINDS:
            d = [sim.levels[r].run(x, h=1.3 / 544, mass=kind).tip_deflection() for r in (1, 2, 4, 8, 16)]
            lines.append(f"| {label} | {kind} | " + " | ".join(f"{v / ref - 1:+.1e}" for v in d) + " |")
    return lines


def main() -> None:
    lines = ["# The mass of a split bar", "",
             f"`python benches/bar_mass.py` on {platform.processor() or platform.machine()}, {platform.python_version()}.", "",
             "## A clamped bar's first frequency (error against 256 elements)", "", *clamped_bar(), "",
             "## The stayed frame's soft stay, refined alone (1920 steps)", "", *stay(), "",
             "## The stayed frame run to rtol = 1e-2", "", *stay_to_tolerance(), "",
             "## The arm, every bar refined alike (error of d against 32 elements per bar, consistent)", "", *arm(), ""]
    (ROOT / "benches" / "results" / "bar_mass.md").write_text("\n".join(lines), encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
