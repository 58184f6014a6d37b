"""The ``flextop`` command line.

``flextop demo``             the paper's robot arm at uniform density: tip error, d, a plot;
``flextop simulate SCENE``   run a scene file (TOML) and summarize it;
``flextop optimize SCENE``   topology optimization (see ``flextop optimize --help``).

A user error (a bad argument, scene, design, setting or checkpoint) prints one line and
exits with 2; a run that fails (Newton, a tolerance out of reach, an unwritable output, a
lost worker) with 1; an optimization that stops without converging (the iteration limit,
repeated evaluation failures, an infeasible design) with 3, after writing its results and
saying why; Ctrl-C with 130. ``flextop --debug ...`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np
from tqdm import tqdm

from . import __version__, responses, scenes
from .errors import CheckpointError, DesignError, ExecutionError, FlextopError, SceneFileError, SettingsError, SimulationError
from .discretization.accuracy import preset
from .discretization.refinement import t_end
from .discretization.spatial import grid_of as spatial_grid
from .execution import Workers, local_executor
from .optimizers import OptimizerState, optimize
from .optimizers.driver import CONVERGED
from .io import cad, checkpoint, export
from .problems.spatial import structures_of, volume_bounds
from .problems import (MIN_FREQUENCY, DensityFilter, ScenarioProblem, SizingProblem, SpatialProblem, TopologyProblem, relation,
                       scenarios, volume_constraints)
from .scenes import Scene, read_toml
from .results import Results
from .simulation import Simulation
from .spatial import SpatialSimulation
from .scenes.spatial import SpatialScene, is_spatial


NOT_CONVERGED = 3
"""Exit code of an optimization that stopped without converging to a feasible design."""

CONTINUUM = ("continuum_robot_arm", "continuum_slider_crank", "half_mbb", "continuum_cantilever")
"""The built-in scenes of continuum members, whose ``nx × ny`` cells ``--cells`` sets."""

CELLS_HELP = f"cells along and across each continuum member of a built-in scene ({', '.join(CONTINUUM)}), e.g. 20x6"
ANALYSIS_HELP = ("static scenes: linear (K0 u = f about the reference, the load at once: the 88-line code's analysis) or "
                 "nonlinear (the default, or the scene's [simulation] analysis)")


def _design(sim: Simulation | SpatialSimulation, x: float | None, design: Path | None) -> np.ndarray | None:
    if design is not None:
        try:
            return np.load(design) if design.suffix == ".npy" else np.loadtxt(design, ndmin=1)
        except (OSError, ValueError, EOFError) as error:
            raise DesignError(f"{design}: cannot read a design vector ({error})") from None
    return None if x is None else np.full(sim.n_design, x)


def _folder(path: Path) -> Path:
    """The output folder ``path``, made if needed (a file of that name is a user error)."""
    if path.exists() and not path.is_dir():
        raise SettingsError(f"--out {path}: a file of that name exists; give a folder")
    path.mkdir(parents=True, exist_ok=True)
    return path


def _summarize(sim: Simulation, res, elapsed: float) -> None:
    if res.discretization is not None:
        errors = ", ".join(f"{name} {error:.2%}" for name, error in res.errors.items())
        print(f"to rtol = {sim.rtol:g}: {res.discretization}; estimated relative error {errors}")
    if isinstance(res, Results):
        newton = res.newton
        steps = f"h = {res.raw['h']:.6g} s" if np.ptp(res.steps) == 0 else f"h = {res.steps.min():.3g} … {res.steps.max():.3g} s"
        print(f"{len(res.time) - 1} steps of {steps} to t = {res.time[-1]:.4g} s in {elapsed * 1e3:.1f} ms "
              f"({newton['total']} Newton iterations, at most {newton['max']} per step)")
        if sim.tip is not None:
            error = np.linalg.norm(res.tip_error(), axis=1)
            print(f"tip '{sim.node_names[sim.tip]}': max |r - r_rigid| = {error.max() * 1e3:.3f} mm, "
                  f"mean squared tip deflection d = {res.tip_deflection():.6e} m^2{_estimate(res, 'tip_deflection')}")
        print(f"mean compliance = {res.response('compliance'):.6g} J{_estimate(res, 'compliance')}")
    elif res.analysis == "linear":
        print(f"linear static analysis (K0 u = f) in {elapsed * 1e3:.1f} ms; compliance F^T u = "
              f"{res.response('compliance'):.6g} J{_estimate(res, 'compliance')}")
    else:
        print(f"static equilibrium in {elapsed * 1e3:.1f} ms ({res.newton['total']} Newton iterations, "
              f"{res.newton['load_steps']} load steps); compliance F^T u = {res.response('compliance'):.6g} J"
              f"{_estimate(res, 'compliance')}")


ROUGH = 0.1
"""An estimated relative error above which a fixed run's value is called rough."""


def _estimate(res, name: str) -> str:
    """A fixed run's estimated error of ``name`` (step doubling in time and space), to
    print beside its value; nothing for a run made to a tolerance (printed above)."""
    if res.discretization is not None:
        return ""
    try:
        error = res.error_estimate(name)
    except FlextopError as failure:
        return f" (no error estimate: {' '.join(str(failure).split())})"
    advice = "; the grid is too coarse for it: give --rtol, or a smaller --h" if error > ROUGH else ""
    return f" (estimated error {error:.1%}{advice})"


def demo(args: argparse.Namespace) -> int:
    """The robot arm of paper Section 4 at x = 0.4 on every bar."""
    from .plots import plot_tip_error

    sim = Simulation(scenes.robot_arm(split=args.split))
    print(f"robot arm: 2 links × 74 bars, {sim.n_design} design variables, x = {args.x} everywhere, "
          f"generalized-alpha rho_inf = 0.8")
    start = time.perf_counter()
    res = sim.run(args.x, h=args.h)
    _summarize(sim, res, time.perf_counter() - start)
    out = _folder(Path(args.out))
    plot_tip_error(res, path=out / "tip_error.png", labels=(f"x = {args.x} on every bar",))
    print(f"wrote {out / 'tip_error.png'}")
    return 0


@contextlib.contextmanager
def _progress_bar(duration: float) -> Iterator[Callable[[float], None]]:
    """A progress bar in simulated seconds on stderr, shown once a run has taken half a
    second; yields the function the run reports the time it reached to."""
    bar = tqdm(total=duration, unit="s", desc="simulate", file=sys.stderr, delay=0.5,
               bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.3g} of {total:.3g} s [{elapsed}<{remaining}]")
    try:
        yield lambda t: bar.update(t - bar.n)
    finally:
        bar.close()


def _picture(sim: Simulation, res: Any, out: Path, label: str) -> Path:
    """The figure of a run: its tip error (a scene with a tip), the paths of its joints and
    bodies (a motion without one), or its deformed shape (a static scene)."""
    from .plots import plot_deformed, plot_paths, plot_tip_error

    if not isinstance(res, Results):
        plot_deformed(res, title=label, path=out / "deformed.png")
        return out / "deformed.png"
    if sim.tip is not None:
        plot_tip_error(res, path=out / "tip_error.png", labels=(label,))
        return out / "tip_error.png"
    plot_paths(res, title=label, path=out / "paths.png")
    return out / "paths.png"


