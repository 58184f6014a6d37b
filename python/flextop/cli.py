"""The ``flextop`` command line.

``flextop demo``             the paper's robot arm at uniform density: tip error, d, a plot;
``flextop simulate SCENE``   run a scene file (TOML) and summarize it;
``flextop optimize SCENE``   topology optimization (see ``flextop optimize --help``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from . import scenes
from .errors import FlextopError, SettingsError
from .optimizers import OptimizerState, optimize
from .problems import TopologyProblem, volume_constraints
from .scene import Scene
from .simulation import Results, Simulation


def _design(sim: Simulation, x: float | None, design: Path | None) -> np.ndarray | None:
    if design is not None:
        return np.load(design) if design.suffix == ".npy" else np.loadtxt(design)
    return None if x is None else np.full(sim.n_design, x)


def _summarize(sim: Simulation, res, elapsed: float) -> None:
    if res.discretization is not None:
        errors = ", ".join(f"{name} {error:.2%}" for name, error in res.errors.items())
        print(f"to rtol = {sim.rtol:g}: {res.discretization}; estimated relative error {errors}")
    if isinstance(res, Results):
        newton = res.newton
        steps = f"h = {res.raw['h']} s" if np.ptp(res.steps) == 0 else f"h = {res.steps.min():.3g} … {res.steps.max():.3g} s"
        print(f"{len(res.time) - 1} steps of {steps} to t = {res.time[-1]:.4g} s in {elapsed * 1e3:.1f} ms "
              f"({newton['total']} Newton iterations, at most {newton['max']} per step)")
        if sim.tip is not None:
            error = np.linalg.norm(res.tip_error(), axis=1)
            print(f"tip '{sim.node_names[sim.tip]}': max |r - r_rigid| = {error.max() * 1e3:.3f} mm, "
                  f"mean squared tip deflection d = {res.tip_deflection():.6e} m^2")
        print(f"mean compliance = {res.response('compliance'):.6g} J")
    else:
        print(f"static equilibrium in {elapsed * 1e3:.1f} ms ({res.newton['total']} Newton iterations, "
              f"{res.newton['load_steps']} load steps); compliance F^T u = {res.response('compliance'):.6g} J")


def demo(args: argparse.Namespace) -> int:
    """The robot arm of paper Section 4 at x = 0.4 on every bar."""
    from .plots import plot_tip_error

    sim = Simulation(scenes.robot_arm(split=args.split))
    print(f"robot arm: 2 links × 74 bars, {sim.n_design} design variables, x = {args.x} everywhere, "
          f"generalized-alpha rho_inf = 0.8")
    start = time.perf_counter()
    res = sim.run(args.x, h=args.h)
    _summarize(sim, res, time.perf_counter() - start)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    plot_tip_error(res, path=out / "tip_error.png", labels=(f"x = {args.x} on every bar",))
    print(f"wrote {out / 'tip_error.png'}")
    return 0


def simulate(args: argparse.Namespace) -> int:
    """Runs a scene file."""
    sim = Simulation(args.scene, accuracy=args.accuracy, rtol=args.rtol)
    settings = {k: v for k, v in {"t_end": args.t_end, "h": args.h, "rho_inf": args.rho_inf, "mass": args.mass,
                                  "local_tol": args.local_tol}.items() if v is not None}
    if args.rtol is not None and args.h is not None:
        raise SettingsError("give --h (a fixed step) or --rtol (steps chosen to meet it), not both")
    if sim.analysis == "static":
        settings = {k: v for k, v in settings.items() if k in ("t_end", "local_tol")}
    start = time.perf_counter()
    res = sim.run(_design(sim, args.x, args.design), **settings)
    _summarize(sim, res, time.perf_counter() - start)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        np.savez(out / "results.npz", **{k: v for k, v in res.raw.items() if isinstance(v, np.ndarray)})
        print(f"wrote {out / 'results.npz'}")
    return 0


def _scene(spec: str) -> Scene:
    """A scene file, or the name of a built-in scene (``robot_arm``, ``static_truss``)."""
    if not Path(spec).exists() and hasattr(scenes, spec):
        return getattr(scenes, spec)()
    return Scene.from_toml(spec)


def _write_json(path: Path, data: dict) -> None:
    """Writes atomically, so an interrupted run never leaves half a checkpoint."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data))
    os.replace(tmp, path)


def _settings(args: argparse.Namespace) -> dict:
    return {k: v for k, v in {"h": args.h, "rho_inf": args.rho_inf, "t_end": args.t_end}.items() if v is not None}


