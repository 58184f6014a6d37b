"""Spatial runs to a tolerance across designs (``flextop.discretization.spatial``): the
spatial robot arm's tip deflection (paper Eq. 40) and its gradient to every bar's density at
rtol 1e-2, on uniform (1, 0.7, 0.4, 0.2), random (in [0.3, 1] and [0.05, 1]) and the designs MMA
passes on its way (iterations 5, 10, 20 and 40 of the tip deflection at 40 % of the volume, on
the scene's grid): ten designs, against a reference on
four times the elements of every beam with the time error removed by Richardson's
extrapolation from 1600 and 3200 steps. Printed per design: the scene's grid (h = 10 ms) and
its true error; the grid the tolerance chose, its cost over the scene's run, its estimated
and true errors (value, and gradient in the 2-norm), the estimate over the true error.

    python benches/spatial_tolerance.py [--rtol R] [--added | --design NAME] [--refine uniform,bars,shares]
                                        [--time-estimate doubling,adjoint]
    python benches/spatial_tolerance.py --adjoint-time

``--added``: only the three designs added to the first seven (MMA's 40th iterate, uniform 0.2,
random in [0.05, 1]); ``--design NAME`` (repeated for more): only those. ``--refine``: how the runs to the
tolerance refine the beams, one row per way given (``uniform`` by default; ``bars`` grades them
by their own frequencies; ``shares`` then refines those whose measured shares carry a value's
space error), each against the same reference. ``--time-estimate``: how a candidate's time
error is estimated, one row per way given for each refinement (``adjoint``, the default: by
its own adjoint sweep where that agrees with its half steps; ``doubling``: step doubling
alone). A design whose run on the scene's grid fails is still run to the tolerance (the
contract's finer grids may carry it).

``--adjoint-time``, instead: the time error the adjoint estimates
(``SpatialSimulation.time_errors``) against the true error of the same grid (the limit in the
step from 32 and 64 times the scene's steps, extrapolated), and whether it agrees with the
half-step run's ``(f(2h) − f(h))/3``: the heavy top's final position (with the Magnus term of
the rotation's increment and without, the second by the difference it makes) and the spatial
arm's tip deflection, strain energy and kinetic energy at uniform 0.5 and a random design,
at 1 to 16 times the scene's steps. Writes benches/results/spatial_adjoint_time.md.
"""

import sys
import time
from dataclasses import replace

import numpy as np

import flextop
from flextop.discretization.spatial import refined_spec
from flextop.problems import SpatialProblem

import bench_args

RESPONSE = "tip_deflection"


def timed(run):
    start = time.perf_counter()
    out = run()
    return out, time.perf_counter() - start


def iterates(sim, wanted=(5, 10, 20, 40)) -> dict[str, np.ndarray]:
    """The designs MMA passes at ``wanted`` iterations minimizing the tip deflection at 40 % of
    the volume from the uniform design, on the scene's grid."""
    found: dict[str, np.ndarray] = {}

    def keep(record) -> bool:
        if record.iteration in wanted:
            found[f"MMA iterate {record.iteration}"] = np.array(record.state.x)
        return record.iteration >= max(wanted)

    problem = SpatialProblem(sim, RESPONSE, volume=0.4)
    flextop.optimize(problem, np.full(sim.n_design, 0.4), method="mma", max_iter=max(wanted), kkt_tol=1e-6, callback=keep)
    return found


def reference(spec: dict, x: np.ndarray):
    """d and its gradient on 4× the elements of every beam, Richardson from 1600 and 3200
    steps; and the size of that correction (the reference's own time error, roughly)."""
    fine = flextop.SpatialSimulation(refined_spec(spec, 4))
    at = [fine.run_with_sensitivities(x, RESPONSE, h=1.0 / n) for n in (3200, 1600)]
    extrapolated = replace(at[0], **{key: (4 * getattr(at[0], key) - getattr(at[1], key)) / 3 for key in ("values", "dfdx")})
    return extrapolated, abs(extrapolated.values[0] - at[0].values[0]) / abs(extrapolated.values[0])


