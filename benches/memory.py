"""Peak memory of a run with gradients on the largest ground structure of the benchmarks
(robot arm, 21 × 5 grid per link, 6664 design variables), adjoint storing every state vs
adjoint with checkpoints, against a plain run — each in a fresh process, peak resident set
size from the kernel (``ru_maxrss``), minus the process's size before the run.

    python benches/memory.py [--split 4] [--h 0.005]     # writes benches/results/memory.md
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

CASES = {
    "plain run (no gradients; returns q, q̇, q̈, λ of every step)": None,
    "adjoint, every state stored": "store",
    "adjoint, checkpoints every ⌈√N⌉ steps": "checkpoints",
}


def child(memory: str | None, split: int, h: float) -> None:
    import numpy as np

    import flextop

    sim = flextop.Simulation(flextop.scenes.robot_arm(nx=21, ny=5, split=split))
    x = np.full(sim.n_design, 0.4)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.perf_counter()
    if memory is None:
        value = sim.run(x, h=h).tip_deflection()
    else:
        f, g = sim.run_with_sensitivities(x, ["tip_deflection"], method="adjoint", memory=memory, h=h)
        value = float(f[0])
    elapsed = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(json.dumps({"before_kib": before, "peak_kib": peak, "seconds": elapsed, "d": value, "dofs": sim.model.n_dofs,
                      "n": sim.n_design, "steps": round(1.3 / h)}))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--split", type=int, default=4)
    parser.add_argument("--h", type=float, default=0.005)
    parser.add_argument("--child", default=None)
    args = parser.parse_args()
    if args.child is not None:
        child(None if args.child == "none" else args.child, args.split, args.h)
        return
    rows = []
    for label, memory in CASES.items():
        out = subprocess.run([sys.executable, __file__, "--child", memory or "none", "--split", str(args.split), "--h", str(args.h)],
                             capture_output=True, text=True, check=True)
        rows.append((label, json.loads(out.stdout.strip().splitlines()[-1])))
    first = rows[0][1]
    n_q, steps = first["dofs"], first["steps"]
    stored = 2 * n_q * (steps + 1) * 8 / 2**20
    lines = [
        f"Command: `python benches/memory.py --split {args.split} --h {args.h}` — robot arm, 21 × 5 grid per link, split = {args.split}, "
        f"{first['n']} design variables, {n_q} DOFs, {steps} steps, x = 0.4, response tip_deflection",
        "",
        "| run | peak RSS increase (MiB) | time (s) | d (m²) |",
        "|---|---|---|---|",
    ]
    for label, r in rows:
        d = "—" if r["d"] is None else f"{r['d']:.6e}"
        lines.append(f"| {label} | {(r['peak_kib'] - r['before_kib']) / 1024:.0f} | {r['seconds']:.1f} | {d} |")
    lines += ["", f"Stored positions and accelerations of every step: 2 × {n_q} × {steps + 1} doubles = {stored:.0f} MiB; "
              f"the direct method would carry 4 × {n_q} × {first['n']} doubles of state sensitivities "
              f"= {4 * n_q * first['n'] * 8 / 2**30:.1f} GiB."]
    text = "\n".join(lines)
    print(text)
    (Path(__file__).parent / "results" / "memory.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
