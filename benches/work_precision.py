"""Work–precision study: error against run time for the settings users trade every day.

For two cases — the reference robot arm (x = 0.4) and a single flexible beam spun up by
a driven hub — each setting (elements per bar m, step size h, spectral radius ρ∞, Newton
tolerance, consistent or lumped inertia) is run and compared with a converged reference:

* error of the tip trajectory: max over t of |r_tip − r_tip,ref| (m), on the times of the
  coarsest step size;
* error of d (paper Eq. 40), relative;
* error of the gradient ∇d, relative in the 2-norm;

against the wall time of a plain run (trajectory, d) and of a run with adjoint gradients
(∇d), best of three. Writes tables to benches/results/work_precision.md and plots (with the
Pareto fronts) to docs/work_precision_*.png.

    python benches/work_precision.py [--quick]
"""

from __future__ import annotations

import argparse
import itertools
import time
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import flextop  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Setting:
    m: int = 1
    h: float = 0.02
    rho_inf: float = 0.8
    tol: float = 1e-10
    mass: str = "consistent"

    def label(self) -> str:
        return f"m={self.m} h={self.h:g} ρ∞={self.rho_inf:g} tol={self.tol:.0e} {self.mass}"


@dataclass
class Case:
    name: str
    build: callable  # m -> Scene
    x: float
    t_end: float
    base: Setting
    compare_every: float  # trajectory compared at multiples of this time
    reference: Setting
    simulations: dict = field(default_factory=dict)

    def simulation(self, m: int) -> flextop.Simulation:
        if m not in self.simulations:
            self.simulations[m] = flextop.Simulation(self.build(m))
        return self.simulations[m]


def spun_beam(m: int) -> flextop.Scene:
    """The second scene (:func:`flextop.scenes.spun_beam`): eight bars spun up by a hub."""
    return flextop.scenes.spun_beam(split=m)


def timed(fn, repeats: int = 3):
    best, out = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def measure(case: Case, s: Setting, repeats: int) -> dict:
    sim = case.simulation(s.m)
    x = np.full(sim.n_design, case.x)
    opts = dict(h=s.h, t_end=case.t_end, rho_inf=s.rho_inf, tol=s.tol, mass=s.mass)
    t_run, res = timed(lambda: sim.run(x, **opts), repeats)
    t_grad, (f, g) = timed(lambda: sim.run_with_sensitivities(x, ["tip_deflection"], method="adjoint", **opts), repeats)
    tip = res.positions[:, sim.tip]
    every = int(round(case.compare_every / s.h))
    return {"setting": s, "t_run": t_run, "t_grad": t_grad, "d": float(f[0]), "grad": g[0], "tip": tip[::every],
            "newton": res.newton["total"]}


def errors(row: dict, ref: dict) -> dict:
    n = min(len(row["tip"]), len(ref["tip"]))
    return {"traj": float(np.max(np.linalg.norm(row["tip"][:n] - ref["tip"][:n], axis=1))),
            "d": abs(row["d"] / ref["d"] - 1.0),
            "grad": float(np.linalg.norm(row["grad"] - ref["grad"]) / np.linalg.norm(ref["grad"]))}


def settings_of(case: Case, quick: bool) -> list[Setting]:
    b = case.base
    ms = [1, 2, 4] if quick else [1, 2, 4, 8]
    hs = [2 * b.h, b.h, b.h / 2, b.h / 4] if not quick else [b.h, b.h / 2]
    out = [Setting(m, h) for m, h in itertools.product(ms, hs)]
    out += [Setting(m, h, mass="lumped") for m, h in itertools.product(ms, hs)]
    out += [Setting(1, b.h, rho_inf=r) for r in (0.0, 0.5, 0.9, 1.0)]
    out += [Setting(2, b.h / 2, rho_inf=r) for r in (0.0, 0.5, 0.9, 1.0)]
    out += [Setting(1, b.h, tol=t) for t in (1e-3, 1e-4, 1e-6, 1e-8, 1e-12)]
    out += [Setting(2, b.h / 2, tol=t) for t in (1e-3, 1e-4, 1e-6, 1e-8)]
    return list(dict.fromkeys(out))


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats in both time and error."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], np.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def study(case: Case, quick: bool) -> list[dict]:
    ref = measure(case, case.reference, 1)
    rows = []
    for s in settings_of(case, quick):
        row = measure(case, s, 1 if quick else 3)
        row.update(errors(row, ref))
        rows.append(row)
    return rows