def main(rtol: float) -> None:
    scene = flextop.scenes.spatial_robot_arm()
    sim = flextop.SpatialSimulation(scene)
    rng = np.random.default_rng(0)
    designs = {"uniform 1": np.ones(sim.n_design), "uniform 0.7": np.full(sim.n_design, 0.7),
               "uniform 0.4": np.full(sim.n_design, 0.4), "random [0.3, 1]": rng.uniform(0.3, 1.0, sim.n_design),
               **iterates(sim), "uniform 0.2": np.full(sim.n_design, 0.2),
               "random [0.05, 1]": rng.uniform(0.05, 1.0, sim.n_design)}
    if "--added" in sys.argv:  # the designs added to the first seven
        designs = {k: v for k, v in designs.items() if k in ("MMA iterate 40", "uniform 0.2", "random [0.05, 1]")}
    if "--design" in sys.argv:  # each given after its own flag
        wanted = {sys.argv[k + 1] for k, arg in enumerate(sys.argv) if arg == "--design"}
        designs = {k: v for k, v in designs.items() if k in wanted}
    ways = [(refine, estimate) for refine in bench_args.value("--refine", "uniform", str).split(",")
            for estimate in bench_args.value("--time-estimate", "adjoint", str).split(",")]
    print(f"rtol = {rtol:g}, the spatial robot arm ({sim.n_design} bars), {RESPONSE}\n")
    print("| design | refine, time estimate | d, scene's grid (m²) | its true error | grid chosen | cost / scene's run | d (m²) | estimated error "
          "| true error | estimate / true | gradient: estimated | true | estimate / true | reference's Richardson correction |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, x in designs.items():
        # The scene's grid may fail where the contract's finer grids carry the motion.
        failed = None
        try:
            plain, t_plain = timed(lambda: sim.run_with_sensitivities(x, RESPONSE))
        except flextop.SimulationError as error:
            plain, t_plain, failed = None, None, f"fails: {error}"
        ref = None
        for way in ways:
            ref = row(scene, sim, name, x, way, rtol, plain, t_plain, failed, ref)


def row(scene, sim, name, x, way, rtol, plain, t_plain, failed, ref):
    """One design's run to ``rtol`` refining its beams and estimating its time error as ``way``
    says (``refine``, ``time_estimate``), printed against the reference (made here where
    ``ref`` is ``None``); returns the reference."""
    refine, estimate = way
    way = f"{refine}, {estimate}"
    try:
        run, t_run = timed(lambda: flextop.SpatialSimulation(scene, rtol=rtol, refine=refine).run_with_sensitivities(
            x, RESPONSE, time_estimate=estimate))
    except (flextop.ToleranceError, flextop.SimulationError) as error:
        print(f"| {name} | {way} | {failed if plain is None else f'{plain.values[0]:.4e}'} | — | {type(error).__name__}: {error} |")
        return ref
    if ref is None:
        ref = reference(sim.spec, x)
    (extrapolated, correction) = ref
    d_ref, g_ref = extrapolated.values[0], extrapolated.dfdx[0]
    true = abs(run.values[0] - d_ref) / abs(d_ref)
    grad = np.linalg.norm(run.dfdx[0] - g_ref) / np.linalg.norm(g_ref)
    est, gest = run.errors[RESPONSE], run.gradient_errors[RESPONSE]
    scene_d = f"{failed} | —" if plain is None else f"{plain.values[0]:.4e} | {abs(plain.values[0] - d_ref) / abs(d_ref):.2e}"
    cost = "—" if t_plain is None else f"{t_run / t_plain:.1f}"
    print(f"| {name} | {way} | {scene_d} | {run.discretization} "
          f"| {cost} | {run.values[0]:.4e} | {est:.2e} | {true:.2e} | {est / true:.2f} | {gest:.2e} "
          f"| {grad:.2e} | {gest / grad:.2f} | {correction:.1e} |", flush=True)
    return ref


def adjoint_time() -> None:
    """The ``--adjoint-time`` table (module docs)."""
    from pathlib import Path
    lines = ["| scene, design | response | steps | true error (relative) | adjoint / true | adjoint / ((f(2h) − f(h))/3) |",
             "|---|---|---|---|---|---|"]
    cases = [("heavy top", flextop.SpatialSimulation(flextop.scenes.heavy_top()), {"": None},
              ["x:top", "y:top", "z:top", "kinetic_energy"])]
    arm = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm())
    designs = {"uniform 0.5": np.full(arm.n_design, 0.5),
               "random [0.3, 1]": np.random.default_rng(4).uniform(0.3, 1.0, arm.n_design)}
    cases.append(("spatial arm", arm, designs, ["tip_deflection", "strain_energy", "kinetic_energy"]))
    for scene, sim, xs, names in cases:
        base = round(sim.spec["simulation"]["t_end"] / sim.spec["simulation"]["h"])
        for label, x in xs.items():
            fine, coarse = (sim.time_errors(x, names, steps=k * base) for k in (64, 32))
            limit = {n: (4 * fine[n][0] - coarse[n][0]) / 3 for n in names}
            runs = {k: sim.time_errors(x, names, steps=k * base) for k in (1, 2, 4, 8, 16)}
            for n in names:
                for k in (2, 4, 8, 16):
                    value, estimate = runs[k][n]
                    true = value - limit[n]
                    half = (runs[k // 2][n][0] - value) / 3
                    lines.append(f"| {scene}{', ' + label if label else ''} | {n} | {k * base} | "
                                 f"{true / abs(limit[n]):+.2e} | {estimate / true:.2f} | {estimate / half:.2f} |")
                    print(lines[-1], flush=True)
    text = ("Produced by `python benches/spatial_tolerance.py --adjoint-time`: the time error estimated by the adjoint "
            "against the true error of the same grid (its limit in the step from 32 and 64 times the scene's steps), "
            "and against the half-step run's (f(2h) − f(h))/3.\n\n" + "\n".join(lines) + "\n")
    (Path(__file__).resolve().parent / "results" / "spatial_adjoint_time.md").write_text(text, encoding="utf-8")


if __name__ == "__main__":
    if "--adjoint-time" in sys.argv:
        adjoint_time()
        sys.exit()
    main(bench_args.value("--rtol", 1e-2, float))