def simulate(args: argparse.Namespace) -> int:
    """Runs a scene file."""
    scene = _scene(args.scene, args.cells)
    if is_spatial(scene.to_dict()):
        return _simulate_spatial(scene.to_dict(), args)
    sim = Simulation(scene, accuracy=args.accuracy, rtol=args.rtol)
    settings = {k: v for k, v in {"t_end": args.t_end, "h": args.h, "rho_inf": args.rho_inf, "mass": args.mass,
                                  "local_tol": args.local_tol, "analysis": args.analysis}.items() if v is not None}
    if args.rtol is not None and args.h is not None:
        raise SettingsError("give --h (a fixed step) or --rtol (steps chosen to meet it), not both")
    if sim.analysis == "static":
        settings = {k: v for k, v in settings.items() if k in ("t_end", "local_tol", "analysis")}
    if args.vtk and args.out is None:
        raise SettingsError("--vtk writes into the --out folder; give --out")
    out = None if args.out is None else _folder(Path(args.out))
    start = time.perf_counter()
    if sim.analysis == "dynamic" and sim.rtol is None:
        with _progress_bar(t_end(sim, settings)) as report:
            res = sim.run(_design(sim, args.x, args.design), progress=report, **settings)
    else:
        res = sim.run(_design(sim, args.x, args.design), **settings)
    _summarize(sim, res, time.perf_counter() - start)
    if out is not None:
        design = (f"design {args.design}" if args.design else f"x = {args.x} on every bar") if sim.n_design else "no design variables"
        written = [res.save(out / "results.npz"), _picture(sim, res, out, f"{sim.spec.get('name', args.scene)}, {design}")]
        print(f"wrote {', '.join(map(str, written))} (flextop.load reads results.npz back)")
    if args.vtk:
        print(f"wrote {_vtk(res, out)} (open it in ParaView)")
    return 0


SPATIAL_OPTIONS = ("t_end", "h", "rho_inf")
"""The options of ``simulate`` a spatial scene takes."""


def _simulate_spatial(spec: dict, args: argparse.Namespace) -> int:
    """Runs a spatial scene (``dimension = 3``) and prints its summary."""
    planar = ("cells", "mass", "local_tol", "analysis")
    given = [k for k in planar if getattr(args, k) not in (None, False)]
    if given:
        names = ", ".join(f"--{k.replace('_', '-')}" for k in sorted(given))
        raise SettingsError(f"{names}: not built for spatial scenes yet (they take --x, --design, --t-end, --h, --rho-inf, "
                            "--accuracy, --rtol, --out)")
    sim = SpatialSimulation(spec, accuracy=args.accuracy, rtol=args.rtol)
    x = _design(sim, None if args.x == 0.4 else args.x, args.design)  # full density unless a design is given
    out = None if args.out is None else _folder(Path(args.out))
    settings = {k: getattr(args, k) for k in SPATIAL_OPTIONS if getattr(args, k) is not None}
    start = time.perf_counter()
    if sim.rtol is not None:
        return _spatial_to_tolerance(sim, x, settings, out, start)
    if sim.analysis == "static":
        eq = sim.equilibrium(x, **settings)
        print(f"static equilibrium in {(time.perf_counter() - start) * 1e3:.1f} ms ({eq.iterations} Newton iterations, "
              f"{eq.load_steps} load steps); strain energy {eq.strain:.6g} J")
        if sim.tip is not None:
            print(f"'{sim.tip}' at {np.array2string(eq.position(sim.tip), precision=6)} m")
        if out is not None:
            print(f"wrote {eq.to_vtk(out / 'state.vtu')} (open it in ParaView; Warp By Vector on displacement)")
            _spatial_design_figure(sim, x, out)
        return 0
    with _progress_bar(float(settings.get("t_end", sim.model.options().get("t_end", 0.0)))) as report:
        res = sim.simulate(x, progress=report, **settings)
    print(f"{len(res.time) - 1} steps to t = {res.time[-1]:.4g} s in {(time.perf_counter() - start) * 1e3:.1f} ms")
    energy = res.kinetic + res.potential
    print(f"kinetic + potential energy {energy[0]:.6g} J at the start, {energy[-1]:.6g} J at the end")
    if sim.tip is not None:
        print(f"'{sim.tip}' at {np.array2string(res.position(sim.tip)[-1], precision=6)} m at the end")
    if out is not None:
        print(f"wrote {res.to_vtk(out / 'motion.pvd')} (open it in ParaView)")
        _spatial_design_figure(sim, x, out)
    return 0


def _spatial_design_figure(sim: SpatialSimulation, x: np.ndarray | None, out: Path) -> None:
    """A designed spatial scene's design in 3D, as ``design.png`` in ``out``."""
    if sim.n_design:
        from .plots import plot_spatial_design

        plot_spatial_design(sim, x, title=f"{sim.model.name}: design", path=out / "design.png")
        print(f"wrote {out / 'design.png'}")


def _spatial_to_tolerance(sim: SpatialSimulation, x: np.ndarray | None, settings: dict, out: Path | None,
                          start: float) -> int:
    """A spatial scene's tip deflection (dynamic, with a tip) or strain energy to the
    simulation's tolerance: its value, the grid chosen and the estimated error."""
    if "h" in settings:
        raise SettingsError("give --h (a fixed step) or --rtol/--accuracy (steps chosen to meet it), not both")
    response = "tip_deflection" if sim.tip is not None and sim.analysis == "dynamic" else "strain_energy"
    run = sim.run_with_sensitivities(x, response, **settings)
    unit = "m²" if response == "tip_deflection" else "J"
    print(f"{response} = {run.values[0]:.6g} {unit} to rtol = {sim.rtol:g} in {time.perf_counter() - start:.1f} s: "
          f"{run.discretization}; estimated relative error {run.errors[response]:.2%}")
    if out is not None:
        grid, at = spatial_grid(sim, run.discretization, x, settings)
        state = grid.simulate(x, **at) if sim.analysis == "dynamic" else grid.equilibrium(x, **at)
        written = state.to_vtk(out / ("motion.pvd" if sim.analysis == "dynamic" else "state.vtu"))
        own = ", its own steps: the value above is extrapolated from half of them" if run.discretization.extrapolated else ""
        print(f"wrote {written} (on the grid accepted{own}; open it in ParaView)")
        _spatial_design_figure(sim, x, out)
    return 0


def _vtk(res, out: Path) -> Path:
    """The result for ParaView in ``out``: ``motion.pvd`` with about 100 frames, or
    ``state.vtu`` for a static result."""
    if isinstance(res, Results):
        return res.to_vtk(out / "motion.pvd")
    return res.to_vtk(out / "state.vtu")


def _scene(spec: str, cells: tuple[int, int] | None = None) -> Scene:
    """A scene file, or the name of a built-in scene (:data:`scenes.BUILT_IN`), its
    continuum members of ``cells`` (``nx``, ``ny``) where given."""
    if cells is not None:
        return _sized(spec, cells)
    if not Path(spec).exists() and spec in scenes.BUILT_IN:
        return scenes.BUILT_IN[spec]()
    if not Path(spec).exists():
        raise SceneFileError(f"{spec}: no such scene file, nor a built-in scene ({', '.join(scenes.BUILT_IN)})")
    return Scene.from_toml(spec)


def _sized(spec: str, cells: tuple[int, int]) -> Scene:
    """The built-in scene ``spec`` with members of ``cells`` = (nx, ny) cells, or a
    SettingsError: ``--cells`` sizes a built-in scene's continuum members."""
    if Path(spec).exists() or spec not in CONTINUUM:
        raise SettingsError(f"--cells sizes the members of a built-in continuum scene ({', '.join(CONTINUUM)}); "
                            f"{spec} is none (a scene file gives its members' nx and ny itself)")
    nx, ny = cells
    return scenes.BUILT_IN[spec](nx=nx, ny=ny)


