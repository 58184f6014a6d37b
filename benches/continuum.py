"""Continuum links in the arm's motion: cost against mesh size, and the issue's floor.

The robot arm of the paper with each link a plane-stress member (1.0 m × 0.1 m, 5 mm of
aluminium, :func:`flextop.scenes.continuum_robot_arm`), driven through rigid rings over
its 1.3 s motion in 100 steps, every cell at density 0.5:

1. one forward run, and one run with the adjoint gradients of the tip deflection (Eq. 40)
   and the strain energy, at 20 × 6 to 120 × 40 cells per link: seconds, microseconds per
   cell-step, Newton iterations per step, unknowns (three per node: a member node's rotation
   row, which no cell reads, is solved outside the factors);
2. at 60 × 20, full
   and modified Newton side by side, on four designs (uniform 0.5 and 1, random in
   [0.01, 1], and a random mix of void 0.01 and solid cells), a failed run reported as such;
3. with ``--optimize NX NY [--plain] [--radius R]``: the tip deflection (Eq. 40) minimized
   under a volume of 0.5 per link, the density filter at R m (default 0.025), by MMA (with its safeguard, or plain) for
   200 iterations from the uniform 0.5 at NX × NY cells per link (the issue's floor: 60 × 20
   in at most 5 minutes); the objective before and after, the time, the design
   (``docs/continuum_arm_NXxNY[_plain].png``), and the optimized design's objective on
   meshes refined 2 × 2 and 4 × 4 with the step halved and quartered (the filter radius is
   fixed in metres, so the design is a field that the finer meshes resolve).

4. with ``--beside``: the continuum designs beside the frame designs of the same machines:
   the slider-crank of Song & Haug with a continuum rod (0.30 m × 20 mm, 5 mm of steel,
   60 × 8 cells, :func:`flextop.scenes.continuum_slider_crank`) and with its frame rod
   (four bars of a 6 mm circle, :func:`flextop.scenes.slider_crank`), the rod's mid-span
   deflection (Eq. 40) minimized under V ≤ 0.5 from x = 0.5 by plain MMA for 100
   iterations, the continuum rod's density filter at 7.5 mm (1.5 cells), its design then
   evaluated with the cells split 2 × 2 and the step halved; the frame arm's tip deflection
   under V ≤ 0.4 per link from x = 0.4, 40 iterations on the scene's grid; and the
   continuum arm's row as ``--optimize 60 20 --plain`` wrote it;
5. with ``--floor [--against PYTHON]``: the issue's floor, two 60 × 20 links run with the
   adjoint gradient of the tip deflection in at most 1.5 s: the scene's runs (modified
   Newton) on the uniform 0.5, a random design in [0.01, 1] and the uniform 1, the best of
   three each, five rounds in fresh processes, alternating with the interpreter ``PYTHON``
   of another build (e.g. a virtual environment with the previous commit installed) where
   given: side by side on the same machine at the same time.

6. with ``--round-off``: designs whose Newton residual stalls at its round-off floor
   above the tolerance (each link solid below its middle and void, x = 0.01, above) at
   40 × 12 (h/2), 60 × 20 (h) and 80 × 24 (h/4) cells per link, under modified and full
   Newton: the outcome, the iterations per step and d; run it with another build's
   interpreter to compare (``ROUND_OFF_ULPS`` in ``src/solver/newton.rs``).

    python benches/continuum.py                   # → benches/results/continuum.md (about 4 min)
    python benches/continuum.py --optimize 20 6   # → benches/results/continuum_optimization_20x6.md
    python benches/continuum.py --optimize 60 20 --plain
    python benches/continuum.py --beside          # → benches/results/continuum_beside_frames.md (about 5 min)
    python benches/continuum.py --floor --against /path/to/other/venv/bin/python   # about 3 min
    python benches/continuum.py --round-off       # about 1 min
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import flextop
from flextop.optimizers.mma import MMA
from flextop.problems import DensityFilter, TopologyProblem, volume_constraints
from flextop.scenes import continuum_robot_arm, continuum_slider_crank, robot_arm, slider_crank

import bench_args

ROOT = Path(__file__).resolve().parents[1]
RESPONSES = ["tip_deflection", "strain_energy"]


def simulation(nx: int, ny: int) -> flextop.Simulation:
    return flextop.Simulation(continuum_robot_arm(nx=nx, ny=ny))


def row(nx: int, ny: int, newton: str = "full") -> str:
    sim = simulation(nx, ny)
    x = np.full(sim.n_design, 0.5)
    clock = time.perf_counter()
    run = sim.run(x, newton=newton)
    forward = time.perf_counter() - clock
    clock = time.perf_counter()
    f, _ = sim.run_with_sensitivities(x, RESPONSES, newton=newton)
    adjoint = time.perf_counter() - clock
    steps, cells = len(run.time) - 1, sim.n_design
    return (f"| {nx} × {ny} | {cells} | {sim.model.n_dofs + sim.model.n_constraints} | {newton} | {forward:.2f} | "
            f"{adjoint:.2f} | {1e6 * forward / (cells * steps):.1f} | {run.newton['mean']:.2f} | {f[0]:.4e} |")


def optimization(nx: int, ny: int, plain: bool, radius: float = 0.025, iterations: int = 200) -> None:
    import flextop.plots as plots

    sim = simulation(nx, ny)
    problem = TopologyProblem(sim, "tip_deflection", volume_constraints(sim, 0.5), filter=DensityFilter(sim, radius))
    method = MMA(safeguard=not plain)
    clock = time.perf_counter()
    result = flextop.optimize(problem, np.full(sim.n_design, 0.5), method=method, max_iter=iterations,
                              callback=lambda r: print(r.iteration, r.f0, r.g, flush=True) and None)
    seconds = time.perf_counter() - clock
    physical = problem.filter.physical(result.x)
    start = result.history[0].f0 * problem.objective_scale
    label = "plain MMA" if plain else "MMA with its safeguard"
    tag = f"{nx}x{ny}{'_plain' if plain else ''}{'' if radius == 0.025 else f'_r{radius * 1e3:g}mm'}"
    plots.plot_design(sim, physical, title=f"tip deflection {result.fun:.3e} m² (uniform 0.5: {start:.3e})",
                      path=ROOT / "docs" / f"continuum_arm_{tag}.png")
    values = on_refined_meshes(sim, physical, nx, ny)
    refined = " | ".join(values + ["—"] * (2 - len(values)))
    flags = f"{' --plain' if plain else ''}{'' if radius == 0.025 else f' --radius {radius:g}'}"
    text = (f"Produced by `python benches/continuum.py --optimize {nx} {ny}{flags}`: the continuum "
            f"robot arm, {nx} × {ny} cells per link, tip deflection under V ≤ 0.5 per link, density filter {radius * 1e3:g} mm, {label} "
            f"from x = 0.5; the optimized (physical) design then evaluated with every cell split into 2 × 2 and 4 × 4 "
            f"and the step halved and quartered.\n\n"
            f"| method | iterations | evaluations | seconds | d at x = 0.5 (m²) | d optimized (m²) | ratio | volume "
            f"constraints | status | d, cells 2 × 2, h/2 | d, cells 4 × 4, h/4 |\n|---|---|---|---|---|---|---|---|---|---|---|\n"
            f"| {label} | {result.nit} | {result.nfev} | {seconds:.0f} | {start:.4e} | {result.fun:.4e} | "
            f"{start / result.fun:.2f} | {np.array2string(result.constr, precision=4)} | {result.status.name} | {refined} |\n")
    name = f"continuum_optimization_{tag}.md"
    (ROOT / "benches" / "results" / name).write_text(text)
    print(text)


def on_refined_meshes(sim: flextop.Simulation, physical: np.ndarray, nx: int, ny: int) -> list[str]:
    """The tip deflection of the physical design ``physical`` on ``sim``'s arm with each cell
    split into f × f (each child at its parent's density, a passive parent's children solid)
    and the step divided by f, for f = 2 and 4 (2 alone above 20 × 6 cells per link: 240 ×
    80 cells over 400 steps would take most of an hour), as the table prints it: where the
    scene's modified Newton fails, full Newton's, and where that fails too, its error."""
    density = dict(zip(sim.variable_names, physical))
    values = []
    for f in (2, 4) if nx * ny <= 20 * 6 else (2,):
        fine = flextop.Simulation(continuum_robot_arm(nx=f * nx, ny=f * ny, h=0.013 / f))
        x = np.empty(fine.n_design)
        for k, name in enumerate(fine.variable_names):
            link, cell = name.split("/cell[")
            i, j = (int(v) // f for v in cell.rstrip("]").split(","))
            x[k] = density.get(f"{link}/cell[{i},{j}]", 1.0)
        try:
            values.append(f"{fine.run_with_sensitivities(x, ['tip_deflection'])[0][0]:.4e}")
        except flextop.SimulationError:
            try:  # the scene's modified Newton can stall near its tolerance on a fine mesh of void and solid
                values.append(f"{fine.run_with_sensitivities(x, ['tip_deflection'], newton='full')[0][0]:.4e} (full Newton)")
            except flextop.SimulationError as error:
                values.append(f"fails: {error}")
        print(f"cells {f} × {f}, h/{f}: d = {values[-1]}", flush=True)
    return values


ROD = {"nx": 60, "ny": 8, "height": 0.02}
"""The continuum rod of ``--beside``: 0.30 m × 20 mm in 60 × 8 cells (5 mm by 2.5 mm)."""


def optimized(sim: flextop.Simulation, fraction: float, x0: float, iterations: int,
              radius: float | None = None) -> tuple[str, np.ndarray, TopologyProblem]:
    """``sim``'s tip deflection minimized under V ≤ ``fraction`` per component from the
    uniform ``x0`` by plain MMA: the row's cells (objective before and after, their ratio,
    iterations, evaluations, seconds, status), the physical design and the problem."""
    cells = None if radius is None else DensityFilter(sim, radius)
    problem = TopologyProblem(sim, "tip_deflection", volume_constraints(sim, fraction), filter=cells)
    clock = time.perf_counter()
    result = flextop.optimize(problem, np.full(sim.n_design, x0), method=MMA(safeguard=False), max_iter=iterations)
    seconds = time.perf_counter() - clock
    start = result.history[0].f0 * problem.objective_scale
    physical = result.x if cells is None else cells.physical(result.x)
    row = (f"{start:.4e} | {result.fun:.4e} | {start / result.fun:.2f} | {result.nit} | {result.nfev} | "
           f"{seconds:.0f} | {result.status.name}")
    print(row, flush=True)
    return row, physical, problem


def beside_frames() -> None:
    """The table of ``--beside`` (module docstring, 4.)."""
    import flextop.plots as plots

    header = ("| machine | links | design variables | d at the start (m²) | d optimized (m²) | ratio | iterations | "
              "evaluations | seconds | status | d optimized, refined (m²) |\n|---|---|---|---|---|---|---|---|---|---|---|")
    lines = [header]
    rod = flextop.Simulation(continuum_slider_crank(**ROD))
    row, physical, _ = optimized(rod, 0.5, 0.5, 100, radius=0.0075)
    density = dict(zip(rod.variable_names, physical))
    fine = flextop.Simulation(continuum_slider_crank(nx=2 * ROD["nx"], ny=2 * ROD["ny"], height=ROD["height"], h=1.25e-4))
    split = [density.get(f"rod/cell[{int(c.split('[')[1].split(',')[0]) // 2},"
                         f"{int(c.split(',')[1].rstrip(']')) // 2}]", 1.0) for c in fine.variable_names]
    refined = fine.run_with_sensitivities(np.array(split), ["tip_deflection"])[0][0]
    plots.plot_design(rod, physical, title="slider-crank, continuum rod: mid-span deflection under V ≤ 0.5",
                      path=ROOT / "docs" / "continuum_slider_crank.png")
    lines.append(f"| slider-crank | continuum rod, 60 × 8 cells, filter 7.5 mm | {rod.n_design} | {row} | "
                 f"{refined:.4e} (cells 2 × 2, h/2) |")
    frame = flextop.Simulation(slider_crank())
    row, _, _ = optimized(frame, 0.5, 0.5, 100)
    lines.append(f"| slider-crank | frame rod, 4 bars of a 6 mm circle | {frame.n_design} | {row} | — |")
    arm = flextop.Simulation(robot_arm())
    row, _, _ = optimized(arm, 0.4, 0.4, 40)
    lines.append(f"| robot arm | frame links, 5 × 3 ground structures, 1 element per bar | {arm.n_design} | {row} | "
                 f"see the tolerance rows of BENCHMARKS.md |")
    stored = (ROOT / "benches" / "results" / "continuum_optimization_60x20_plain.md").read_text().splitlines()
    cells = [c.strip() for c in stored[-1].strip("|").split("|")]
    variables = simulation(60, 20).n_design
    lines.append(f"| robot arm | continuum links, 60 × 20 cells, filter 25 mm (`--optimize 60 20 --plain`) | {variables} | "
                 f"{cells[4]} | {cells[5]} | {cells[6]} | {cells[1]} | {cells[2]} | {cells[3]} | {cells[8]} | "
                 f"{cells[9]} (cells 2 × 2, h/2) |")
    text = ("Produced by `python benches/continuum.py --beside` (the continuum arm's row read from "
            "`continuum_optimization_60x20_plain.md`): each machine's tip or mid-span deflection (Eq. 40) minimized by "
            "plain MMA from a uniform design, the volume bound per link.\n\n" + "\n".join(lines) + "\n")
    (ROOT / "benches" / "results" / "continuum_beside_frames.md").write_text(text)
    print(text)


def designs() -> list[str]:
    sim = simulation(60, 20)
    rng = np.random.default_rng(0)
    family = {"uniform 0.5": np.full(sim.n_design, 0.5), "uniform 1": np.ones(sim.n_design),
              "random": rng.uniform(0.01, 1.0, sim.n_design),
              "void or solid": np.where(rng.random(sim.n_design) < 0.5, 0.01, 1.0)}
    lines = ["| design (60 × 20) | modified Newton, run + adjoint (s) | full Newton (s) | d (m²) |", "|---|---|---|---|"]
    for label, x in family.items():
        cells, values = [], []
        for newton in ("modified", "full"):
            clock = time.perf_counter()
            try:
                f, _ = sim.run_with_sensitivities(x, RESPONSES, newton=newton)
                cells.append(f"{time.perf_counter() - clock:.2f}")
                values.append(f"{f[0]:.6e}")
            except flextop.SimulationError as error:
                cells.append(f"fails: {error}")
        lines.append(f"| {label} | {cells[0]} | {cells[1]} | {' / '.join(dict.fromkeys(values)) or '—'} |")
        print(lines[-1], flush=True)
    return lines


FLOOR_DESIGNS = ["uniform 0.5", "random", "uniform 1"]
"""The designs of the floor's table, in order."""

