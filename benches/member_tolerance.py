"""Continuum members under the accuracy contract: the continuum arm (``continuum_robot_arm``,
NX × NY cells per link, its scene's 100 steps) run with its tip deflection's gradient to
rtol 1e-2 on a family of designs — uniform low, mid and full density, random, random
smoothed by a density filter, and the design MMA reaches with that filter in 40 iterations
(tip deflection at half the volume, on the scene's grid) and one it passes on the way —,
each against a reference on the scene refined eight times per side of a cell
(``split_by(spec, 8)``), Richardson's extrapolation of its runs at an eighth and a
sixteenth of the scene's step (the change it makes printed), and against the scene's own
grid.

    python benches/member_tolerance.py [NX NY]      # 10 4 if not given
"""

import sys
import time

import numpy as np

import flextop
from flextop.discretization import split_by
from flextop.errors import ToleranceError
from flextop.problems import DensityFilter, TopologyProblem, volume_constraints

RTOL, REFERENCE, NAME = 1e-2, 8, "tip_deflection"


def designs(sim: flextop.Simulation) -> dict[str, np.ndarray]:
    """The family of designs (module docstring), physical densities of the cells."""
    n = sim.n_design
    rng = np.random.default_rng(0)
    cells = DensityFilter(sim, radius_cells=1.5)
    family = {f"uniform {x}": np.full(n, x) for x in (0.1, 0.5, 1.0)}
    family["random in [0.2, 1]"] = rng.uniform(0.2, 1.0, n)
    family["random, filtered"] = cells.physical(rng.uniform(0.01, 1.0, n))
    problem = TopologyProblem(sim, NAME, volume_constraints(sim, 0.5), filter=cells)
    passed = flextop.optimize(problem, 0.5, method="mma", max_iter=10)
    family["MMA iterate 10"] = cells.physical(passed.x)
    optimum = flextop.optimize(problem, 0.5, method="mma", max_iter=40)
    family["MMA iterate 40"] = cells.physical(optimum.x)
    return family


def main(nx: int, ny: int) -> None:
    sim = flextop.Simulation(flextop.scenes.continuum_robot_arm(nx=nx, ny=ny))
    h = sim.spec["simulation"]["h"]
    reference_sim = flextop.Simulation(split_by(sim.spec, REFERENCE))
    print(f"`python benches/member_tolerance.py {nx} {ny}`: continuum arm, {nx} × {ny} cells per link, rtol {RTOL}\n")
    print("| design | d to rtol (m²) | estimate | true error | gradient's true error | discretization | cost (runs on the scene's grid) | the scene's grid's error | reference's time correction |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, x in designs(sim).items():
        clock = time.perf_counter()
        own = sim.run_with_sensitivities(x, [NAME])
        base = time.perf_counter() - clock
        coarse, fine = (reference_sim.run_with_sensitivities(x, [NAME], h=h / k) for k in (8, 16))
        d_ref = (4 * fine.values[0] - coarse.values[0]) / 3
        g_ref = (4 * fine.gradients[0] - coarse.gradients[0]) / 3
        moved = abs(d_ref / fine.values[0] - 1)
        scene = abs(own.values[0] / d_ref - 1)
        clock = time.perf_counter()
        try:
            run = sim.run_with_sensitivities(x, [NAME], rtol=RTOL)
        except ToleranceError as error:
            print(f"| {name} | — | — | — | — | ToleranceError: {str(error)[:160]} | {(time.perf_counter() - clock) / base:.0f} | {scene:.1e} | {moved:.1e} |",
                  flush=True)
            continue
        cost = (time.perf_counter() - clock) / base
        true = abs(run.values[0] / d_ref - 1)
        gradient = np.linalg.norm(run.gradients[0] - g_ref) / np.linalg.norm(g_ref)
        print(f"| {name} | {run.values[0]:.6e} | {run.errors[NAME]:.1e} | {true:.1e} | {gradient:.1e} | {run.discretization} "
              f"| {cost:.0f} | {scene:.1e} | {moved:.1e} |", flush=True)


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:3]]
    main(*(args if len(args) == 2 else (10, 4)))