def plot(case: Case, rows: list[dict], path: Path) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), layout="constrained")
    groups = {"consistent": "tab:blue", "lumped": "tab:orange"}
    for ax, (key, time_key, label) in zip(axes, [("traj", "t_run", "tip trajectory error (m)"), ("d", "t_run", "relative error of d"),
                                                  ("grad", "t_grad", "relative error of ∇d")]):
        pts = [(r[time_key], max(r[key], 1e-16)) for r in rows]
        for r, (t, e) in zip(rows, pts):
            s = r["setting"]
            marker = "o" if s.tol == 1e-10 and s.rho_inf == 0.8 else ("s" if s.tol != 1e-10 else "^")
            ax.scatter(t, e, c=groups[s.mass], marker=marker, s=22, alpha=0.8)
        front = pareto(pts)
        ax.plot([pts[i][0] for i in front], [pts[i][1] for i in front], "k-", lw=1, label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(("run" if time_key == "t_run" else "run with gradients") + " time (s)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    handles = [plt.Line2D([], [], color=c, marker="o", ls="", label=f"{k} mass (m, h)") for k, c in groups.items()]
    handles += [plt.Line2D([], [], color="gray", marker="^", ls="", label="ρ∞ varied"),
                plt.Line2D([], [], color="gray", marker="s", ls="", label="Newton tol varied"),
                plt.Line2D([], [], color="k", label="Pareto front")]
    axes[0].legend(handles=handles, fontsize=8)
    fig.suptitle(f"Work–precision: {case.name}")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(case: Case, rows: list[dict]) -> list[str]:
    lines = [f"### {case.name}", "", f"Reference: {case.reference.label()}; Pareto-optimal rows (for d against run time, or ∇d against gradient-run time) marked ★.", "",
             "| setting | run (ms) | run + ∇ (ms) | Newton its | tip trajectory error (m) | d error | ∇d error |", "|---|---|---|---|---|---|---|"]
    front_d = set(pareto([(r["t_run"], r["d"]) for r in rows]))
    front_g = set(pareto([(r["t_grad"], r["grad"]) for r in rows]))
    for i, r in enumerate(sorted(range(len(rows)), key=lambda k: rows[k]["t_run"])):
        row = rows[r]
        star = " ★" if r in front_d or r in front_g else ""
        lines.append(f"| {row['setting'].label()}{star} | {1e3 * row['t_run']:.1f} | {1e3 * row['t_grad']:.1f} | {row['newton']} | "
                     f"{row['traj']:.2e} | {row['d']:.2e} | {row['grad']:.2e} |")
    return lines + [""]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    cases = [
        Case("robot arm (x = 0.4)", lambda m: flextop.scenes.robot_arm(split=m), 0.4, 1.3, Setting(1, 0.02), 0.04, Setting(16, 0.00125)),
        Case("spun beam (8 bars, x = 0.6)", spun_beam, 0.6, 0.6, Setting(1, 0.005), 0.01, Setting(32, 0.000625)),
    ]
    lines = ["Command: `python benches/work_precision.py`" + (" --quick" if args.quick else ""), ""]
    for case in cases:
        rows = study(case, args.quick)
        slug = "robot_arm" if "robot" in case.name else "spun_beam"
        if not args.quick:  # a quick run only prints
            plot(case, rows, ROOT / "docs" / f"work_precision_{slug}.png")
        lines += table(case, rows)
    text = "\n".join(lines)
    print(text)
    if not args.quick:
        (ROOT / "benches" / "results" / "work_precision.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
