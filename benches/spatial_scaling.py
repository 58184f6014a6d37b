"""How the spatial robot arm's cost grows with its bars (``flextop.scenes.spatial_robot_arm``,
lattice links of ``nx × ny × nz`` nodes with ``diagonals``, from 100 to about 22,000 bars):
the build, a run, and a run with its adjoint gradient of ``∫U dt`` to every density, per
bar-step, and the exponent of each between sizes (``t ∝ bars^k``). Two families: slender
links (``ny = nz = 3``, ``nx`` growing: a chain of bays, the iteration matrix banded) and
deep ones (``nx = 30``, ``ny = nz`` growing: wider fronts). Medians of three runs of 20
steps of 10 ms at ``x = 0.5``.

With ``--profile``: where a run with its adjoint spends its time, from ``perf`` samples of
the largest slender arm, grouped by the engine's phases (perf must be installed).

    python benches/spatial_scaling.py [--profile]
"""

import math
import subprocess
import sys
import tempfile
import time
from collections import defaultdict

import numpy as np

import flextop
from flextop.scenes import spatial_robot_arm

STEPS, H = 20, 0.01
SLENDER = [(3, 2, 2), (5, 3, 3), (16, 3, 3), (50, 3, 3), (160, 3, 3)]
DEEP = [(30, 2, 2), (30, 3, 3), (30, 4, 4), (30, 5, 5)]

# Symbol fragments → phase, first match wins (perf's demangled Rust names).
PHASES = [
    ("sensitivity sweep", ("spatial::sensitivity", "solver::backward")),
    ("solves", ("BlockLu::solve", "triangular_solve", "solve_in_place", "solve_with_conj")),
    ("factorization", ("block_lu::", "Unsymmetric::factorize", "Ldlt::factorize", "cholesky", "permute_self_adjoint", "lu::", "ereach",
                       "sparse::utils::transpose", "pulp::", "gemm")),
    ("element kernels", ("spatial::beam", "spatial::truss", "group::so3", "group::pair", "nalgebra", "spatial::element",
                         "joint::spatial", "body::spatial", "spatial::force", "sin", "cos", "atan2")),
    ("the build (scene to model, pattern)", ("scene::spatial", "SpatialModel::add_", "Assembler::new", "memcmp",
                                             "sort::", "Sparsity::from_entries", "BlockLu::analyze")),
    ("assembly", ("spatial::assembly", "spatial::model", "memmove", "memset", "memcpy")),
    ("integrator", ("spatial::integrator", "group::Frame")),
]


def median_seconds(f, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def arm(nx: int, ny: int, nz: int) -> flextop.scenes.SpatialScene:
    return spatial_robot_arm(nx=nx, ny=ny, nz=nz, connectivity="diagonals", t_end=STEPS * H, h=H)


def table(name: str, sizes: list[tuple[int, int, int]]) -> None:
    print(f"\n{name}\n")
    print("| lattice | bars | unknowns | build (s) | run (s) | run + adjoint (s) | µs per bar-step (run + adjoint) "
          "| exponent of the build | of the run | of run + adjoint |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    previous = None
    for nx, ny, nz in sizes:
        build = median_seconds(lambda: flextop.SpatialSimulation(arm(nx, ny, nz)))
        sim = flextop.SpatialSimulation(arm(nx, ny, nz))
        x = np.full(sim.n_design, 0.5)
        run = median_seconds(lambda: sim.simulate(x))
        both = median_seconds(lambda: sim.run_with_sensitivities(x, "strain_energy", method="adjoint"))
        unknowns = 6 * len(sim.model.node_names) + sim.simulate(x, t_end=H).lam.shape[1]
        bars = sim.n_design
        exponents = ["", "", ""]
        if previous is not None:
            ratio = math.log(bars / previous[0])
            exponents = [f"{math.log(now / before) / ratio:.2f}" for now, before in zip((build, run, both), previous[1:])]
        print(f"| {nx} × {ny} × {nz} | {bars} | {unknowns} | {build:.3f} | {run:.3f} | {both:.3f} "
              f"| {1e6 * both / (bars * STEPS):.1f} | {' | '.join(exponents)} |")
        previous = (bars, build, run, both)


def profile() -> None:
    nx, ny, nz = SLENDER[-1]
    script = (f"import numpy as np, flextop, sys; sys.path.insert(0, 'benches'); from spatial_scaling import arm\n"
              f"sim = flextop.SpatialSimulation(arm({nx}, {ny}, {nz}))\n"
              f"x = np.full(sim.n_design, 0.5)\n"
              f"for _ in range(3): sim.run_with_sensitivities(x, 'strain_energy', method='adjoint')\n")
    with tempfile.NamedTemporaryFile(suffix=".data") as data:
        subprocess.run(["perf", "record", "-q", "-o", data.name, sys.executable, "-c", script], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        report = subprocess.run(["perf", "report", "-i", data.name, "--no-children", "--sort", "symbol", "--stdio"],
                                check=True, capture_output=True, text=True).stdout
    shares: dict[str, float] = defaultdict(float)
    for line in report.splitlines():
        parts = line.split()
        if not parts or not parts[0].endswith("%") or line.lstrip().startswith("#"):
            continue
        share, symbol = float(parts[0].rstrip("%")), " ".join(parts[2:])
        phase = next((p for p, keys in PHASES if any(k in symbol for k in keys)), "other (Python, the build, the allocator)")
        shares[phase] += share
    print(f"\nWhere a run with its adjoint spends its time: the {nx} × {ny} × {nz} arm, perf samples by phase\n")
    print("| phase | share of the samples (%) |")
    print("|---|---|")
    for phase, share in sorted(shares.items(), key=lambda kv: -kv[1]):
        print(f"| {phase} | {share:.1f} |")


if __name__ == "__main__":
    if "--profile" in sys.argv:
        profile()
    else:
        table("Slender links (a chain of bays)", SLENDER)
        table("Deep links (wider fronts)", DEEP)