FLOOR_RUN = """
import json, time
import numpy as np
import flextop
sim = flextop.Simulation(flextop.scenes.continuum_robot_arm(nx=60, ny=20))
designs = [np.full(sim.n_design, 0.5), np.random.default_rng(0).uniform(0.01, 1.0, sim.n_design), np.ones(sim.n_design)]
best = []
for x in designs:
    times = []
    for _ in range(3):
        clock = time.perf_counter()
        sim.run_with_sensitivities(x, "tip_deflection")
        times.append(time.perf_counter() - clock)
    best.append(min(times))
print(json.dumps(best))
"""
"""One round of the floor in a fresh process: the best of three runs with the adjoint per design."""


def floor(against: str | None, rounds: int = 5) -> None:
    """The floor's table: each design's run with its adjoint, the median over ``rounds`` of
    the best of three, this build and (``against``) another, rounds alternating."""
    builds = {"this build": sys.executable} | ({"other build": against} if against else {})
    times: dict[str, list[list[float]]] = {name: [] for name in builds}
    for _ in range(rounds):
        for name, python in builds.items():
            out = subprocess.run([python, "-c", FLOOR_RUN], capture_output=True, text=True, check=True).stdout
            times[name].append(json.loads(out.splitlines()[-1]))
    medians = {name: np.median(np.array(t), axis=0) for name, t in times.items()}
    header = " | ".join(f"{name} (s)" for name in builds) + (" | this / other |" if against else " |")
    print(f"| design (60 × 20) | {header}\n|---|{'---|' * (len(builds) + bool(against))}")
    for k, design in enumerate(FLOOR_DESIGNS):
        cells = " | ".join(f"{medians[name][k]:.2f}" for name in builds)
        ratio = f" | {medians['this build'][k] / medians['other build'][k]:.2f}" if against else ""
        print(f"| {design} | {cells}{ratio} |")