def _problem(args: argparse.Namespace, workers: Workers) -> tuple[Simulation, TopologyProblem | ScenarioProblem]:
    """The problem the arguments describe: one scene, or the scenarios of ``--scenarios``,
    with volume constraints per component (or on the whole) of the first scene."""
    if args.scenarios is None:
        sim = Simulation(_scene(args.scene or "robot_arm", args.cells), accuracy=args.accuracy)
        constraints = volume_constraints(sim, args.volume_fraction or 0.4, per_component=not args.global_volume)
        if args.min_frequency is not None:
            constraints.append((MIN_FREQUENCY, args.min_frequency))
        if args.max_stress is not None:
            constraints.append(("stress", args.max_stress))
        if args.max_von_mises is not None:
            constraints.append(("von_mises", args.max_von_mises))
        if args.max_buckling is not None:
            constraints.append(("buckling", args.max_buckling))
        return sim, TopologyProblem(sim, args.objective or sim._default_response(), constraints, settings=_settings(args), rtol=args.rtol,
                                    filter=_filter(sim, args))
    if args.scene is not None:
        raise SettingsError("give a scene or --scenarios, not both")
    for flag, value in (("--min-frequency", args.min_frequency), ("--max-stress", args.max_stress), ("--max-von-mises", args.max_von_mises),
                        ("--max-buckling", args.max_buckling), ("--filter", args.filter), ("--filter-cells", args.filter_cells),
                        ("--projection", args.projection), ("--cells", args.cells)):
        if value is not None:
            raise SettingsError(f"{flag} applies to one scene, not to --scenarios")
    cases, aggregate = _scenario_file(args.scenarios)
    if is_spatial(cases[0].spec()):
        if args.analysis is not None:
            raise SettingsError("--analysis: not built for spatial scenes yet")
        first: Simulation | SpatialSimulation = SpatialSimulation(cases[0].spec())
        objective = args.objective or _spatial_objective(first)
        constraints = volume_bounds(first, args.volume_fraction or 0.4, not args.global_volume)
        settings = {k: getattr(args, k) for k in SPATIAL_OPTIONS if getattr(args, k) is not None}
    else:
        first = Simulation(cases[0].spec(), accuracy=args.accuracy)
        objective = args.objective or first._default_response()
        constraints = volume_constraints(first, args.volume_fraction or 0.4, per_component=not args.global_volume)
        settings = _settings(args)
    problem = ScenarioProblem(cases, objective, constraints, aggregate=args.aggregate or aggregate,
                              executor=workers.executor, chunksize=workers.chunksize(len(cases)), settings=settings,
                              rtol=args.rtol, accuracy=args.accuracy)
    return problem.simulations[0], problem


def _filter(sim: Simulation, args: argparse.Namespace) -> DensityFilter | None:
    """The density filter of ``--filter`` (radius in m) or ``--filter-cells`` (in cells)
    with the projection of ``--projection`` (its sharpness β), or none."""
    if args.filter is not None and args.filter_cells is not None:
        raise SettingsError("give the filter's radius in m (--filter) or in cells (--filter-cells), not both")
    flag = "--filter" if args.filter is not None else "--filter-cells" if args.filter_cells is not None else None
    if flag is None:
        if args.projection is not None:
            raise SettingsError("--projection sharpens the density filter's densities: give --filter RADIUS too")
        return None
    if not _designs_cells(sim):
        raise SettingsError(f"{flag} acts on continuum members' cells, and the scene designs none")
    return DensityFilter(sim, args.filter, radius_cells=args.filter_cells, beta=args.projection)


def _scenario_file(spec: str) -> tuple[list[scenarios.Scenario], str]:
    """The scenarios of a TOML file (``aggregate = "sum" | "worst"`` and ``[[scenario]]``
    tables of ``name``, ``scene`` — a file relative to this one or a built-in scene — and
    ``weight``), or of the built-in ``robust_robot_arm``."""
    if not Path(spec).exists():
        if spec == "robust_robot_arm":
            return scenarios.robust_robot_arm(), "worst"
        raise SceneFileError(f"{spec}: no such scenario file, nor a built-in set of scenarios (robust_robot_arm)")
    data = read_toml(spec)
    entries = data.get("scenario")
    if not isinstance(entries, list) or not entries:
        raise SceneFileError(f"{spec}: give the scenarios as [[scenario]] tables (name, scene, weight)")
    cases = []
    for k, entry in enumerate(entries):
        if not isinstance(entry, dict) or set(entry) - {"name", "scene", "weight"} or "scene" not in entry:
            raise SceneFileError(f"{spec}: scenario[{k}] needs a scene and may have a name and a weight, nothing else")
        path = Path(spec).parent / str(entry["scene"])
        scene = _scene(str(path) if path.exists() else str(entry["scene"]))
        cases.append(scenarios.Scenario(str(entry.get("name", f"scenario {k}")), scene, entry.get("weight", 1.0)))
    aggregate = data.get("aggregate", "sum")
    if aggregate not in {a.value for a in scenarios.Aggregate}:
        raise SceneFileError(f"{spec}: aggregate must be \"sum\" or \"worst\", got {aggregate!r}")
    return cases, aggregate


def _started(sim: Simulation, path: Path) -> np.ndarray:
    """The start design of ``--start``: a design file, checked against the scene."""
    x = _design(sim, None, path)
    try:
        return sim._design(x)
    except DesignError as error:
        raise DesignError(f"--start {path}: {error}") from None


def _title(sim: Simulation, problem) -> str:
    if isinstance(problem, ScenarioProblem):
        return f"{len(problem.scenarios)} scenarios of {sim.spec.get('name') or 'a scene'}"
    return sim.spec.get("name") or "scene"


def _settings(args: argparse.Namespace) -> dict:
    given = {"h": args.h, "rho_inf": args.rho_inf, "t_end": args.t_end, "analysis": args.analysis}
    return {k: v for k, v in given.items() if v is not None}


def _keep_earlier_run(out: Path, force: bool) -> None:
    """A new run does not replace the checkpoint of an earlier one in ``out`` unless
    ``force``: one that can be resumed would be lost without a word."""
    path = out / "checkpoint.json"
    if force or not path.exists():
        return
    try:
        saved = checkpoint.load(path)
        finished = saved.get("finished")
        what = (f"a run that converged ({finished})" if finished in {s.name for s in CONVERGED}
                else f"a run that can be resumed from iteration {saved['state'].get('iteration', '?')}")
    except (CheckpointError, AttributeError, KeyError):
        what = "a checkpoint"
    resume = " (--resume goes on with it)" if what.startswith("a run that can") else ""
    raise SettingsError(f"--out {out} holds {what}{resume}: give another --out, or --force to start over in it")


def optimize_command(args: argparse.Namespace) -> int:
    """Topology optimization of a scene, or of several scenarios, with checkpoints, progress
    bar, summary and plots; the scenarios of an evaluation run on ``--workers`` threads or
    on the Dask cluster at ``--scheduler``."""
    with local_executor(args.workers, args.scheduler) as workers:
        return _optimize(args, workers)


