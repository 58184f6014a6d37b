"""Joint reactions after a kink of a drive's law, and peaks held to a tolerance.

1. The issue's rigid slider-crank (crank driven from rest at 3000 rad/s² up to 150 rad/s,
   the acceleration dropping to zero at t = 0.05 s, where the grid lands): the crank torque
   against closed-form inverse dynamics along the computed crank angle and rate with the
   law's own acceleration, relative to its peak, at every state (the state on the kink
   reports the left limit), at ρ∞ = 0.9 and 0.5 and halved steps.
2. The flexible slider-crank driven by the same law, four designs, runs to a tolerance of
   the crank torque (p-mean), the rod's stress and the force of the hinge A between crank
   and rod: their peaks against a reference on 16×
   the elements per bar and 32000 steps (and how far that reference moved from 16× and
   16000 steps), with the estimated errors the run reports.
3. ``--arm``: does a grid that lands on the robot arm's kinks (0.25 s, π/3 s and π/3 + 0.25 s,
   where both drives' accelerations jump by ∓2 rad/s²) converge faster than the uniform
   grids that runs to a tolerance use? Relative errors of d, ∇d and the peaks of the
   shoulder and elbow torques and of the elbow's reaction, at the scene's elements, on
   uniform grids of 68·2ᵏ steps and on grids of as many steps spread over the four pieces
   between kinks in proportion to their lengths (at least one step each at 17 steps),
   against a landing grid of 17408 steps.

    python benches/kink.py            # → benches/results/kink.md (about 10 min)
    python benches/kink.py --arm      # → benches/results/kink_arm.md (about 2 min)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))

import flextop  # noqa: E402
from flextop.scenes.builder import trapezoidal  # noqa: E402
from test_kink import KINK, crank_torque_errors  # noqa: E402

DRIVE = trapezoidal(0.0, 1000.0, acceleration=3000.0, speed=150.0)
NAMES = ["torque:crank", "stress", "reaction:A"]


def torque_table() -> list[str]:
    lines = ["| ρ∞ | h (µs) | largest error, every state | first state after the kink | ms |", "|---|---|---|---|---|"]
    for rho in (0.9, 0.5):
        for h in (5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5, 1.5625e-5):
            clock = time.perf_counter()
            errors = crank_torque_errors(h, rho)
            ms = 1e3 * (time.perf_counter() - clock)
            after = round(KINK / h) + 1
            lines.append(f"| {rho} | {h * 1e6:g} | {errors.max():.2e} | {errors[after]:.2e} | {ms:.0f} |")
    return lines


def slider_crank(**options: float) -> dict:
    spec = flextop.scenes.slider_crank(t_end=2 * KINK, **options).to_dict()
    spec["joints"][0]["drive"] = DRIVE
    return spec


def designs(n: int) -> dict[str, np.ndarray]:
    return {"uniform 0.1": np.full(n, 0.1), "uniform 1": np.ones(n), "graded 0.4–0.9": np.linspace(0.4, 0.9, n),
            "random": np.random.default_rng(7).uniform(0.05, 1.0, n)}


def peak_table() -> list[str]:
    sim = flextop.Simulation(slider_crank(h=5e-4))
    coarser, reference = (flextop.Simulation(slider_crank(h=h, split=split)) for split, h in ((16, 6.25e-6), (32, 3.125e-6)))
    lines = ["| design | rtol | discretization | s | torque peak error (est.) | stress peak error (est.) | hinge A force peak error (est.) |",
             "|---|---|---|---|---|---|---|"]
    for label, x in designs(sim.n_design).items():
        truth, rough = reference.run_with_sensitivities(x, NAMES).peaks, coarser.run_with_sensitivities(x, NAMES).peaks
        moved = [f"{abs(rough[n] - truth[n]) / abs(truth[n]):.1e}" for n in NAMES]
        lines.append(f"| {label} | reference (32×, 32000 steps) against 16×, 16000 steps | | | {' | '.join(moved)} |")
        for rtol in (3e-2, 1e-2, 3e-3):
            clock = time.perf_counter()
            try:
                out = sim.run_with_sensitivities(x, NAMES, rtol=rtol, hold_gradients=False)
            except flextop.ToleranceError as error:
                lines.append(f"| {label} | {rtol:g} | ToleranceError: {error} | | | | |")
                continue
            seconds = time.perf_counter() - clock
            cells = [f"{abs(out.peaks[n] - truth[n]) / abs(truth[n]):.2e} ({out.peak_errors[n]:.2e})" for n in NAMES]
            lines.append(f"| {label} | {rtol:g} | {out.discretization} | {seconds:.2f} | {' | '.join(cells)} |")
    return lines


ARM_KINKS = (0.25, np.pi / 3, np.pi / 3 + 0.25)
"""The arm's kinks (docs/reference-scenes.md): the end of the ramp up, the start and the
end of the ramp down, the same for both drives."""

ARM_NAMES = ["tip_deflection", "torque:shoulder", "torque:elbow", "reaction:elbow"]


def arm_grid(t_end: float, level: int, landing: bool) -> np.ndarray:
    """Steps of 17·2ᵏ over ``[0, t_end]``: uniform, or spread over the pieces between the
    arm's kinks in proportion to their lengths, each halved ``level`` times."""
    if not landing:
        n = 17 * 2**level
        return np.full(n, t_end / n)
    pieces = np.diff([0.0, *ARM_KINKS, t_end])
    counts = np.maximum(1, np.round(17 * pieces / t_end)).astype(int) * 2**level
    return np.concatenate([np.full(n, piece / n) for n, piece in zip(counts, pieces)])


