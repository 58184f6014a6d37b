"""Designing the spatial robot arm (``flextop.scenes.spatial_robot_arm``): the cost of a run
with its adjoint gradient to every bar's density at two lattice connectivities, and the arm's
dynamic compliance ``∫U dt`` minimized by MMA (``flextop.optimizers.FunctionProblem``) at 40 %
of the full volume from the uniform design. Medians of three runs.

    python benches/spatial_design.py
"""

import statistics
import time

import numpy as np

import flextop
from flextop.optimizers import EvaluationError, FunctionProblem


def seconds(run) -> float:
    times = []
    for _ in range(3):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def costs() -> None:
    print("| lattice | connectivity | bars | unknowns | run (s) | run + adjoint (s) | ratio |")
    print("|---|---|---|---|---|---|---|")
    for nx, connectivity in ((5, "diagonals"), (5, "full"), (6, "full")):
        sim = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm(nx=nx, connectivity=connectivity))
        x = np.full(sim.n_design, 0.5)
        run = seconds(lambda: sim.simulate(x))
        adjoint = seconds(lambda: sim.run_with_sensitivities(x, "strain_energy", method="adjoint"))
        lam = sim.simulate(x, t_end=0.01).lam.shape[1]
        unknowns = 6 * len(sim.model.node_names) + lam
        print(f"| {nx} × 2 × 2 | {connectivity} | {sim.n_design} | {unknowns} | {run:.3f} | {adjoint:.3f} | {adjoint / run:.2f} |")


def optimization(iterations: int = 60, fraction: float = 0.4) -> None:
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm())
    volumes = np.asarray(sim.model.volumes[0])
    budget = fraction * volumes.sum()
    x0 = np.full(sim.n_design, fraction)
    reference = sim.run_with_sensitivities(x0, "strain_energy", method="adjoint").values[0]

    def objective(x):
        try:
            g = sim.run_with_sensitivities(x, "strain_energy", method="adjoint")
        except flextop.SimulationError as error:  # a trial the optimizer steps back from
            raise EvaluationError(str(error), x) from error
        return g.values[0] / reference, g.dfdx[0] / reference

    def constraints(x):
        return np.array([volumes @ x / budget - 1.0]), (volumes / budget)[None, :]

    problem = FunctionProblem(objective, constraints, np.full(sim.n_design, sim.x_min), np.ones(sim.n_design), 1)
    start = time.perf_counter()
    result = flextop.optimize(problem, x0, method="mma", max_iter=iterations, kkt_tol=1e-4)
    elapsed = time.perf_counter() - start
    print()
    print("| bars | iterations | ∫U dt / uniform | KKT residual | volume / budget | status | time (s) |")
    print("|---|---|---|---|---|---|---|")
    print(f"| {sim.n_design} | {result.nit} | {result.fun:.4f} | {result.kkt:.2e} | {volumes @ result.x / budget:.4f} "
          f"| {result.status.name} | {elapsed:.1f} |")


if __name__ == "__main__":
    costs()
    optimization()