def _optimize(args: argparse.Namespace, workers: Workers) -> int:
    out = Path(args.out)
    if args.scenarios is None and not args.resume:
        alone = [flag for flag, value in (("--aggregate", args.aggregate), ("--workers", args.workers), ("--scheduler", args.scheduler))
                 if value is not None]
        if alone:
            raise SettingsError(f"{', '.join(alone)}: for several scenarios; give --scenarios")
    if args.scene is not None and args.scenarios is None and not args.resume:
        spec = _scene(args.scene).to_dict()
        if is_spatial(spec):
            return _optimize_spatial(spec, args, out)
    sizing = [flag for flag, value in (("--size", args.size), ("--place", args.place), ("--max-mass", args.max_mass),
                                       ("--densities", args.densities or None)) if value is not None]
    if sizing and not args.resume:
        raise SettingsError(f"{', '.join(sizing)}: for a spatial scene (dimension = 3), not "
                            + ("scenarios" if args.scenarios is not None else "a planar one"))
    if args.resume:
        sim, problem, options, x0, state, animate = _resume(args, out, workers)
        if isinstance(problem, (SpatialProblem, SizingProblem)):
            return _optimize_spatial(sim.spec, args, out, resumed=(sim, problem, options, x0, state))
        print(f"resuming {out / 'checkpoint.json'} at iteration {state.iteration}")
    else:
        if args.rtol is not None and args.h is not None:
            raise SettingsError("give --h (a fixed step) or --rtol (steps chosen to meet it), not both")
        sim, problem = _problem(args, workers)
        x0 = 0.4 if args.x0 is None else args.x0
        if not sim.x_min <= x0 <= 1.0:
            raise DesignError(f"--x0 {x0:g} is outside [{sim.x_min:g}, 1]")
        options = {"method": args.method or "mma", "max_iter": args.max_iter or 30, "move": args.move or 0.2,
                   "kkt_tol": args.kkt_tol or 1e-6, "xtol": args.xtol}
        start = np.full(sim.n_design, x0) if args.start is None else _started(sim, args.start)
        x0, state, animate = problem.start(start), None, args.animate
        _keep_earlier_run(out, args.force)
        _folder(out)
    print(f"{_title(sim, problem)}: minimize {problem.description} over {sim.n_design} densities "
          f"subject to {', '.join(f'{n} {relation(n)} {b:.4g}' for n, b in problem.bounded) or 'bounds only'} ({options['method']})")
    def save(state_dict: dict, finished: str | None = None) -> None:
        checkpoint.save(out / "checkpoint.json", {"scene": sim.spec, "accuracy": sim.accuracy, "problem": problem.to_dict(),
                                                  "optimizer": options, "x0": x0.tolist(), "state": state_dict,
                                                  "animate": animate, "finished": finished})

    bar = _Progress(options["max_iter"], 0 if state is None else state.iteration)

    latest: dict[str, dict] = {}

    def on_iteration(record) -> None:
        latest["state"] = record.state.to_dict()
        save(latest["state"])
        bar.update(1)
        bar.set_postfix(f=f"{problem.unscaled(record.f0, record.g):.4g}", g=f"{np.max(record.g, initial=-np.inf):+.2e}", change=f"{record.change:.3f}")

    start = time.perf_counter()
    try:
        result = optimize(problem, x0, options["method"], max_iter=options["max_iter"], move=options["move"],
                          kkt_tol=options["kkt_tol"], xtol=options["xtol"], callback=on_iteration, state=state)
    except KeyboardInterrupt:
        if latest or state is not None:
            print(f"interrupted; the last iteration is saved: resume with `flextop optimize --resume --out {out}`")
        else:
            print("interrupted before the first iteration ended: nothing to resume")
        return 130
    finally:
        bar.close()
    if latest:  # a resume can tell a run that has stopped for good; the state as concluded at the returned design
        save(result.state.to_dict() if result.state is not None else latest["state"], finished=result.status.name)
    elapsed = time.perf_counter() - start
    _report(problem, result, elapsed, result.nit - (0 if state is None else state.iteration))
    np.save(out / "design.npy", result.x[: sim.n_design])
    if getattr(problem, "filter", None) is not None:
        np.save(out / "densities.npy", problem.densities(result.x[: sim.n_design]))
    checkpoint.write_atomically(out / "history.json", json.dumps({
        "history": [r.to_dict() for r in result.history], "status": result.status.name, "message": result.message,
        "objective_scale": problem.objective_scale}))
    if isinstance(sim, SpatialSimulation):
        _spatial_scenario_output(sim, problem, result, out, plots=not args.no_plots, vtk=args.vtk)
    elif not args.no_plots and result.history:
        _pictures(sim, problem, result, x0, out, animate=animate, every=args.every, fps=args.fps)
    if args.vtk and result.history and not isinstance(sim, SpatialSimulation):
        x = problem.densities(result.x[: sim.n_design])
        tolerance = {"rtol": problem.rtol} if problem.rtol else {}
        written = [export.write_design(sim, x, out / "design.vtu"), _vtk(sim.run(x, **tolerance, **problem.settings), out)]
        print(f"wrote {', '.join(map(str, written))} (open them in ParaView)")
    if not args.no_cad and result.history and _designs_cells(sim):
        _cad(sim, problem.densities(result.x[: sim.n_design]), out / "cad", args.cad_threshold)
    if not result.success:
        print(f"flextop: the optimizer did not converge: {' '.join(result.message.split())}", file=sys.stderr)
        return NOT_CONVERGED
    return 0


class _Progress:
    """An optimization's progress bar on stderr, drawn from its first iteration's end: an error
    in the first evaluation (a response the scene does not have) is the one line printed."""

    def __init__(self, total: int, initial: int) -> None:
        self.total, self.initial, self.bar = total, initial, None  # type: int, int, Any

    def _drawn(self) -> Any:
        if self.bar is None:
            self.bar = tqdm(total=self.total, initial=self.initial, unit="it", desc="optimize", file=sys.stderr)
        return self.bar

    def update(self, n: int) -> None:
        self._drawn().update(n)

    def set_postfix(self, **values: Any) -> None:
        self._drawn().set_postfix(**values)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


SPATIAL_REFUSED = ("cells", "filter", "filter_cells", "projection",
                   "max_von_mises", "start", "analysis", "animate", "every")
"""The options of ``optimize`` a spatial scene does not take yet."""