def optimize_command(args: argparse.Namespace) -> int:
    """Topology optimization of a scene with checkpoints, progress bar, summary and plots."""
    out = Path(args.out)
    checkpoint = out / "checkpoint.json"
    if args.resume:
        if not checkpoint.exists():
            raise FileNotFoundError(f"no checkpoint to resume in {out}")
        saved = json.loads(checkpoint.read_text())
        scene = Scene.from_dict(saved["scene"])
        sim = Simulation(scene, accuracy=saved.get("accuracy"))
        problem = TopologyProblem.from_dict(sim, saved["problem"])
        options = {**saved["optimizer"], "max_iter": args.max_iter or saved["optimizer"]["max_iter"]}
        x0 = np.array(saved["x0"])
        state = OptimizerState.from_dict(saved["state"])
        print(f"resuming {checkpoint} at iteration {state.iteration}")
    else:
        scene = _scene(args.scene)
        sim = Simulation(scene, accuracy=args.accuracy)
        constraints = volume_constraints(sim, args.volume_fraction, per_component=not args.global_volume)
        if args.rtol is not None and args.h is not None:
            raise SettingsError("give --h (a fixed step) or --rtol (steps chosen to meet it), not both")
        problem = TopologyProblem(sim, args.objective, constraints, settings=_settings(args), rtol=args.rtol)
        options = {"method": args.method, "max_iter": args.max_iter or 30, "move": args.move, "kkt_tol": args.kkt_tol, "xtol": args.xtol}
        x0 = np.full(sim.n_design, args.x0)
        state = None
        out.mkdir(parents=True, exist_ok=True)
    print(f"{scene.to_dict().get('name') or 'scene'}: minimize {problem.objective} over {sim.n_design} densities "
          f"subject to {', '.join(f'{n} <= {b:.4g}' for n, b in problem.constraints) or 'bounds only'} ({options['method']})")

    bar = tqdm(total=options["max_iter"], initial=0 if state is None else state.iteration, unit="it", desc="optimize", file=sys.stderr)

    def on_iteration(record) -> None:
        _write_json(checkpoint, {"scene": scene.to_dict(), "accuracy": sim.accuracy, "problem": problem.to_dict(), "optimizer": options,
                                 "x0": x0.tolist(), "state": record.state.to_dict()})
        bar.update(1)
        bar.set_postfix(f=f"{record.f0 * problem.objective_scale:.4g}", g=f"{np.max(record.g, initial=-np.inf):+.2e}", change=f"{record.change:.3f}")

    start = time.perf_counter()
    try:
        result = optimize(problem, x0, options["method"], max_iter=options["max_iter"], move=options["move"],
                          kkt_tol=options["kkt_tol"], xtol=options["xtol"], callback=on_iteration, state=state)
    except KeyboardInterrupt:
        bar.close()
        print(f"interrupted; the last iteration is saved: resume with `flextop optimize --resume --out {out}`")
        return 130
    bar.close()
    elapsed = time.perf_counter() - start
    _report(problem, result, elapsed, result.nit - (0 if state is None else state.iteration))
    np.save(out / "design.npy", result.x)
    _write_json(out / "history.json", {"history": [r.to_dict() for r in result.history], "status": result.status.name,
                                       "message": result.message, "objective_scale": problem.objective_scale})
    if not args.no_plots:
        _pictures(sim, problem, result, x0, out, animate=args.animate)
    return 0 if result.success or result.status.name == "MAX_ITER" else 1


def _report(problem: TopologyProblem, result, elapsed: float, session: int) -> None:
    """The final summary table; `session` iterations ran in this call (the time shares)."""
    scale = problem.objective_scale
    print(f"\n{'it':>4} {problem.objective:>16} {'max g':>10} {'change':>8} {'KKT':>9}")
    for r in result.history:
        print(f"{r.iteration:>4} {r.f0 * scale:>16.6g} {np.max(r.g, initial=-np.inf):>10.2e} {r.change:>8.4f} {r.kkt:>9.2e}")
    initial = scale  # the objective is scaled by its value at the start design
    print(f"\nstatus: {result.status.name} — {result.message}")
    print(f"{problem.objective}: {initial:.6g} at the start → {result.fun * scale:.6g} "
          f"({100 * (result.fun * scale / initial - 1):+.1f} %) after {result.nit} iterations, {result.nfev} evaluations")
    for (name, bound), g in zip(problem.constraints, result.constr):
        print(f"{name}: {(g + 1) * bound:.6g} (bound {bound:.6g})")
    if problem.refinements:
        at = ", ".join(f"{d.refinement}×/{d.steps} steps at evaluation {k}" for k, d in problem.refinements)
        print(f"to rtol = {problem.rtol or sim.rtol:g}: discretizations {at}")
    solve = sum(r.solve_time for r in result.history[-session:]) if session else 0.0
    shares = {"simulation": problem.timings["simulation"], "gradients": problem.timings["gradients"], "subproblem": solve}
    other = max(elapsed - sum(shares.values()), 0.0)
    print(f"time: {elapsed:.2f} s — " + ", ".join(f"{k} {100 * v / elapsed:.1f} %" for k, v in {**shares, "other": other}.items()))


