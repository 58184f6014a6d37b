"""Scenarios and batches on executors: throughput, overhead, a multi-scenario optimization,
and the paper's arm designed for three motions and three payloads.

    python benches/scenarios.py            # writes benches/results/scenarios.md and docs/robust_arm.png

1. Throughput: six scenarios of the arm (three motions × payloads 2.5 and 5 kg), each
   evaluation one run with gradients per scenario, serial and on 2 workers: a process
   pool, a thread pool, a Dask LocalCluster (2 worker processes, 1 thread each); one
   evaluation at a time and as a batch, 1, 3 or 6 runs to a task.
2. Overhead per task: empty tasks (``abs``) through each executor, and the arm's task
   time measured inside the worker, for the scaling estimate of BENCHMARKS.md.
3. A 6-scenario worst-case optimization of the arm (148 densities, 50 MMA iterations)
   serially and on each executor.
4. The robust arm: nine scenarios (three motions × 0, 2.5, 5 kg), worst tip deflection
   started from the weighted-sum optimum, V ≤ 0.4 V per link, against the single-scenario
   (reference motion, 5 kg) optimum, the weighted sum and the worst case from x = 0.4:
   every scenario's d at each design.
"""

from __future__ import annotations

import platform
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import flextop  # noqa: E402
from flextop.plots import plot_design  # noqa: E402
from flextop.problems import ScenarioProblem, evaluate, robust_robot_arm  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
REPEAT = 10


def six():
    return [c for c in robust_robot_arm() if not c.name.endswith(" 0 kg")]


def throughput(executor, cases, x, chunksize=1, batch=False) -> float:
    """Scenario runs (with gradients) per second over ``REPEAT`` designs of every scenario:
    one design after the other as an optimizer asks for them, or (``batch``) all at once as
    a parameter study does. Every design is new (Dask computes identical tasks once); best
    of three rounds."""
    evaluate(cases, [x], "tip_deflection", executor=executor)  # warm: every worker builds its scenes
    best = np.inf
    for round in range(3):
        designs = [x * (1.0 - 1e-4 * (round * REPEAT + k + 1 + 1000 * chunksize + 100 * batch)) for k in range(REPEAT)]
        start = time.perf_counter()
        for group in [designs] if batch else [[d] for d in designs]:
            evaluate(cases, group, "tip_deflection", executor=executor, chunksize=chunksize)
        best = min(best, time.perf_counter() - start)
    return len(cases) * REPEAT / best


def empty_task_seconds(executor, n=400) -> float:
    futures = [executor.submit(abs, -k) for k in range(20)]
    [f.result() for f in futures]
    start = time.perf_counter()
    futures = [executor.submit(abs, -k) for k in range(n)]
    [f.result() for f in futures]
    return (time.perf_counter() - start) / n


def executors():
    """Name → a context manager of an executor with 2 workers."""
    def dask():
        import distributed

        class Cluster:
            def __enter__(self):
                self.cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
                self.client = distributed.Client(self.cluster)
                return self.client.get_executor()

            def __exit__(self, *exc):
                self.client.close()
                self.cluster.close()
        return Cluster()

    return {"process pool": lambda: ProcessPoolExecutor(2, mp_context=get_context("spawn")),
            "thread pool": lambda: ThreadPoolExecutor(2), "Dask LocalCluster": dask}


def parallel_table(lines: list[str]) -> None:
    cases = six()
    x = np.full(flextop.Simulation(cases[0].scene).n_design, 0.4)
    serial = throughput(None, cases, x)
    task = 1.0 / serial
    batch = throughput(None, cases, x, batch=True)
    lines += ["## Six scenarios on 2 workers", "",
              f"Six scenarios of the arm at x = 0.4, one run with gradients each (adjoint), for {REPEAT} designs: one design "
              "after the other as an optimizer asks for them (each evaluation waits for its six runs), or all designs at once "
              "as a parameter study does (a batch of 60 runs); best of three rounds. Chunk: runs per task.", "",
              "| executor | chunk | per evaluation: runs / s | speed-up | batch: runs / s | speed-up | empty task (ms) |",
              "|---|---|---|---|---|---|---|",
              f"| serial (this process) | — | {serial:.1f} | 1.00 | {batch:.1f} | 1.00 | — |"]
    for name, make in executors().items():
        with make() as ex:
            empty = empty_task_seconds(ex)
            for chunk in (1, 3, 6):
                rate, rate_batch = throughput(ex, cases, x, chunk), throughput(ex, cases, x, chunk, batch=True)
                lines.append(f"| {name} | {chunk} | {rate:.1f} | {rate / serial:.2f} | {rate_batch:.1f} | {rate_batch / batch:.2f} | "
                             f"{empty * 1e3:.3f} |")
                print(lines[-1], flush=True)
    lines += ["", f"One scenario run with gradients takes {task * 1e3:.1f} ms serially.", ""]