def _optimize_spatial(spec: dict, args: argparse.Namespace, out: Path, resumed: tuple | None = None) -> int:
    """Minimizes a spatial scene's response (``--objective``; its tip's deflection from the
    rigid trajectory where it names a tip, else its strain energy) over its beams' densities
    at ``--volume-fraction`` of each ground structure's volume (paper Eq. 41; of the whole
    with ``--global-volume`` or where the scene has none) (:class:`~flextop.problems.SpatialProblem`),
    or goes on with the run ``resumed`` from its checkpoint; a checkpoint after every
    iteration; writes design.npy, history.json, the design's figure and, with ``--vtk``, its
    motion."""
    if resumed is None:
        sim, problem, options, start = _spatial_problem(spec, args)
        state = None
        _keep_earlier_run(out, args.force)
        _folder(out)
    else:
        sim, problem, options, start, state = resumed
        print(f"resuming {out / 'checkpoint.json'} at iteration {state.iteration}")
    objective, settings, method = problem.objective, problem.settings, options["method"]
    sizing = isinstance(problem, SizingProblem)
    over = f"{sim.n_design} densities"
    if sizing:
        over = f"{problem.k} sizes and places ({', '.join(problem.variables)})" + (
            f" and {sim.n_design} densities" if problem.densities else "")
    print(f"{sim.model.name}: minimize {objective} over {over} subject to "
          f"{', '.join(problem.names or []) or 'bounds only'} ({method})")

    def save(state_dict: dict, finished: str | None = None) -> None:
        checkpoint.save(out / "checkpoint.json", {"spatial": True, "sizing": sizing, "scene": sim.spec, "accuracy": None,
                                                  "problem": problem.to_dict(),
                                                  "optimizer": options, "x0": start.tolist(), "state": state_dict,
                                                  "finished": finished})

    bar = _Progress(options["max_iter"], 0 if state is None else state.iteration)
    latest: dict[str, dict] = {}

    def on_iteration(record) -> None:
        latest["state"] = record.state.to_dict()
        save(latest["state"])
        bar.update(1)
        bar.set_postfix(f=f"{record.f0:.4g}", g=f"{np.max(record.g, initial=-np.inf):+.2e}", kkt=f"{record.kkt:.2e}")

    begun = time.perf_counter()
    try:
        result = optimize(problem, start, method, max_iter=options["max_iter"], move=options["move"],
                          kkt_tol=options["kkt_tol"], xtol=options["xtol"], callback=on_iteration, state=state)
    except KeyboardInterrupt:
        if latest or state is not None:
            print(f"interrupted; the last iteration is saved: resume with `flextop optimize --resume --out {out}`")
        else:
            print("interrupted before the first iteration ended: nothing to resume")
        return 130
    finally:
        bar.close()
    if latest:
        save(result.state.to_dict() if result.state is not None else latest["state"], finished=result.status.name)
    elapsed = time.perf_counter() - begun
    print(f"\nstatus: {result.status.name} — {result.message}")
    if sizing:
        sim = SpatialSimulation(problem.spec_at(result.x))
    if result.history:
        held = (f"mass {sim.mass(problem.densities_at(result.x)):.4g} kg" if sizing else
                f"volume {sim.volume(result.x) / sim.volume(1.0):.4f} of the full")
        print(f"{objective}: {problem.reference:.6g} at the start → {result.fun * problem.reference:.6g} "
              f"({100 * (result.fun - 1):+.1f} %) after {result.nit} iterations, {result.nfev} evaluations, "
              f"KKT residual {result.kkt:.2e}; {held}; {elapsed:.1f} s")
    if sizing:
        for name, value, lo, hi in zip(problem.variables, result.x, problem.lower, problem.upper):
            print(f"{name}: {value:.6g} m (bounds {lo:g} to {hi:g})")
    if problem.tolerance is not None and problem.held is not None:
        rtol = problem.tolerance[0]
        at = problem.scaled(result.x) if sizing else result.x
        measured = problem.rule.at is not None and np.array_equal(problem.rule.at, at)
        print(f"to rtol = {rtol:g}: the design returned measured on {problem.held}" if measured else
              f"to rtol = {rtol:g}: the design returned could not be measured; its values are those of "
              f"{problem.held}, held")
    np.save(out / "design.npy", result.x)
    if sizing:
        if problem.densities:
            np.save(out / "densities.npy", problem.densities_at(result.x))
        (out / "sized.toml").write_text(SpatialScene.from_dict(sim.spec).to_toml(
            header=f"{sim.model.name} sized by flextop optimize: {objective} minimized"))
        print(f"wrote {out / 'sized.toml'} (the scene at the sizes and places returned)")
    checkpoint.write_atomically(out / "history.json", json.dumps({
        "history": [r.to_dict() for r in result.history], "status": result.status.name, "message": result.message,
        "objective_scale": problem.reference}))
    if not args.no_plots and result.history:
        from .plots import plot_history, plot_spatial_design

        x = problem.densities_at(result.x) if sizing else result.x
        plot_spatial_design(sim, x, title=f"{sim.model.name}: {objective}, optimized", path=out / "design.png")
        plot_history(result.history, path=out / "history.png", objective_label=f"{objective} / start")
    if args.vtk and result.history and sim.analysis == "dynamic":
        x = problem.densities_at(result.x) if sizing else result.x
        print(f"wrote {sim.simulate(x, **settings).to_vtk(out / 'motion.pvd')} (open it in ParaView)")
    if not result.success:
        print(f"flextop: the optimizer did not converge: {' '.join(result.message.split())}", file=sys.stderr)
        return NOT_CONVERGED
    return 0


def _spatial_problem(spec: dict, args: argparse.Namespace
                     ) -> tuple[SpatialSimulation, SpatialProblem | SizingProblem, dict, np.ndarray]:
    """The spatial scene's simulation, problem, optimizer options and start from the
    command line's options, those it does not take named: its densities
    (:class:`~flextop.problems.SpatialProblem`), or with ``--size`` or ``--place`` its
    sections' sizes and its joints' places (:class:`~flextop.problems.SizingProblem`)."""
    given = [k for k in SPATIAL_REFUSED if getattr(args, k) not in (None, False)]
    if given:
        names = ", ".join(f"--{k.replace('_', '-')}" for k in sorted(given))
        raise SettingsError(f"{names}: not built for spatial scenes yet (they take --objective, --volume-fraction, "
                            "--global-volume, --max-stress, --max-buckling, --min-frequency, --max-mass, --size, --place, --densities, "
                            "--x0, --accuracy, --rtol, --method, --max-iter, --move, --kkt-tol, --xtol, --t-end, --h, "
                            "--rho-inf, --out, --force, --resume, --no-plots, --vtk)")
    options = {"method": args.method or "mma", "max_iter": args.max_iter or 30, "move": args.move or 0.2,
               "kkt_tol": args.kkt_tol or 1e-6, "xtol": args.xtol}
    if args.size or args.place:
        sim, sizing = _sizing_problem(spec, args)
        return sim, sizing, options, sizing.z0
    if args.densities:
        raise SettingsError("--densities designs the densities beside --size or --place; without them the densities "
                            "are the design already")
    sim = SpatialSimulation(spec)
    if sim.n_design == 0:
        raise SettingsError(f"{spec.get('name', 'the scene')}: every beam is fixed: nothing to design")
    settings = {k: getattr(args, k) for k in SPATIAL_OPTIONS if getattr(args, k) is not None}
    objective = args.objective or _spatial_objective(sim)
    fraction = args.volume_fraction or 0.4
    per_structure = not args.global_volume and bool(structures_of(sim))
    limits = [(name, value) for name, value in (("stress", args.max_stress), ("buckling", args.max_buckling))
              if value is not None]
    if args.min_frequency is not None:
        limits.append((MIN_FREQUENCY, args.min_frequency))
    if args.max_mass is not None:
        limits.append(("mass", args.max_mass))
    problem = SpatialProblem(sim, objective, limits, volume=fraction, per_structure=per_structure,
                             rtol=_spatial_rtol(args, settings), **settings)
    x0 = 0.4 if args.x0 is None else args.x0
    if not sim.x_min <= x0 <= 1.0:
        raise DesignError(f"--x0 {x0:g} is outside [{sim.x_min:g}, 1]")
    return sim, problem, options, np.full(sim.n_design, x0)


def _spatial_rtol(args: argparse.Namespace, settings: dict) -> float | None:
    """The tolerance of ``--accuracy`` or ``--rtol`` (``None``: the scene's grid)."""
    if args.accuracy is not None and args.rtol is not None:
        raise SettingsError("give --accuracy (a named tolerance) or --rtol, not both")
    rtol = preset(args.accuracy) if args.accuracy is not None else args.rtol
    if rtol is not None and "h" in settings:
        raise SettingsError("give --h (a fixed step) or --rtol/--accuracy (steps chosen to meet it), not both")
    return rtol


