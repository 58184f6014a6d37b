"""Designing the spatial robot arm (``flextop.scenes.spatial_robot_arm``): the cost of a run
with its adjoint gradient to every bar's density at two lattice connectivities, and the arm's
dynamic compliance ``∫U dt`` and its payload's mean squared deflection from the rigid
trajectory (``tip_deflection``, paper Eq. 40) each minimized by MMA
(``flextop.problems.SpatialProblem``) at 40 % of the full volume from the uniform design;
the paper's arm as 3D lattices (``spatial_paper_arm``) designed for its tip deflection at
40 % of each link's volume, evaluated on finer steps. Medians of three runs. With
``--stress``: only the arm's tip deflection at 40 % of its volume under a limit on its peak
stress over the motion (the uniform design's), against the same optimization without it.
With ``--sizing``: the arm's tubes sized instead (their outer and inner diameters at the
start's mass, ``SizingProblem``; ``--held``: held to rtol 1e-2). With ``--places``: the spatial slider-crank's drive effort
over its joints' places instead (``SizingProblem(..., places=...)``). With ``--tolerance``: the arm's tip deflection at 40 % of
its volume by MMA held to rtol 1e-2 (``SpatialProblem(..., rtol=1e-2)``), against the same
optimization on the scene's grid, both optimized designs measured to rtol 1e-2 and 1e-3; each
iteration's progress on stderr; with ``--plain`` too, by plain MMA (one evaluation per
iteration) instead of MMA with its safeguard; ``--iterations N``: N of them (100); ``--save DIR``:
each optimized design written to ``DIR`` as ``.npy`` as soon as its optimization ends, before
the long measurements of the last table.
With ``--polish``: the same optimization on the scene's grid (100 iterations), then from its
design held to rtol 1e-2 (60 at most), each design measured to rtol 1e-2.
With ``--hundred``: 100 iterations of the arm's tip deflection by MMA with its safeguard and by
plain MMA, the design issue's floor (``--nx 6 --full``: on the arm of 472 bars, links of 6 × 2 × 2
nodes with every bar; ``--built``: the start and both designs then run to rtol 1e-2, as built). With ``--costs``: the cost table alone, which also times
the adjoint of four responses at once (``FOUR``).

    python benches/spatial_design.py [--costs | --stress | --sizing [--held] | --places | --polish | --tolerance [--plain] [--iterations N] [--save DIR] | --hundred [--nx 6 --full] [--built]]
"""

import sys
import time
from typing import Any
from pathlib import Path

import numpy as np

import flextop
from flextop.optimizers import MMA
from flextop.problems import SizingProblem, SpatialProblem

import bench_args
from spatial_arm import seconds  # medians of three, as that bench times its runs


FOUR = ["strain_energy", "tip_deflection", "kinetic_energy", "compliance"]
"""The responses of the cost table's last columns: one backward sweep carries them all."""


def costs() -> None:
    print("| lattice | connectivity | bars | unknowns | run (s) | run + adjoint (s) | ratio | run + adjoint of 4 responses (s) | ratio |")
    print("|---|---|---|---|---|---|---|---|---|")
    for nx, connectivity in ((5, "diagonals"), (5, "full"), (6, "full")):
        sim = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm(nx=nx, connectivity=connectivity))
        x = np.full(sim.n_design, 0.5)
        run = seconds(lambda: sim.simulate(x))
        adjoint = seconds(lambda: sim.run_with_sensitivities(x, "strain_energy", method="adjoint"))
        four = seconds(lambda: sim.run_with_sensitivities(x, FOUR, method="adjoint"))
        lam = sim.simulate(x, t_end=0.01).lam.shape[1]
        unknowns = 6 * len(sim.model.node_names) + lam
        print(f"| {nx} × 2 × 2 | {connectivity} | {sim.n_design} | {unknowns} | {run:.3f} | {adjoint:.3f} | {adjoint / run:.2f} "
              f"| {four:.3f} | {four / run:.2f} |")


def optimization(response: str, iterations: int = 60, fraction: float = 0.4) -> None:
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm())
    problem = SpatialProblem(sim, response, volume=fraction)
    x0 = np.full(sim.n_design, fraction)
    start = time.perf_counter()
    result = flextop.optimize(problem, x0, method="mma", max_iter=iterations, kkt_tol=1e-4)
    elapsed = time.perf_counter() - start
    print(f"| {response} | {sim.n_design} | {result.nit} | {result.fun:.4f} | {result.kkt:.2e} "
          f"| {sim.volume(result.x) / (fraction * sim.volume(1.0)):.4f} | {result.status.name} | {elapsed:.1f} |")


