"""The paper's arm optimized in both engines: its tip deflection (Eq. 40) at 40 % of each
link's volume (Eq. 41) by MMA from x = 0.4, on the planar scene (``robot_arm_problem``) and
on the same scene built as a spatial one (``flextop.spatial.from_planar``: its bars beams in
the plane z = 0, the planar variables in order; ``SpatialProblem(..., per_structure=True)``),
each on its scene's grid (one element per bar, h = 20 ms); each optimum started from in the
other engine's problem; then both optima measured to rtol 1e-2 in each engine. With
``--tolerance``: both optimizations held to rtol 1e-2 (the
planar problem's and the spatial problem's rule: measured where an accepted design moved,
the grid held between). With ``--converged``: both optima measured to rtol 1e-3 in each engine
too (about 10 minutes, the spatial engine's runs the most of it).

    python benches/spatial_planar_optimum.py [--tolerance] [--converged]
"""

import sys
import time

import numpy as np

import flextop
from flextop.problems import SpatialProblem, TopologyProblem, robot_arm_problem, volume_constraints
from flextop.spatial import SpatialSimulation, from_planar

ITERATIONS, KKT = 300, 1e-4


def main(rtol: float | None, converged: bool = False) -> None:
    planar = robot_arm_problem("tip_deflection")
    sim = planar.simulation
    if rtol is not None:
        planar = TopologyProblem(sim, "tip_deflection", volume_constraints(sim, 0.4), rtol=rtol)
    spatial_sim = SpatialSimulation(from_planar(sim))
    spatial = SpatialProblem(spatial_sim, "tip_deflection", volume=0.4, per_structure=True, rtol=rtol)
    assert spatial_sim.variables == tuple(sim.variable_names)
    def tip(engine: str, x: np.ndarray) -> float:
        """d of design ``x`` in ``engine``, on its scene's grid."""
        run = (sim.run_with_sensitivities(x, ["tip_deflection"]) if engine == "planar"
               else spatial_sim.run_with_sensitivities(x, "tip_deflection"))
        return float(run.values[0])

    results = {}
    print("| engine | iterations | evaluations | d / start | d on the scene's grid (m²) | KKT residual | status | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for name, problem in (("planar", planar), ("spatial", spatial)):
        start = time.perf_counter()
        result = flextop.optimize(problem, 0.4, method="mma", max_iter=ITERATIONS, kkt_tol=KKT)
        elapsed = time.perf_counter() - start
        d, d_start = (tip(name, result.x), tip(name, np.full(len(result.x), 0.4)))
        results[name] = (result.x, d)
        print(f"| {name} | {result.nit} | {result.nfev} | {d / d_start:.4f} | {d:.6e} | {result.kkt:.2e} "
              f"| {result.status.name} | {elapsed:.1f} |", flush=True)
    (xp, dp), (xs, ds) = results["planar"], results["spatial"]
    print(f"\nd spatial / planar − 1 = {ds / dp - 1:+.2e}; designs: max |Δx| = {np.abs(xp - xs).max():.3f}, "
          f"mean {np.abs(xp - xs).mean():.4f}\n")
    print("| optimum | started from in | iterations | KKT residual there | d there on its grid (m²) | d there / d in its engine − 1 |")
    print("|---|---|---|---|---|---|")
    problems = {"planar": planar, "spatial": spatial}
    for name, other in (("planar", "spatial"), ("spatial", "planar")):
        x, d = results[name]
        there = flextop.optimize(problems[other], x, method="mma", max_iter=ITERATIONS, kkt_tol=KKT)
        d_there = tip(other, there.x)
        print(f"| {name} | {other} | {there.nit} | {there.kkt:.2e} | {d_there:.6e} | {d_there / d - 1:+.1e} |", flush=True)
    print()
    for measure in (1e-2, 1e-3) if converged else (1e-2,):
        print(f"| optimum | d planar, rtol {measure:g} (m²) | estimated error | d spatial, rtol {measure:g} (m²) "
              "| estimated error | spatial / planar − 1 |")
        print("|---|---|---|---|---|---|")
        for name, (x, _) in results.items():
            p = sim.run_with_sensitivities(x, ["tip_deflection"], rtol=measure)
            s = spatial_sim.run_with_sensitivities(x, "tip_deflection", rtol=measure)
            print(f"| {name} | {p.values[0]:.6e} | {p.errors['tip_deflection']:.1e} | {s.values[0]:.6e} "
                  f"| {s.errors['tip_deflection']:.1e} | {s.values[0] / p.values[0] - 1:+.1e} |", flush=True)
        print()


if __name__ == "__main__":
    main(1e-2 if "--tolerance" in sys.argv[1:] else None, converged="--converged" in sys.argv[1:])