def _sizing_problem(spec: dict, args: argparse.Namespace) -> tuple[SpatialSimulation, SizingProblem]:
    """The sizing problem of ``--size`` and ``--place``: ``--objective`` (the tip's
    deflection or the strain energy by default) under ``--max-mass``, the densities held at
    ``--x0`` (full density by default) or, with ``--densities``, designed too from it (0.4
    by default) under ``--volume-fraction`` of each ground structure's volume at the scene's
    sizes (of the whole with ``--global-volume``)."""
    refused = [flag for flag, value in (("--max-stress", args.max_stress), ("--max-buckling", args.max_buckling),
                                        ("--min-frequency", args.min_frequency)) if value not in (None, False)]
    if not args.densities:
        refused += [flag for flag, value in (("--volume-fraction", args.volume_fraction),
                                             ("--global-volume", args.global_volume)) if value not in (None, False)]
    if refused:
        raise SettingsError(f"{', '.join(refused)}: not built for sizing (--size, --place) yet; it takes --max-mass"
                            + ("" if args.densities else ", and with --densities --volume-fraction"))
    sim = SpatialSimulation(spec)
    if args.place and args.objective is None and _spatial_objective(sim) == "tip_deflection":
        raise SettingsError("--place: give --objective: the tip's deflection from its rigid trajectory, the default, "
                            "moves with a joint's place, and that rate is not built")
    settings = {k: getattr(args, k) for k in SPATIAL_OPTIONS if getattr(args, k) is not None}
    limits = [] if args.max_mass is None else [("mass", args.max_mass)]
    if args.densities and args.volume_fraction is not None:
        limits += volume_bounds(sim, args.volume_fraction, not args.global_volume)
    x = (0.4 if args.x0 is None else args.x0) if args.densities else args.x0
    problem = SizingProblem(spec, args.objective or _spatial_objective(sim), limits, sizes=_bounded(args.size, "--size"),
                            places=_bounded(args.place, "--place"), x=x, densities=args.densities,
                            rtol=_spatial_rtol(args, settings), **settings)
    return sim, problem


def _bounded(entries: list[str] | None, flag: str) -> dict[str, tuple[float, float]]:
    """``NAME=LOWER:UPPER`` entries of ``flag`` as ``{NAME: (lower, upper)}`` (m)."""
    out: dict[str, tuple[float, float]] = {}
    for entry in entries or []:
        name, _, bounds = entry.partition("=")
        lower, _, upper = bounds.partition(":")
        try:
            out[name.strip()] = (float(lower), float(upper))
        except ValueError:
            raise SettingsError(f"{flag} {entry}: give NAME=LOWER:UPPER, the bounds in m") from None
    return out


def _spatial_objective(sim: SpatialSimulation) -> str:
    """A spatial scene's default objective: its tip's deflection from the rigid trajectory
    where it names a tip and moves, else its strain energy."""
    return "tip_deflection" if sim.tip is not None and sim.analysis == "dynamic" else "strain_energy"


def _designs_cells(sim: Simulation | SpatialSimulation) -> bool:
    """Whether the scene designs cells of a continuum member (a spatial scene has none)."""
    if isinstance(sim, SpatialSimulation):
        return False
    return bool(np.asarray(sim.model.cells()["variable"]).max(initial=-1) >= 0)


def _cad(sim: Simulation, densities: np.ndarray, folder: Path, threshold: float) -> None:
    """The continuum members' shapes at ``threshold`` as DXF, SVG and STL in ``folder``, or a
    one-line warning where the ``cad`` extra is not installed."""
    if absent := cad.missing():
        print(f"flextop: warning: no CAD files: they need {', '.join(absent)} (pip install \"flextop[cad]\")", file=sys.stderr)
        return
    written = cad.write(sim, densities, folder, threshold=threshold)
    print(f"wrote {', '.join(map(str, written))} (the members' outlines at density {threshold:g}, in mm)")


def _resume(args: argparse.Namespace, out: Path, workers: Workers):
    """Everything a checkpointed run needs to go on, verified: the checkpoint's own
    integrity, options that agree with it, a design inside its bounds, and a run that
    has not stopped for good."""
    path = out / "checkpoint.json"
    saved = checkpoint.load(path)
    if args.scenarios is not None or args.scene is not None:
        raise SettingsError("--resume takes the scene or scenarios from the checkpoint; give neither")
    fixed = {"--volume-fraction": args.volume_fraction, "--global-volume": args.global_volume or None, "--x0": args.x0,
             "--start": args.start, "--analysis": args.analysis, "--h": args.h, "--rho-inf": args.rho_inf, "--t-end": args.t_end, "--accuracy": args.accuracy,
             "--rtol": args.rtol, "--aggregate": args.aggregate, "--move": args.move, "--kkt-tol": args.kkt_tol,
             "--xtol": args.xtol, "--min-frequency": args.min_frequency, "--max-stress": args.max_stress,
             "--size": args.size, "--place": args.place, "--max-mass": args.max_mass, "--densities": args.densities or None,
             "--max-von-mises": args.max_von_mises, "--max-buckling": args.max_buckling, "--filter": args.filter,
             "--filter-cells": args.filter_cells, "--projection": args.projection, "--cells": args.cells}
    given = [flag for flag, value in fixed.items() if value is not None]
    if given:
        raise SettingsError(f"{', '.join(given)}: the checkpoint fixes the problem; start a new run in another --out to change it")
    try:
        if saved.get("sizing"):
            problem = SizingProblem.from_dict(saved["problem"])
            sim = SpatialSimulation(problem.spec)
        elif saved.get("spatial"):
            sim = SpatialSimulation(saved["scene"])
            problem = SpatialProblem.from_dict(sim, saved["problem"])
        elif "scenarios" in saved["problem"]:
            n = len(saved["problem"]["scenarios"])
            problem = ScenarioProblem.from_dict(saved["problem"], workers.executor, workers.chunksize(n))
            sim = problem.simulations[0]
        else:
            sim = Simulation(Scene.from_dict(saved["scene"]), accuracy=saved["accuracy"])
            problem = TopologyProblem.from_dict(sim, saved["problem"])
        state = OptimizerState.from_dict(saved["state"])
        options = {**saved["optimizer"], "max_iter": args.max_iter or saved["optimizer"]["max_iter"]}
        x0 = np.array(saved["x0"], dtype=float)
    except (FlextopError, KeyError, TypeError, ValueError, AttributeError) as error:
        if isinstance(error, ExecutionError):
            raise
        raise CheckpointError(f"{path} does not describe a run: {error}") from None
    for flag, given, kept in (("--method", args.method, options["method"]), ("--objective", args.objective, problem.objective)):
        if given is not None and given != kept:
            raise SettingsError(f"{flag} {given} differs from the checkpoint's {kept}; start a new run in another --out")
    if not (state.x.shape == problem.lower.shape and np.all(np.isfinite(state.x)) and np.all(state.x >= problem.lower)
            and np.all(state.x <= problem.upper)):
        raise CheckpointError(f"{path} holds a design outside the bounds [{problem.lower.min():g}, {problem.upper.max():g}]")
    finished = saved.get("finished")
    if finished in {s.name for s in CONVERGED}:
        raise CheckpointError(f"the run in {out} has converged ({finished}); there is nothing to resume")
    if state.iteration >= options["max_iter"]:
        raise CheckpointError(f"the run in {out} has done its {state.iteration} iterations; give --max-iter above that to go on")
    return sim, problem, options, x0, state, args.animate or bool(saved.get("animate"))


