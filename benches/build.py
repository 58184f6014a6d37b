"""Building a scene: the time of ``flextop.Simulation(scene)`` (the scene checked and
converted, the engine's model built, the mechanism analysed) against its number of rigid
bodies n, for three mechanisms under gravity:

* **pinned** — n bodies, each pinned to the ground at its own point (n pendulums);
* **chain** — a hinge chain of n bodies, the first pinned (a tree, mobility n);
* **closed** — a zig-zag hinge chain pinned at both ends (one loop through the ground,
  mobility n − 2; a straight one would be at a dead centre, its end pin redundant).

The engine's part alone is ``flextop._core.Model.from_dict(spec)`` (the dict read, the
model built and checked); the rest of a Simulation is Python's (the scene copied, the
mechanism described, the plausibility checks). The growth exponent between two sizes is
``log(t₂/t₁) / log(n₂/n₁)``. A kind's larger sizes are skipped once one of its builds took
longer than ``--budget`` seconds.

    python benches/build.py [--sizes 100 300 1000 3000 10000] [--budget 60] [--repeat 3] [--kinds ...]
                            [--output build.md]
"""

from __future__ import annotations

import argparse
import gc
import math
import time
from pathlib import Path

import flextop

KINDS = {
    "pinned": "n bodies, each pinned at its own point",
    "chain": "hinge chain, the first body pinned",
    "closed": "zig-zag hinge chain, pinned at both ends (one loop)",
}


def scene(kind: str, n: int) -> flextop.Scene:
    """The ``kind`` mechanism of ``n`` unit bodies (1 kg, 0.1 kg m², 1 m long) under gravity."""
    s = flextop.Scene(f"{kind}_{n}", gravity=(0.0, -9.81))
    if kind == "pinned":
        for k in range(n):
            s.rigid_body(f"b{k}", mass=1.0, inertia=0.1, position=(2.0 * k, 0.0), points={"p": (0.0, 0.5)})
            s.pin(f"p{k}", f"b{k}.p")
    else:
        rise = 0.25 if kind == "closed" else 0.0
        for k in range(n):
            left, right = (k, rise * (k % 2)), (k + 1, rise * ((k + 1) % 2))
            centre = ((left[0] + right[0]) / 2, (left[1] + right[1]) / 2)
            s.rigid_body(f"b{k}", mass=1.0, inertia=0.1, position=centre,
                         points={"l": (left[0] - centre[0], left[1] - centre[1]), "r": (right[0] - centre[0], right[1] - centre[1])})
        s.pin("p0", "b0.l")
        for k in range(1, n):
            s.hinge(f"h{k}", f"b{k - 1}.r", f"b{k}.l")
        if kind == "closed":
            s.pin("end", f"b{n - 1}.r")
    s.simulation(t_end=0.01, h=0.001)
    return s


def least_time(build, repeat: int) -> tuple[float, object]:
    """The least seconds of ``repeat`` calls of ``build`` (the machine's other work only
    ever adds), and what the last returned."""
    best = float("inf")
    for _ in range(repeat):
        gc.collect()
        start = time.perf_counter()
        built = build()
        best = min(best, time.perf_counter() - start)
    return best, built


def exponent(previous: tuple[int, float, float] | None, n: int, seconds: float, column: int) -> str:
    """``log(t₂/t₁) / log(n₂/n₁)`` from the ``previous`` size's time in ``column`` to
    ``seconds`` at ``n``; blank for the first size."""
    if previous is None:
        return ""
    return f"{math.log(seconds / previous[column]) / math.log(n / previous[0]):.2f}"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 300, 1000, 3000, 10000])
    parser.add_argument("--budget", type=float, default=60.0, help="skip a kind's larger sizes after a build this long (s)")
    parser.add_argument("--repeat", type=int, default=3, help="builds of each scene, the least time kept")
    parser.add_argument("--kinds", nargs="+", default=list(KINDS), choices=list(KINDS))
    parser.add_argument("--output", default="build.md", help="file name in benches/results/")
    args = parser.parse_args()
    lines = [f"Command: `python benches/build.py --sizes {' '.join(map(str, args.sizes))} --budget {args.budget:g} "
             f"--repeat {args.repeat}` — time of `flextop.Simulation(scene)`, and of the engine's part alone "
             f"(`flextop._core.Model.from_dict`: the dict read, the model built and checked), the least of {args.repeat} "
             "builds each", "",
             "| mechanism | n | Simulation (s) | growth exponent | engine (s) | growth exponent | mobility | redundant rows |",
             "|---|---|---|---|---|---|---|---|"]
    for kind in args.kinds:
        label = KINDS[kind]
        previous = None
        for n in args.sizes:
            if previous is not None and previous[1] > args.budget:
                lines.append(f"| {label} | {n} | — (skipped) | | | | | |")
                print(lines[-1], flush=True)
                continue
            spec = scene(kind, n).to_dict()
            seconds, sim = least_time(lambda: flextop.Simulation(spec), args.repeat)
            engine, _ = least_time(lambda: flextop._core.Model.from_dict(spec), args.repeat)
            growth = [exponent(previous, n, seconds, 1), exponent(previous, n, engine, 2)]
            mechanism = sim.mechanism
            lines.append(f"| {label} | {n} | {seconds:.3f} | {growth[0]} | {engine:.3f} | {growth[1]} | "
                         f"{mechanism['mobility']} | {mechanism['redundant_rows']} |")
            print(lines[-1], flush=True)
            previous = (n, seconds, engine)
    text = "\n".join(lines)
    (Path(__file__).parent / "results" / args.output).write_text(text + "\n")


if __name__ == "__main__":
    main()
