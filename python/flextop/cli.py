"""The ``flextop`` command line.

``flextop demo``             the paper's robot arm at uniform density: tip error, d, a plot;
``flextop simulate SCENE``   run a scene file (TOML) and summarize it;
``flextop optimize SCENE``   topology optimization (see ``flextop optimize --help``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from . import scenes
from .errors import FlextopError
from .simulation import Results, Simulation


def _design(sim: Simulation, x: float | None, design: Path | None) -> np.ndarray | None:
    if design is not None:
        return np.load(design) if design.suffix == ".npy" else np.loadtxt(design)
    return None if x is None else np.full(sim.n_design, x)


def _summarize(sim: Simulation, res, elapsed: float) -> None:
    if isinstance(res, Results):
        newton = res.newton
        print(f"{len(res.time) - 1} steps of h = {res.raw['h']} s to t = {res.time[-1]:.4g} s in {elapsed * 1e3:.1f} ms "
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
    sim = Simulation(args.scene)
    settings = {k: v for k, v in {"t_end": args.t_end, "h": args.h, "rho_inf": args.rho_inf, "mass": args.mass}.items() if v is not None}
    if sim.analysis == "static":
        settings = {k: v for k, v in settings.items() if k == "t_end"}
    start = time.perf_counter()
    res = sim.run(_design(sim, args.x, args.design), **settings)
    _summarize(sim, res, time.perf_counter() - start)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        np.savez(out / "results.npz", **{k: v for k, v in res.raw.items() if isinstance(v, np.ndarray)})
        print(f"wrote {out / 'results.npz'}")
    return 0


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
    s.add_argument("--out", help="folder for results.npz")
    s.set_defaults(run=simulate)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        return args.run(args)
    except (FlextopError, FileNotFoundError) as error:
        print(f"flextop: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