def _pictures(sim: Simulation, problem: TopologyProblem, result, x0: np.ndarray, out: Path, *, animate: bool) -> None:
    from .plots import animate as animation, plot_design, plot_history, plot_tip_error

    plot_design(sim, x0, path=out / "design_initial.png", title="initial design")
    plot_design(sim, result.x, path=out / "design.png", title=f"optimized: {problem.objective}")
    if result.history:
        plot_history(result.history, path=out / "history.png", objective_label=f"{problem.objective} (scaled)",
                     constraint_labels=[n for n, _ in problem.constraints])
    written = ["design_initial.png", "design.png", "history.png"]
    if sim.analysis == "dynamic" and sim.tip is not None:
        tolerance = {"rtol": problem.rtol} if problem.rtol else {}
        before, after = sim.run(x0, **tolerance, **problem.settings), sim.run(result.x, **tolerance, **problem.settings)
        plot_tip_error(before, after, path=out / "tip_error.png")
        written.append("tip_error.png")
        if animate:
            animation(after, out / "motion.gif", x=result.x)
            written.append("motion.gif")
    print(f"wrote {', '.join(str(out / w) for w in written)}")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="flextop", description="Flexible multibody dynamics and topology optimization of moving machines.")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="run the paper's robot arm and plot its tip error")
    d.add_argument("--x", type=float, default=0.4, help="density of every bar (default 0.4)")
    d.add_argument("--h", type=float, default=0.02, help="step size in s (default 0.02)")
    d.add_argument("--split", type=int, default=1, help="elements per bar (default 1)")
    d.add_argument("--out", default="demo_out", help="output folder (default demo_out)")
    d.set_defaults(run=demo)
    s = sub.add_parser("simulate", help="run a scene file")
    s.add_argument("scene", type=Path, help="TOML scene file")
    s.add_argument("--x", type=float, help="uniform density of every bar (default: full density)")
    s.add_argument("--design", type=Path, help="design vector file (.npy or text)")
    s.add_argument("--t-end", type=float)
    s.add_argument("--h", type=float)
    s.add_argument("--rho-inf", type=float)
    s.add_argument("--mass", choices=["consistent", "lumped"])
    s.add_argument("--accuracy", choices=["fast", "balanced", "accurate"], help="accuracy preset (see flextop.accuracy)")
    s.add_argument("--rtol", type=float, help="relative tolerance on d (or compliance): steps and elements per bar chosen to meet it")
    s.add_argument("--local-tol", type=float, help="variable steps by local error control (relative to the model's size)")
    s.add_argument("--out", help="folder for results.npz")
    s.set_defaults(run=simulate)
    o = sub.add_parser("optimize", help="topology optimization of a scene (checkpointed, resumable)")
    o.add_argument("scene", nargs="?", default="robot_arm", help="TOML scene file or robot_arm / static_truss (default robot_arm)")
    o.add_argument("--objective", default="tip_deflection", help="response to minimize (default tip_deflection; e.g. compliance)")
    o.add_argument("--method", choices=["mma", "gcmma", "conlin"], default="mma")
    o.add_argument("--volume-fraction", type=float, default=0.4, help="V <= fraction * V_full (default 0.4)")
    o.add_argument("--global-volume", action="store_true", help="one volume constraint instead of one per component")
    o.add_argument("--x0", type=float, default=0.4, help="initial density of every bar (default 0.4)")
    o.add_argument("--max-iter", type=int, help="iterations in all, resumed ones included (default 30)")
    o.add_argument("--move", type=float, default=0.2, help="move limit as a fraction of the bounds (default 0.2)")
    o.add_argument("--kkt-tol", type=float, default=1e-6)
    o.add_argument("--xtol", type=float, default=1e-4)
    o.add_argument("--h", type=float)
    o.add_argument("--rho-inf", type=float)
    o.add_argument("--t-end", type=float)
    o.add_argument("--accuracy", choices=["fast", "balanced", "accurate"], help="accuracy preset (see flextop.accuracy)")
    o.add_argument("--rtol", type=float, help="relative tolerance on every response of every evaluation (see TopologyProblem)")
    o.add_argument("--out", default="runs/optimize", help="folder for checkpoint, design, history and plots")
    o.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    o.add_argument("--no-plots", action="store_true")
    o.add_argument("--animate", action="store_true", help="also write motion.gif of the optimized design")
    o.set_defaults(run=optimize_command)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        return args.run(args)
    except (FlextopError, FileNotFoundError) as error:
        print(f"flextop: error: {error}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader left (e.g. `| head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1


if __name__ == "__main__":
    sys.exit(main())