def round_off() -> None:
    """Modified and full Newton on designs whose residual stalls at its round-off floor:
    each link solid below its middle and void above, at three meshes and steps."""
    print("| cells per link | h (s) | Newton | outcome | iterations per step | d (m²) |\n|---|---|---|---|---|---|")
    for nx, ny, f in ((40, 12, 2), (60, 20, 1), (80, 24, 4)):
        sim = flextop.Simulation(continuum_robot_arm(nx=nx, ny=ny, h=0.013 / f))
        upper = np.array([int(name.split(",")[1].rstrip("]")) >= ny // 2 for name in sim.variable_names])
        for newton in ("modified", "full"):
            try:
                run = sim.run(np.where(upper, 0.01, 1.0), newton=newton)
                cells = f"runs | {run.newton['mean']:.2f} | {run.response('tip_deflection'):.10e}"
            except flextop.SimulationError as error:
                cells = f"{str(error).split(':')[0]}: {str(error).split(':')[1].split('(')[0].strip()} | — | —"
            print(f"| {nx} × {ny} | {0.013 / f:.5f} | {newton} | {cells} |", flush=True)


def main() -> None:
    if "--round-off" in sys.argv:
        round_off()
        return
    if "--floor" in sys.argv:
        floor(bench_args.value("--against", None, str))
        return
    if "--beside" in sys.argv:
        beside_frames()
        return
    if "--optimize" in sys.argv:
        nx, ny = bench_args.values("--optimize", 2, int) or (0, 0)
        radius = bench_args.value("--radius", 0.025, float)
        optimization(nx, ny, plain="--plain" in sys.argv, radius=radius)
        return
    lines = ["| cells per link | cells | unknowns | Newton | run (s) | run + adjoint (s) | µs per cell-step | "
             "iterations per step | d (m²) |", "|---|---|---|---|---|---|---|---|---|"]
    for nx, ny in ((20, 6), (40, 12), (60, 20), (120, 40)):
        lines.append(row(nx, ny))
        print(lines[-1], flush=True)
    lines.append(row(60, 20, "modified"))
    print(lines[-1], flush=True)
    out = ROOT / "benches" / "results" / "continuum.md"
    out.write_text("Produced by `python benches/continuum.py`: the continuum robot arm, 100 steps over 1.3 s, "
                   "x = 0.5.\n\n" + "\n".join(lines) + "\n\nAcross designs:\n\n" + "\n".join(designs()) + "\n")
    print(f"→ {out}")


if __name__ == "__main__":
    main()