def arm_table() -> list[str]:
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    t_end, n = 1.3, arm.n_design
    designs = {"uniform 0.4": np.full(n, 0.4), "uniform 1": np.ones(n),
               "random #0": np.random.default_rng(0).uniform(arm.x_min, 1.0, n)}
    settings = {"t_end": t_end, "method": "adjoint"}
    lines = ["| design | grid | steps | d | ∇d | shoulder torque peak | elbow torque peak | elbow reaction peak |",
             "|---|---|---|---|---|---|---|---|"]
    for label, x in designs.items():
        ref = arm.sensitivities_fixed(x, ARM_NAMES, settings, steps=arm_grid(t_end, 10, True))
        for landing in (False, True):
            for level in range(2, 8):
                steps = arm_grid(t_end, level, landing)
                out = arm.sensitivities_fixed(x, ARM_NAMES, settings, steps=steps)
                d = abs(out.values[0] - ref.values[0]) / ref.values[0]
                g = np.linalg.norm(out.gradients[0] - ref.gradients[0]) / np.linalg.norm(ref.gradients[0])
                peaks = [abs(out.peaks[m] - ref.peaks[m]) / ref.peaks[m] for m in ARM_NAMES[1:]]
                cells = " | ".join(f"{e:.1e}" for e in (d, g, *peaks))
                lines.append(f"| {label} | {'landing' if landing else 'uniform'} | {len(steps)} | {cells} |")
    return lines


def main() -> None:
    if "--arm" in sys.argv[1:]:
        lines = ["# The arm's kinks: grids that land on them against uniform grids", "", "`python benches/kink.py --arm`",
                 "", "Relative errors against a landing grid of 17408 steps, at the scene's elements.", "", *arm_table(), ""]
        out = ROOT / "benches" / "results" / "kink_arm.md"
        out.write_text("\n".join(lines))
        print("\n".join(lines))
        return
    lines = ["# Reactions after a kink; peaks held to a tolerance", "", "`python benches/kink.py`", "",
             "## Crank torque against inverse dynamics (rigid slider-crank, kink at 0.05 s)", "", *torque_table(), "",
             "## Peaks of a run to a tolerance (flexible slider-crank, same drive)", "", *peak_table(), ""]
    out = ROOT / "benches" / "results" / "kink.md"
    out.write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