def paper_arm(iterations: int = 60) -> None:
    """The paper's arm as 3D lattices (``flextop.scenes.spatial_paper_arm``, 746 bars, the
    payload 5 cm off the links' plane): its tip deflection minimized by MMA at 40 % of each
    link's volume (paper Eq. 41) from the uniform design, then both designs evaluated as the
    optimizer saw them (h = 20 ms) and on finer steps."""
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_paper_arm())
    problem = SpatialProblem(sim, "tip_deflection", volume=0.4, per_structure=True)
    x0 = np.full(sim.n_design, 0.4)
    start = time.perf_counter()
    result = flextop.optimize(problem, x0, method="mma", max_iter=iterations, kkt_tol=1e-4)
    elapsed = time.perf_counter() - start
    used = " / ".join(f"{sim.volume(result.x, n) / sim.volume(1.0, n):.3f}" for n in ("link1", "link2"))
    print("| bars | iterations | evaluations | d / uniform | KKT residual | volume / full (link 1 / 2) | status | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    print(f"| {sim.n_design} | {result.nit} | {result.nfev} | {result.fun:.3e} | {result.kkt:.2e} | {used} "
          f"| {result.status.name} | {elapsed:.1f} |")
    print()
    print("| h (s) | d uniform (m²) | d optimized (m²) | ratio |")
    print("|---|---|---|---|")
    for h in (0.02, 0.01, 0.005, 0.0025):
        d = [sim.run_with_sensitivities(x, "tip_deflection", h=h).values[0] for x in (x0, result.x)]
        print(f"| {h} | {d[0]:.4e} | {d[1]:.4e} | {d[0] / d[1]:.0f} |")