def _report(problem: TopologyProblem | ScenarioProblem, result, elapsed: float, session: int) -> None:
    """The final summary table; `session` iterations ran in this call (the time shares)."""
    if not result.history or problem.objective_scale is None:  # not even the start design ran
        print(f"\nstatus: {result.status.name} — {result.message}")
        return
    print(f"\n{'it':>4} {problem.objective:>16} {'max g':>10} {'change':>8} {'KKT':>9}")
    for r in result.history:
        print(f"{r.iteration:>4} {problem.unscaled(r.f0, r.g):>16.6g} {np.max(r.g, initial=-np.inf):>10.2e} {r.change:>8.4f} {r.kkt:>9.2e}")
    initial, final = problem.objective_scale, result.fun  # scaled by its value at the start design
    print(f"\nstatus: {result.status.name} — {result.message}")
    print(f"{problem.description}: {initial:.6g} at the start → {final:.6g} "
          f"({100 * (final / initial - 1):+.1f} %) after {result.nit} iterations, {result.nfev} evaluations")
    constr = result.constr
    if isinstance(problem, ScenarioProblem):
        if problem.aggregate is scenarios.Aggregate.WORST:  # each scenario's w f first
            for case, value in zip(problem.scenarios, constr):
                print(f"{case.name}: {problem.objective} = {value / case.weight:.6g}")
        constr = constr[len(constr) - len(problem.bounded):]
        for name, d in problem.discretizations.items():
            print(f"{name}: {d}")
    for (name, bound), value in zip(problem.bounded, constr):
        print(f"{name}: {value:.6g} ({relation(name)} {bound:.6g})")
    if getattr(problem, "refinements", None):
        at = ", ".join(f"{d} at evaluation {k}" for k, d in problem.refinements)
        print(f"to rtol = {problem.rtol or problem.simulation.rtol:g}: discretizations {at}")
    solve = sum(r.solve_time for r in result.history[-session:]) if session else 0.0
    if isinstance(problem, ScenarioProblem):  # the runs' seconds add up over the workers
        runs = (f"{problem.timings['runs']:.2f} s (motions with their adjoint sweeps)" if "runs" in problem.timings else
                f"{problem.timings['simulation']:.2f} s of simulation and {problem.timings['gradients']:.2f} s of gradients")
        print(f"time: {elapsed:.2f} s — the scenarios' runs took {runs} in all, the subproblems {solve:.2f} s")
        return
    shares = {"simulation": problem.timings["simulation"], "gradients": problem.timings["gradients"], "subproblem": solve}
    other = max(elapsed - sum(shares.values()), 0.0)
    print(f"time: {elapsed:.2f} s — " + ", ".join(f"{k} {100 * v / elapsed:.1f} %" for k, v in {**shares, "other": other}.items()))


def _spatial_scenario_output(sim: SpatialSimulation, problem: ScenarioProblem, result, out: Path, *, plots: bool,
                             vtk: bool) -> None:
    """The figures of a finished run on spatial scenarios — the design in 3D, the history —
    and, with ``vtk``, the first scenario's motion at the design for ParaView."""
    if not result.history:
        return
    x = problem.densities(result.x)
    written = []
    if plots:
        from .plots import plot_history, plot_spatial_design

        worst = problem.aggregate is scenarios.Aggregate.WORST
        plot_spatial_design(sim, x, title=f"{sim.model.name}: {problem.description}, optimized", path=out / "design.png")
        plot_history(result.history, path=out / "history.png",
                     objective_label="β = ln(worst / start)" if worst else problem.objective,
                     objective_scale=None if worst else problem.objective_scale, constraint_labels=list(problem.names or []))
        written += [out / "design.png", out / "history.png"]
    if vtk and sim.analysis == "dynamic":
        settings = {k: v for k, v in problem.settings.items() if k in SPATIAL_OPTIONS}
        written.append(sim.simulate(x, **settings).to_vtk(out / "motion.pvd"))
    if written:
        print(f"wrote {', '.join(map(str, written))}" + (f" (the motion of {problem.scenarios[0].name!r}; open it in ParaView)"
                                                         if vtk and sim.analysis == "dynamic" else ""))


