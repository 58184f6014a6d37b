"""The paper's arm built as a spatial frame (``flextop.spatial.from_planar``) against the
planar engine on the same scene: run time at one, two and four elements per bar, full and
modified Newton, and the tip deflection (Eq. 40) from both engines; then, at a random design,
the mean strain energy and its gradient to the 148 densities from both engines and the
spatial adjoint's cost against a run. Medians of three runs.

    python benches/spatial_arm.py
"""

import statistics
import time

import numpy as np

import flextop
from flextop.spatial import from_planar


def seconds(run) -> float:
    times = []
    for _ in range(3):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    print("| elements per bar | h (s) | unknowns (spatial) | planar (s) | spatial, full Newton (s) | spatial, modified (s) "
          "| full / planar | d planar (m²) | d spatial (m²) | relative difference |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for split, h in [(1, 0.02), (2, 0.01), (4, 0.005)]:
        sim = flextop.Simulation(flextop.scenes.robot_arm(split=split, h=h))
        spatial = flextop.SpatialSimulation(from_planar(sim))
        planar_time = seconds(lambda: sim.run(None))
        full = seconds(lambda: spatial.simulate())
        modified = seconds(lambda: spatial.simulate(newton="modified"))
        d_planar = sim.run(None).tip_deflection()
        run = spatial.simulate()
        error = run.position(spatial.tip)[:, :2] - sim.rigid_trajectory(sim.tip, run.time)
        d_spatial = np.trapezoid(np.sum(error**2, axis=1), run.time) / run.time[-1]
        unknowns = 6 * len(spatial.model.node_names) + run.lam.shape[1]
        print(f"| {split} | {h} | {unknowns} | {planar_time:.3f} | {full:.3f} | {modified:.3f} | {full / planar_time:.1f} "
              f"| {d_planar:.6e} | {d_spatial:.6e} | {d_spatial / d_planar - 1:.1e} |")


def gradients() -> None:
    print()
    print("| elements per bar | U planar (J) | U spatial (J) | relative difference | ‖∇U spatial − ∇U planar‖ / ‖∇U planar‖ "
          "| spatial run (s) | spatial run + adjoint (s) | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    x = np.random.default_rng(1).uniform(0.3, 1.0, 148)
    for split, h in [(1, 0.02), (2, 0.01), (4, 0.005)]:
        sim = flextop.Simulation(flextop.scenes.robot_arm(split=split, h=h))
        spatial = flextop.SpatialSimulation(from_planar(sim))
        f, dfdx = sim.run_with_sensitivities(x, ["strain_energy"])
        g = spatial.run_with_sensitivities(x, "strain_energy", method="adjoint")
        run = seconds(lambda: spatial.simulate(x))
        adjoint = seconds(lambda: spatial.run_with_sensitivities(x, "strain_energy", method="adjoint"))
        u = g.values[0]
        gap = np.linalg.norm(g.dfdx - dfdx) / np.linalg.norm(dfdx)
        print(f"| {split} | {f[0]:.6e} | {u:.6e} | {u / f[0] - 1:.1e} | {gap:.1e} | {run:.3f} | {adjoint:.3f} "
              f"| {adjoint / run:.2f} |")


if __name__ == "__main__":
    main()
    gradients()
