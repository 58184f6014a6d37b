"""The spatial example machines' figures (``docs/spatial_*.png``): each scene of
:mod:`flextop.scenes` seen in 3D with its tip's path against the rigid one.

1. The spatial robot arm (``spatial_robot_arm``, 188 bars): its tip deflection (Eq. 40)
   minimized at 40 % of its volume by plain MMA for 100 iterations from the uniform design
   on the scene's grid (the "A hundred iterations" row of BENCHMARKS.md), the design drawn
   with each bar's width and colour by density at the start and at the end of the motion,
   and its payload's path against the rigid one.
2. The spatial slider-crank (``spatial_slider_crank``, rigid bodies): its slider's path.
3. The paper's arm as 3D lattices (``spatial_paper_arm``, 746 bars, the payload 5 cm off the
   links' plane), uniform at 0.4: the design and the payload's path, out of the plane.

    python benches/spatial_figures.py   # about a minute
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

import flextop  # noqa: E402
from flextop.optimizers import MMA  # noqa: E402
from flextop.plots import plot_spatial_design, plot_spatial_paths  # noqa: E402
from flextop.problems import SpatialProblem  # noqa: E402

DOCS = Path(__file__).resolve().parents[1] / "docs"


def robot_arm() -> None:
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm())
    problem = SpatialProblem(sim, "tip_deflection", volume=0.4)
    result = flextop.optimize(problem, np.full(sim.n_design, 0.4), method=MMA(safeguard=False), max_iter=100,
                              kkt_tol=1e-4)
    run = sim.simulate(result.x)
    title = (f"spatial robot arm: tip deflection {result.fun:.3f} of the uniform design's\n"
             f"(100 MMA iterations, KKT {result.kkt:.1e})")
    plot_spatial_design(sim, result.x, title=title + ", t = 0", path=DOCS / "spatial_robot_arm_design.png")
    plot_spatial_design(sim, result.x, q=run.q[-1], title=f"the same design at t = {run.time[-1]:.1f} s",
                        path=DOCS / "spatial_robot_arm_design_end.png")
    plot_spatial_paths(run, sim.rigid_trajectory(), "payload", title="the optimized arm's payload",
                       path=DOCS / "spatial_robot_arm_paths.png")
    print(f"spatial robot arm: d / uniform {result.fun:.4f}, KKT {result.kkt:.2e}, {result.nit} iterations")


def slider_crank() -> None:
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_slider_crank())
    run = sim.simulate(None)
    plot_spatial_paths(run, sim.rigid_trajectory(), "slider", title="spatial slider-crank: its slider (rigid bodies)",
                       path=DOCS / "spatial_slider_crank_paths.png")
    print("spatial slider-crank: drawn")


def paper_arm() -> None:
    sim = flextop.SpatialSimulation(flextop.scenes.spatial_paper_arm())
    x = np.full(sim.n_design, 0.4)
    run = sim.simulate(x)
    plot_spatial_design(sim, x, title="the paper's arm as 3D lattices, uniform 0.4",
                        path=DOCS / "spatial_paper_arm_design.png")
    plot_spatial_paths(run, sim.rigid_trajectory(), "payload", title="its payload, 5 cm off the links' plane",
                       path=DOCS / "spatial_paper_arm_paths.png")
    print("the paper's arm in 3D: drawn")


if __name__ == "__main__":
    robot_arm()
    slider_crank()
    paper_arm()