def _pictures(sim: Simulation, problem: TopologyProblem | ScenarioProblem, result, x0: np.ndarray, out: Path, *, animate: bool,
              every: int | None = None, fps: float = 20) -> None:
    """Designs, history and tip error (of the first scenario) of a finished run."""
    from .plots import animate as animation, plot_design, plot_history, plot_tip_error

    x0, x = problem.densities(x0[: sim.n_design]), problem.densities(result.x[: sim.n_design])
    plot_design(sim, x0, path=out / "design_initial.png", title="initial design")
    plot_design(sim, x, path=out / "design.png", title=f"optimized: {problem.description}")
    if result.history:
        worst = isinstance(problem, ScenarioProblem) and problem.aggregate is scenarios.Aggregate.WORST
        plot_history(result.history, path=out / "history.png",
                     objective_label="β = ln(worst / start)" if worst else problem.objective,
                     objective_scale=None if worst else problem.objective_scale, constraint_labels=list(problem.names or []))
    written = ["design_initial.png", "design.png", "history.png"]
    if sim.analysis == "dynamic" and sim.tip is not None:
        tolerance = {"rtol": problem.rtol} if problem.rtol else {}
        before, after = sim.run(x0, **tolerance, **problem.settings), sim.run(x, **tolerance, **problem.settings)
        plot_tip_error(before, after, path=out / "tip_error.png")
        written.append("tip_error.png")
        if animate:
            animation(after, out / "motion.gif", x=x, every=every, fps=fps)
            written.append("motion.gif")
    print(f"wrote {', '.join(str(out / w) for w in written)}")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="flextop", description="Flexible multibody dynamics and topology optimization of moving machines.")
    p.add_argument("--debug", action="store_true", help="show the traceback of an error instead of one line")
    p.add_argument("--version", action="version", version=f"flextop {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="run the paper's robot arm and plot its tip error")
    d.add_argument("--x", type=float, default=0.4, help="density of every bar (default 0.4)")
    d.add_argument("--h", type=_positive(float), default=0.02, help="step size in s (default 0.02)")
    d.add_argument("--split", type=_positive(int), default=1, help="elements per bar (default 1)")
    d.add_argument("--out", default="demo_out", help="output folder (default demo_out)")
    d.set_defaults(run=demo)
    s = sub.add_parser("simulate", help="run a scene file")
    s.add_argument("scene", help="TOML scene file or a built-in scene: " + ", ".join(scenes.BUILT_IN))
    s.add_argument("--cells", type=_cells, metavar="NXxNY", help=CELLS_HELP)
    s.add_argument("--x", type=float, default=0.4, help="uniform density of every bar (default 0.4, as demo and optimize; a spatial scene runs at full density unless given)")
    s.add_argument("--design", type=Path, help="design vector file (.npy or text)")
    s.add_argument("--t-end", type=_positive(float))
    s.add_argument("--h", type=_positive(float))
    s.add_argument("--rho-inf", type=float)
    s.add_argument("--mass", choices=["consistent", "lumped", "bar_lumped"])
    s.add_argument("--analysis", choices=["nonlinear", "linear"], help=ANALYSIS_HELP)
    s.add_argument("--accuracy", choices=["fast", "balanced", "accurate"], help="accuracy preset (see flextop.discretization.accuracy)")
    s.add_argument("--rtol", type=_fraction, help="relative tolerance on d (or compliance): steps and elements per bar chosen to meet it")
    s.add_argument("--local-tol", type=_positive(float), help="variable steps by local error control (relative to the model's size)")
    s.add_argument("--out", help="folder for results.npz (everything the run holds; flextop.load reads it) and tip_error.png")
    s.add_argument("--vtk", action="store_true", help="also write the motion for ParaView (motion.pvd and its .vtu files) in --out")
    s.set_defaults(run=simulate)
    o = sub.add_parser("optimize", help="topology optimization of a scene (checkpointed, resumable)")
    o.add_argument("scene", nargs="?", help="TOML scene file or a built-in scene: " + ", ".join(scenes.BUILT_IN) + " (default robot_arm)")
    o.add_argument("--scenarios", help="optimize for several scenarios: a TOML file of [[scenario]] tables (name, scene, weight; the scenes planar or all spatial) "
                   "and aggregate = \"sum\" | \"worst\", or the built-in robust_robot_arm (3 motions x 3 payloads, worst case)")
    o.add_argument("--cells", type=_cells, metavar="NXxNY", help=CELLS_HELP)
    o.add_argument("--aggregate", choices=["sum", "worst"], help="with --scenarios: weighted sum or worst case of the objective")
    o.add_argument("--workers", type=_positive(int), help="run the scenarios of an evaluation on N threads")
    o.add_argument("--scheduler", help="run the scenarios on the Dask cluster whose scheduler is at ADDRESS (tcp://host:8786)")
    o.add_argument("--objective", help="response to minimize (default: tip_deflection, or compliance for a static scene): "
                   + ", ".join(responses.NAMES))
    o.add_argument("--method", choices=["mma", "gcmma", "conlin", "oc"],
                   help="optimizer (default mma; oc: optimality criteria, for one volume constraint with --global-volume)")
    o.add_argument("--filter", type=_positive(float), metavar="RADIUS",
                   help="density filter on continuum members' cells, radius in m (design.npy then holds the variables, densities.npy the densities)")
    o.add_argument("--filter-cells", type=_positive(float), metavar="CELLS",
                   help="the density filter with its radius in cells (the 88-line code's rmin), instead of --filter's metres")
    o.add_argument("--projection", type=_positive(float), metavar="BETA", help="with --filter: tanh projection of sharpness BETA about 0.5")
    o.add_argument("--volume-fraction", type=_fraction, help="V <= fraction * V_full (default 0.4)")
    o.add_argument("--global-volume", action="store_true", help="one volume constraint instead of one per component")
    o.add_argument("--min-frequency", type=_positive(float), metavar="HZ",
                   help="a floor on the lowest natural frequency at rest, drives locked (KS over the lowest two, to 1e-3; "
                   "on a spatial scene, of the mesh as built, its loads, motors and gravity taken away)")
    o.add_argument("--max-stress", type=_positive(float), metavar="PA",
                   help="a limit on the peak fibre stress over the motion, relaxed as x^0.5 σ (p-mean normalized to the peak); "
                   "on a spatial scene, the beams' von Mises stress at their sections' edges and the bars' axial stress")
    o.add_argument("--max-von-mises", type=_positive(float), metavar="PA",
                   help="a limit on the peak von Mises stress of the continuum members' cells over the motion, relaxed as "
                   "x^0.5 σ (p-mean normalized to the peak)")
    o.add_argument("--max-buckling", type=_positive(float), metavar="RATIO",
                   help="a limit on the peak compression over the Euler load of the bars, relaxed as x^0.5 P/P_cr (1 = a solid bar buckles)")
    o.add_argument("--size", action="append", metavar="SECTION.DIMENSION=LOWER:UPPER",
                   help="a spatial scene: size this section's dimension (m) between the bounds, the densities held "
                   "unless --densities (SizingProblem; repeat for several)")
    o.add_argument("--place", action="append", metavar="JOINT.AXIS=LOWER:UPPER",
                   help="a spatial scene: place this joint along x, y or z (m) between the bounds, the densities held "
                   "unless --densities (SizingProblem; repeat for several)")
    o.add_argument("--densities", action="store_true",
                   help="with --size or --place: design the bars' densities too, from --x0 (default 0.4), under "
                   "--volume-fraction if given")
    o.add_argument("--max-mass", type=_positive(float), metavar="KG",
                   help="a spatial scene: a limit on the beams' and bars' mass (kg)")
    o.add_argument("--x0", type=float, help="initial density of every bar (default 0.4); with --size or --place, the "
                   "density every bar is held at (default 1)")
    o.add_argument("--start", type=Path, help="start from this design (.npy or text), e.g. the design.npy of an earlier run")
    o.add_argument("--max-iter", type=_positive(int), help="iterations in all, resumed ones included (default 30)")
    o.add_argument("--move", type=_fraction, help="move limit as a fraction of the bounds (default 0.2)")
    o.add_argument("--kkt-tol", type=_positive(float), help="converged, and stop, when the KKT residual falls below it (default 1e-6)")
    o.add_argument("--xtol", type=_positive(float), help="stop when the largest design change falls below it: converged for --method oc "
                        "(its update's change is its optimality residual; 0.01 in the 88-line code), "
                        "stalled (not converged) for the others (default: off)")
    o.add_argument("--analysis", choices=["nonlinear", "linear"], help=ANALYSIS_HELP)
    o.add_argument("--h", type=_positive(float))
    o.add_argument("--rho-inf", type=float)
    o.add_argument("--t-end", type=_positive(float))
    o.add_argument("--accuracy", choices=["fast", "balanced", "accurate"], help="accuracy preset (see flextop.discretization.accuracy)")
    o.add_argument("--rtol", type=_fraction, help="relative tolerance on every response of every evaluation (see TopologyProblem)")
    o.add_argument("--out", default="runs/optimize", help="folder for checkpoint, design, history and plots")
    o.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    o.add_argument("--force", action="store_true", help="start a new run in an --out that holds an earlier run's checkpoint")
    o.add_argument("--no-plots", action="store_true")
    o.add_argument("--animate", action="store_true", help="also write motion.gif of the optimized design")
    o.add_argument("--every", type=_positive(int), help="with --animate: a frame every N steps (default: about 100 frames)")
    o.add_argument("--fps", type=_positive(float), default=20.0, help="with --animate: frames per second (default 20)")
    o.add_argument("--vtk", action="store_true", help="also write the optimized design (design.vtu) and its motion (motion.pvd) "
                   "for ParaView")
    o.add_argument("--cad-threshold", type=_open_fraction, default=0.5, metavar="DENSITY",
                   help="the density at which the continuum members' outlines are drawn into --out/cad "
                   "(NAME.dxf, NAME.svg, NAME.stl extruded by the member's thickness, in mm; default 0.5)")
    o.add_argument("--no-cad", action="store_true", help="do not write the continuum members' outlines")
    o.set_defaults(run=optimize_command)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    warnings.formatwarning = _warning
    try:
        return args.run(args)
    except BrokenPipeError:  # the reader left (e.g. `| head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (FlextopError, OSError, KeyboardInterrupt) as error:
        if args.debug:
            raise
        return _fail(error)


def _warning(message, category, *_: Any, **__: Any) -> str:
    """A warning as one line: ``flextop: warning: ...`` (no source line)."""
    return f"flextop: warning: {' '.join(str(message).split())}\n"


def _fail(error: BaseException) -> int:
    """One line on stderr and the exit code: 2 for a user error, 1 for a failed run or
    output, 130 for Ctrl-C."""
    if isinstance(error, KeyboardInterrupt):
        print("flextop: interrupted", file=sys.stderr)
        return 130
    if isinstance(error, OSError):
        print(f"flextop: error: {error.filename or ''}: {error.strerror or error}".replace(": : ", ": "), file=sys.stderr)
        return 1
    print(f"flextop: error: {' '.join(str(error).split())}", file=sys.stderr)
    return 1 if isinstance(error, (SimulationError, ExecutionError)) else 2


def _positive(kind: type) -> Any:
    """An argparse type: a finite ``kind`` above zero."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a {kind.__name__}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{text} must be above 0")
        return value
    parse.__name__ = f"positive {kind.__name__}"
    return parse


def _fraction(text: str) -> float:
    """An argparse type: a number in (0, 1]."""
    value = _positive(float)(text)
    if value > 1:
        raise argparse.ArgumentTypeError(f"{text} must be in (0, 1]")
    return value


def _cells(text: str) -> tuple[int, int]:
    """An argparse type: ``NXxNY``, two whole numbers above 0 (``20x6``)."""
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() and int(p) > 0 for p in parts):
        raise argparse.ArgumentTypeError(f"{text!r} is not NXxNY, two whole numbers above 0 (e.g. 20x6)")
    return int(parts[0]), int(parts[1])


def _open_fraction(text: str) -> float:
    """An argparse type: a number in (0, 1)."""
    value = _fraction(text)
    if value == 1:
        raise argparse.ArgumentTypeError(f"{text} must be in (0, 1)")
    return value


if __name__ == "__main__":
    sys.exit(main())
