"""Motor effort: the robot arm minimizing tip deflection with a limit on a motor's peak
torque, and what the limit costs.

The arm's tip-deflection problem (V ≤ 0.4 V per link), MMA from the unconstrained optimum
of 50 iterations (continuation), 50 more with ``("torque:JOINT", limit)`` — the p-mean
(p = 8) of the drive's torque over the motion, normalized to its peak (Le et al.) — at
limits below the unconstrained optimum's peak on the converged structure; then, as for
stresses (benches/stress.py), 25 more with the limit at target/(κ(1 + 0.005)), κ the
converged peak over the model's at the first stage's design. Each design is judged on the
converged structure (rtol 3e-3): d, the peak and RMS torques of both drives.

    python benches/motor.py   # writes benches/results/motor.md
"""

from __future__ import annotations

import platform
import time
from pathlib import Path

import flextop
from flextop.problems import TopologyProblem, robot_arm_problem, tightened

ROOT = Path(__file__).resolve().parents[1]
TORQUES = ["torque:shoulder", "torque:elbow", "torque_rms:shoulder", "torque_rms:elbow"]


def judged(sim: flextop.Simulation, x) -> dict[str, float]:
    run = sim.run(x, rtol=3e-3, responses=["tip_deflection"])
    return {"d": run.response("tip_deflection"), "peak shoulder": run.peak("torque:shoulder"),
            "peak elbow": run.peak("torque:elbow"), "rms shoulder": run.response("torque_rms:shoulder"),
            "rms elbow": run.response("torque_rms:elbow")}


def main() -> None:
    base = robot_arm_problem("tip_deflection")
    sim = base.simulation
    start = flextop.optimize(base, 0.4, "mma", max_iter=50).x
    free = judged(sim, start)
    out = ["# Motor effort", "", f"`python benches/motor.py` on {platform.machine()}, {platform.python_version()}.", "",
           "Robot arm, tip deflection, V ≤ 0.4 V per link; MMA, 50 iterations from the unconstrained optimum, then 25 "
           "with the limit at target/(κ(1 + 0.005)). "
           "Judged on the converged structure (rtol 3e-3 on d).", "",
           "| problem | time (s) | iterations (both stages) | d converged (m²) | shoulder peak / RMS (N m) | elbow peak / RMS (N m) | message |",
           "|---|---|---|---|---|---|---|",
           f"| unconstrained | — | — | {free['d']:.4e} | {free['peak shoulder']:.2f} / {free['rms shoulder']:.2f} | "
           f"{free['peak elbow']:.2f} / {free['rms elbow']:.2f} | |"]
    print(out[-1], flush=True)
    for joint, fraction in (("shoulder", 0.97), ("shoulder", 0.94), ("elbow", 0.97)):
        limit = fraction * free[f"peak {joint}"]
        problem = TopologyProblem(sim, "tip_deflection", [*base.constraints, (f"torque:{joint}", limit)])
        clock = time.perf_counter()
        first = flextop.optimize(problem, start, "mma", max_iter=50)
        problem, kappa = tightened(problem, first.x, rtol=1e-2, targets={f"torque:{joint}": limit}, margin=5e-3)
        result = flextop.optimize(problem, first.x, "mma", max_iter=25)
        seconds = time.perf_counter() - clock
        truth = judged(sim, result.x)
        out.append(f"| {joint} peak ≤ {limit:.2f} N m ({fraction:.0%} of the unconstrained; κ {kappa[f'torque:{joint}']:.3f}) | "
                   f"{seconds:.1f} | {first.nit} + {result.nit} | "
                   f"{truth['d']:.4e} | {truth['peak shoulder']:.2f} / {truth['rms shoulder']:.2f} | "
                   f"{truth['peak elbow']:.2f} / {truth['rms elbow']:.2f} | {result.message.split(';')[0][:60]} |")
        print(out[-1], flush=True)
    (ROOT / "benches" / "results" / "motor.md").write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