def stress_limited(iterations: int = 60) -> None:
    """The arm's tip deflection at 40 % of its volume, without and with a limit on the peak
    von Mises stress over the motion (``stress``, ``x^0.5`` relaxed, normalized to its
    peak) equal to the uniform design's; each design's peak and tip deflection."""
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm())
    x0 = np.full(sim.n_design, 0.4)
    limit = sim.run_with_sensitivities(x0, "stress").peaks["stress"]
    print(f"uniform design x = 0.4: peak stress {limit:.4g} Pa")
    print("| limit | iterations | d / uniform | KKT residual | peak / limit | volume / budget | status | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for limits in ([], [("stress", limit)]):
        problem = SpatialProblem(sim, "tip_deflection", limits, volume=0.4)
        start = time.perf_counter()
        result = flextop.optimize(problem, x0, method="mma", max_iter=iterations, kkt_tol=1e-4)
        elapsed = time.perf_counter() - start
        peak = sim.run_with_sensitivities(result.x, "stress").peaks["stress"]
        print(f"| {'peak stress' if limits else 'none'} | {result.nit} | {result.fun:.4f} | {result.kkt:.2e} "
              f"| {peak / limit:.3f} | {sim.volume(result.x) / (0.4 * sim.volume(1.0)):.4f} | {result.status.name} "
              f"| {elapsed:.1f} |")


def sizing(iterations: int = 60, rtol: float | None = None) -> None:
    """The arm's aluminium tubes sized (``flextop.problems.SizingProblem``: the section's
    outer and inner diameters as the design, every bar at full density) for its payload's
    tip deflection at the start's mass, by MMA from the scene's 12/9 mm tubes, on the scene's
    grid or held to ``rtol``; the sized design evaluated as the optimizer saw it (h = 10 ms)
    and on steps of 5 and 2.5 ms."""
    scene = flextop.scenes.spatial_robot_arm()
    problem = SizingProblem(scene, "tip_deflection", [("mass", flextop.SpatialSimulation(scene).mass())],
                            sizes={"alu.outer": (0.006, 0.04), "alu.inner": (0.003, 0.038)}, rtol=rtol)
    start = time.perf_counter()
    result = flextop.optimize(problem, problem.z0, method="mma", max_iter=iterations, kkt_tol=1e-4)
    elapsed = time.perf_counter() - start
    print("| sizes (outer / inner, mm) | iterations | evaluations | d / start | KKT residual | mass / bound | status | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    mass = problem.physical(problem.evaluate(result.x))[1][0] / problem.bounds[0]
    print(f"| {1e3 * problem.z0[0]:.1f} / {1e3 * problem.z0[1]:.1f} → {1e3 * result.x[0]:.2f} / {1e3 * result.x[1]:.2f} "
          f"| {result.nit} | {result.nfev} | {result.fun / problem.reference:.4f} | {result.kkt:.2e} | {mass:.6f} | {result.status.name} "
          f"| {elapsed:.1f} |")
    print(f"\nsized: outer {result.x[0]:.6g} m, inner {result.x[1]:.6g} m"
          + ("" if rtol is None else f", held to rtol {rtol:g}: the design returned measured on {problem.held}") + "\n")
    on_finer_steps(problem, result.x, "tip_deflection", (0.01, 0.005, 0.0025), "| h (s) | d start (m²) | d sized (m²) | ratio |")


def on_finer_steps(problem: SizingProblem, design: np.ndarray, response: str, steps: tuple[float, ...], header: str) -> None:
    """A table of ``response`` at the start and at ``design`` on each of ``steps``, and their
    ratio."""
    print(header)
    print("|---|---|---|---|")
    for h in steps:
        f = [flextop.SpatialSimulation(problem.spec_at(z)).run_with_sensitivities(None, response, h=h).values[0]
             for z in (problem.z0, design)]
        print(f"| {h} | {f[0]:.5e} | {f[1]:.5e} | {f[1] / f[0]:.4f} |")


def places(iterations: int = 100) -> None:
    """The spatial slider-crank's drive effort ``∫τ² dt`` over 0.3 s (its crank turned by
    2 rad on a trapezoidal law) with the pin's place along x and y and the wrist's along z
    as the design (``SizingProblem(..., places=...)``), by MMA from the scene's places; the
    design evaluated as the optimizer saw it (h = 4 ms) and on steps of 2 and 1 ms; the cost
    of a run with the three places' adjoint gradients against a plain run."""
    scene = flextop.scenes.spatial_slider_crank(turn=2.0, t_end=0.3, h=0.004)
    bounds = {"pin.x": (0.1, 0.2), "pin.y": (-0.05, 0.05), "wrist.z": (-0.05, 0.05)}
    problem = SizingProblem(scene, "torque_squared:crank", places=bounds)
    start = time.perf_counter()
    result = flextop.optimize(problem, problem.z0, method="mma", max_iter=iterations, kkt_tol=1e-5)
    elapsed = time.perf_counter() - start
    print("| places (m) | iterations | evaluations | effort / start | KKT residual | status | time (s) |")
    print("|---|---|---|---|---|---|---|")
    moved = ", ".join(f"{name} {a:.3f} → {b:.4f}" for name, a, b in zip(bounds, problem.z0, result.x))
    print(f"| {moved} | {result.nit} | {result.nfev} | {result.fun / problem.reference:.4f} | {result.kkt:.2e} "
          f"| {result.status.name} | {elapsed:.1f} |")
    print()
    on_finer_steps(problem, result.x, "torque_squared:crank", (0.004, 0.002, 0.001),
                   "| h (s) | effort, start (N² m² s) | effort, placed | ratio |")
    sim = flextop.SpatialSimulation(scene)
    names = [f"position_{name[-1]}:{name.split('.')[0]}" for name in bounds]
    plain = seconds(lambda: sim.run(None))
    adjoint = seconds(lambda: sim.run_with_sensitivities(None, "torque_squared:crank", names, method="adjoint"))
    print(f"\nA run: {1e3 * plain:.1f} ms; with the three places' adjoint gradients: {1e3 * adjoint:.1f} ms "
          f"({adjoint / plain:.2f} runs).")


def arm_table(reference: str) -> tuple[flextop.SpatialSimulation, np.ndarray]:
    """The spatial robot arm and its uniform design x = 0.4, the optimizations' table's header
    printed (``d / REFERENCE's``)."""
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm())
    print(f"| optimized | iterations | evaluations | measured | grid at the end | d / {reference} (as the optimizer saw it) "
          "| KKT residual | volume / budget | status | time (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    return sim, np.full(sim.n_design, 0.4)


def arm_row(sim: flextop.SpatialSimulation, problem: SpatialProblem, name: str, result: flextop.OptimizeResult,
            measurements: int, elapsed: float) -> None:
    """The optimizations' table's row of ``result``."""
    print(f"| {name} | {result.nit} | {result.nfev} | {measurements} | {problem.held or 'the scene’s'} "
          f"| {result.fun:.4f} | {result.kkt:.2e} | {sim.volume(result.x) / (0.4 * sim.volume(1.0)):.4f} "
          f"| {result.status.name} | {elapsed:.1f} |", flush=True)


def counted(problem: SpatialProblem, x0: np.ndarray, method: Any, iterations: int,
            name: str) -> tuple[flextop.OptimizeResult, list[bool], float]:
    """``problem`` optimized from ``x0`` (``kkt_tol`` 1e-4), each iteration on stderr (so that a
    run stopped before its end says how far it got): the result, the measurements it made
    and its seconds."""
    measurements: list[bool] = []
    measure = problem._run
    problem._run = lambda x, m: (measurements.append(m) if m else None, measure(x, m))[1]  # type: ignore[method-assign]
    start = time.perf_counter()

    def progress(record) -> None:
        print(f"{name}: iteration {record.iteration}, {record.evaluations} evaluations in it, f0 {record.f0:.4f}, "
              f"KKT {record.kkt:.2e}, {len(measurements)} measured, {time.perf_counter() - start:.0f} s",
              file=sys.stderr, flush=True)

    result = flextop.optimize(problem, x0, method=method, max_iter=iterations, kkt_tol=1e-4, callback=progress)
    return result, measurements, time.perf_counter() - start


def held_to_tolerance(iterations: int = 100, rtol: float = 1e-2, plain: bool = False, save: str | None = None) -> None:
    """The arm's tip deflection at 40 % of its volume by MMA from the uniform design, on the
    scene's grid (10 ms) and held to ``rtol`` (the grid measured where an accepted design
    moved by more than 0.1, held between, the returned design measured); each optimized design
    and the start measured to ``rtol`` and to rtol 1e-3. ``plain``: by ``MMA(safeguard=False)``;
    ``save``: a directory each optimized design is written to."""
    sim, x0 = arm_table("uniform")
    designs = {"uniform 0.4": x0}
    for tol in (None, rtol):
        problem = SpatialProblem(sim, "tip_deflection", volume=0.4, rtol=tol)
        method = MMA(safeguard=False) if plain else "mma"
        result, measurements, elapsed = counted(problem, x0, method, iterations,
                                                "scene's grid" if tol is None else f"rtol {tol:g}")
        name = "on the scene's grid" if tol is None else f"held to rtol {tol:g}"
        designs[name] = result.x
        if save is not None:
            file = name.replace(" ", "_").replace("'", "")
            np.save(Path(save) / f"{file}.npy", result.x)
        arm_row(sim, problem, name, result, len(measurements), elapsed)
    print()
    print("| design | d, scene's grid (m²) | d to rtol 1e-2 (m²) | estimated error | grid | d to rtol 1e-3 (m²) | estimated error | grid |")
    print("|---|---|---|---|---|---|---|---|")
    for name, x in designs.items():
        plain = sim.run_with_sensitivities(x, "tip_deflection").values[0]
        cells = " | ".join(measured(sim, x, r) for r in (1e-2, 1e-3))
        print(f"| {name} | {plain:.4e} | {cells} |", flush=True)


def polished(iterations: int = 100, rtol: float = 1e-2, held_iterations: int = 60) -> None:
    """The arm's tip deflection at 40 % of its volume by MMA from the uniform design on the
    scene's grid, then from that design held to ``rtol`` (continuation: the cheap grid finds
    the layout, the tolerance corrects what that grid got wrong); both designs and the start
    measured to ``rtol``. Progress on stderr."""
    sim, x0 = arm_table("start's")
    designs = {"uniform 0.4": x0}
    start_design = x0
    for tol, name, most in ((None, "on the scene's grid, from x = 0.4", iterations),
                            (rtol, f"held to rtol {rtol:g}, from the scene's grid's", held_iterations)):
        problem = SpatialProblem(sim, "tip_deflection", volume=0.4, rtol=tol)
        result, measurements, elapsed = counted(problem, start_design, "mma", most, name)
        designs[name] = start_design = result.x
        arm_row(sim, problem, name, result, len(measurements), elapsed)
    print()
    print(f"| design | d, scene's grid (m²) | d to rtol {rtol:g} (m²) | estimated error | grid |")
    print("|---|---|---|---|---|")
    for name, x in designs.items():
        plain = sim.run_with_sensitivities(x, "tip_deflection").values[0]
        print(f"| {name} | {plain:.4e} | {measured(sim, x, rtol)} |", flush=True)


def measured(sim: flextop.SpatialSimulation, x: np.ndarray, rtol: float) -> str:
    """The final table's three cells of design ``x`` run to ``rtol`` with its gradient: d, the
    estimated error and the grid, or the ``ToleranceError`` that stopped it."""
    try:
        r = sim.run_with_sensitivities(x, "tip_deflection", rtol=rtol)
    except flextop.ToleranceError as error:
        return f"ToleranceError: {error} | — | —"
    return f"{r.values[0]:.4e} | {r.errors['tip_deflection']:.1e} | {r.discretization}"


def hundred_iterations(nx: int = 5, connectivity: str = "diagonals", built: bool = False) -> None:
    """The floor of the design issue: 100 MMA iterations of the arm's tip deflection at 40 %
    of its volume from the uniform design, on the scene's grid, by MMA with its safeguard
    (the default) and by plain MMA (``MMA(safeguard=False)``); the arm's links of ``nx × 2 ×
    2`` nodes joined by ``connectivity`` (the scene's 188 bars, or ``--nx 6 --full``: 472). With
    ``built``, the uniform start and both designs then run to rtol 1e-2 (as built)."""
    scene = flextop.scenes.spatial_robot_arm(nx=nx, connectivity=connectivity)
    designs = {}
    print("| bars | method | iterations | evaluations | d / uniform | KKT residual | status | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for name, method in (("MMA with its safeguard", "mma"), ("plain MMA", MMA(safeguard=False))):
        sim = flextop.SpatialSimulation(scene)  # each optimization on a simulation of its own
        problem = SpatialProblem(sim, "tip_deflection", volume=0.4)
        start = time.perf_counter()
        result = flextop.optimize(problem, np.full(sim.n_design, 0.4), method=method, max_iter=100, kkt_tol=1e-4)
        elapsed = time.perf_counter() - start
        print(f"| {sim.n_design} | {name} | {result.nit} | {result.nfev} | {result.fun:.4f} | {result.kkt:.2e} "
              f"| {result.status.name} | {elapsed:.1f} |", flush=True)
        designs[name] = result.x
    if built:
        sim = flextop.SpatialSimulation(scene)
        print("\n| design | d, scene's grid (m²) | d to rtol 1e-2 (m²) | estimated error | grid |\n|---|---|---|---|---|")
        for name, x in {"uniform 0.4": np.full(sim.n_design, 0.4), **designs}.items():
            on_grid = sim.run_with_sensitivities(x, "tip_deflection").values[0]
            print(f"| {name} | {on_grid:.4e} | {measured(sim, x, 1e-2)} |", flush=True)


if __name__ == "__main__":
    if "--hundred" in sys.argv[1:]:
        hundred_iterations(bench_args.value("--nx", 5, int), "full" if "--full" in sys.argv[1:] else "diagonals",
                           built="--built" in sys.argv[1:])
        sys.exit()
    if "--polish" in sys.argv[1:]:
        polished()
        sys.exit()
    if "--tolerance" in sys.argv[1:]:
        held_to_tolerance(bench_args.value("--iterations", 100, int), plain="--plain" in sys.argv[1:],
                          save=bench_args.value("--save", None, str))
        sys.exit()
    if "--stress" in sys.argv[1:]:
        stress_limited()
        sys.exit()
    if "--sizing" in sys.argv[1:]:
        sizing(rtol=0.01 if "--held" in sys.argv[1:] else None)
        sys.exit()
    if "--places" in sys.argv[1:]:
        places()
        sys.exit()
    costs()
    if "--costs" in sys.argv[1:]:
        sys.exit()
    print()
    print("| objective | bars | iterations | objective / uniform | KKT residual | volume / budget | status | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    optimization("strain_energy")
    optimization("tip_deflection")
    print()
    paper_arm()