def optimization_table(lines: list[str]) -> None:
    cases = six()
    volumes = flextop.volume_constraints(flextop.Simulation(cases[0].scene), 0.4)
    lines += ["## A six-scenario optimization", "", "Worst tip deflection of the six scenarios, V ≤ 0.4 V per link, MMA, "
              "50 iterations from x = 0.4 (chunks of 3 scenarios on processes and Dask).", "",
              "| executor | seconds | final worst d (m²) |", "|---|---|---|"]
    runs = {"serial": (_Nothing, 1), "thread pool, 2 workers": (lambda: ThreadPoolExecutor(2), 1),
            "process pool, 2 workers": (lambda: ProcessPoolExecutor(2, mp_context=get_context("spawn")), 3),
            "Dask LocalCluster, 2 workers": (executors()["Dask LocalCluster"], 3)}
    for name, (make, chunk) in runs.items():
        with make() as ex:
            if ex is not None:
                evaluate(cases, [np.full(148, 0.4)], "tip_deflection", executor=ex)  # workers up and scenes built
            problem = ScenarioProblem(cases, "tip_deflection", volumes, aggregate="worst", executor=ex, chunksize=chunk)
            start = time.perf_counter()
            result = flextop.optimize(problem, problem.start(np.full(problem.n - 1, 0.4)), "mma", max_iter=50)
            seconds = time.perf_counter() - start
        lines.append(f"| {name} | {seconds:.1f} | {result.fun:.4e} |")
        print(lines[-1], flush=True)
    lines.append("")


class _Nothing:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def robust_table(lines: list[str]) -> None:
    cases = robust_robot_arm()
    sim = flextop.Simulation(cases[0].scene)
    volumes = flextop.volume_constraints(sim, 0.4)
    x0 = np.full(sim.n_design, 0.4)
    with ThreadPoolExecutor(2) as pool:
        start = time.perf_counter()
        total = ScenarioProblem(cases, "tip_deflection", volumes, aggregate="sum", executor=pool)
        xsum = flextop.optimize(total, x0, "mma", max_iter=40).x
        worst = ScenarioProblem(cases, "tip_deflection", volumes, aggregate="worst", executor=pool)
        xr = flextop.optimize(worst, worst.start(xsum), "mma", max_iter=40).x[:-1]
        robust_seconds = time.perf_counter() - start
        cold = flextop.optimize(worst, worst.start(x0), "mma", max_iter=80).x[:-1]
        single_case = next(c for c in cases if c.name == "reference, 5 kg")
        single = flextop.TopologyProblem(flextop.Simulation(single_case.scene), "tip_deflection", volumes)
        xs = flextop.optimize(single, x0, "mma", max_iter=80).x
        designs = {"x = 0.4": x0, "single scenario": xs, "weighted sum": xsum, "worst case from x = 0.4": cold, "robust": xr}
        runs = evaluate(cases, list(designs.values()), "tip_deflection", gradients=False, executor=pool)
    lines += ["## The arm for three motions and three payloads", "",
              "Nine scenarios: the reference motion (π/3 → π/2, 0.5 rad/s, 2 rad/s²), the same twice as fast "
              "(1 rad/s, 8 rad/s², at h = 0.01 s) and a shorter move to 75° (π/3 → 5π/12), each with 0, 2.5 and 5 kg at "
              "the tip; V ≤ 0.4 V per link, MMA, from x = 0.4, on 2 threads. Designs: the paper's single-scenario optimum "
              "(reference motion, 5 kg; 80 iterations); the weighted sum of the nine (40 iterations); the worst case from "
              "x = 0.4 (80 iterations); and the robust design, the worst case started from the weighted-sum optimum "
              f"(40 + 40 iterations, {robust_seconds:.0f} s). Every scenario's d (m², each scene's own grid):", "",
              "| scenario | " + " | ".join(designs) + " |", "|---|" + "---|" * len(designs)]
    for c in cases:
        lines.append(f"| {c.name} | " + " | ".join(f"{r[c.name].values[0]:.3e}" for r in runs) + " |")
    lines += ["| **worst** | " + " | ".join(f"**{max(r[c.name].values[0] for c in cases):.3e}**" for r in runs) + " |", ""]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    plot_design(sim, xs, ax=axes[0], title="single scenario: reference motion, 5 kg")
    plot_design(sim, xr, ax=axes[1], title="robust: worst of 9 scenarios")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "robust_arm.png", dpi=120)
    lines += ["![single-scenario and robust designs](../../docs/robust_arm.png)", ""]


def main() -> None:
    lines = ["# Scenarios and batches", "", f"`python benches/scenarios.py` on {platform.processor() or platform.machine()}, "
             f"{platform.python_version()}, 2 cores.", ""]
    parallel_table(lines)
    optimization_table(lines)
    robust_table(lines)
    (ROOT / "benches" / "results" / "scenarios.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
