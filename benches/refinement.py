"""Refinement bar by bar against uniform refinement, across the designs users give.

The family: the 15 arm designs of ``benches/tolerance.py`` (uniform densities, seeded random
designs, a chords-only design, the optima of both objectives under both mass laws), uniform
0.08 and 0.12 beside them, and the designs MMA passes through on its way to those optima
(iterations 5, 10, 20 and 30; the tip deflection under du_olhoff converges at 28: 32 designs); the spun beam's designs beside the arm's. Each design runs
``run_with_sensitivities(x, "tip_deflection", rtol=1e-2)`` refined bar by bar
(``refine="bars"``) with Richardson's extrapolation in the step (``extrapolate=True``, the
default) and without, and every bar alike (``refine="uniform"``, without) — gradients held
to 5·rtol (the default) and not (``hold_gradients=False``, what ``TopologyProblem`` asks
for) — and is judged against a converged reference (arm: 8× the elements of every bar, 32×
the steps; spun beam: 32×, 8×; each extrapolated in the step from half its steps). The unit
of cost is the fixed run with gradients on the scene's own grid (one element per bar, the
scene's step).

    python benches/refinement.py [--quick]    # writes benches/results/refinement.md

With ``--mass KIND`` (``lumped``, ``bar_lumped``): the same study with the scenes' runs and
references on that mass matrix (the designs are those of the default mass); writes
benches/results/refinement_KIND.md.

With ``--shares``, instead: each bar's share of the space error — the arm solid but for its
1.0 m diagonal ``link1/bar24`` at x = 0.1, 1088 steps, every bar refined alone (twice its
elements) against all bars at once: whether the shares add up, how many bars carry half
and 80 % of the change of ∇d, and the largest with their frequency, mass and rank by need.

With ``--frame``, instead: the stayed frame solid but for its 1 m stay at x = 0.1, whose
gradient is before its asymptotic range up to 16 elements: the grid a run to rtol = 1e-2
accepts and its errors against the stay at 256 elements. Writes benches/results/frame.md.

With ``--dual``, instead: the a-posteriori indicator (``Simulation.bar_shares``, dual-weighted
residuals) against the truth it estimates, on the arm (1088 steps; solid but for
``link1/bar24`` at x = 0.1, uniform 0.1 and 0.4, a random design, the tip-deflection optimum),
the stayed frame and the spun beam: the shares' sum against the change of splitting every
bar (with the trapezoidal weights and with the coarse run's adjoint alone), each bar's share
against the change of splitting it alone, whether the bars of the largest shares are those
of the largest changes, and what the shares cost. Writes benches/results/shares.md.

With ``--measured``: the same family, only ``refine="bars"`` against ``refine="shares"`` (the
default: the bars refined where their measured shares of the space error carry 80 % of it),
with extrapolation in the step; writes benches/results/refinement_shares.md.

With ``--time-estimate``: the same family, gradients held, the default rule (a candidate's
time errors from its own adjoint sweep where they agree with its half steps) against step
doubling alone (``time_estimate="doubling"``); writes
benches/results/refinement_time_estimate.md.

With ``--richardson``, instead: whether Richardson's extrapolation in the step pays — on three
designs an optimizer produces, the error of d on the grid ``rtol = 1e-2`` chose in space,
raw and extrapolated from the run at twice the step (``f(h) + (f(h) − f(2h))/3``), against
the extrapolated value at 4352 steps. Writes benches/results/richardson.md.

With ``--oracle``, instead: the least a run to rtol could pay on this integrator. For each
design of the family, every grid of a ladder — one element per bar, the graded grids of
refinement 2, 4 and 8, and every bar at 2× and 4× — at 66 to 2112 steps, on its own values
and extrapolated from its half steps, is judged against the converged reference; the
cheapest that meets rtol on d and 5·rtol on ∇d is what a method that knew the answer would
run, with no estimate and no companion. Beside it, the time error alone: the fewest steps at
which the one-element grid's d and ∇d are within the same bounds of that grid's own limit in
the step. Writes benches/results/oracle.md.

With ``--tight``, instead: the family (and the design the rtol 1e-3 optimization of
``benches/tolerance.py --optimization`` ends at) run to rtol 1e-3 with the gradients not
held, against 32× the elements of every bar: whether the estimate stays honest at a tight
tolerance. Writes benches/results/refinement_tight.md. With ``--scene spun_beam`` or
``--scene slider_crank``: that scene's designs instead, to refinement_tight_SCENE.md; with
``--held``, the gradients held too and judged against the reference's (…_held.md).

With ``--adjoint-time``, instead: the time error the adjoint estimates (``Simulation.time_errors``)
against step doubling's estimate and the true error, design by design, at the first
candidate's steps and four doublings, on the arm's family or (``--scene``) the spun beam's or
the slider-crank's designs. Writes benches/results/adjoint_time.md (adjoint_time_SCENE.md).

With ``--adaptive``, instead: on the one-element grid of each design of the family, the
fewest steps at which d is within rtol of that grid's own limit in the step, uniform and
with local error control. Writes benches/results/adaptive.md.

With ``--held-newton``, instead: Newton's tolerance on the grid an optimization holds
(``HELD_NEWTON_TOL``) against the default 1e-10 on 30 arm designs at 1×, 4× and 8× the
elements per bar: the change of d and ∇d, and Newton's iterations per step. Writes
benches/results/held_newton.md.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import flextop  # noqa: E402
from flextop.discretization.refinement import HELD_NEWTON_TOL  # noqa: E402
from flextop.discretization.tolerance import Discretization, estimate, start  # noqa: E402
from flextop.errors import SimulationError, ToleranceError  # noqa: E402
from tolerance import arm_designs, beam_designs, reference, timed  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RTOL = 1e-2
MODES = {"bars, extrapolated": ("bars", {}), "bars": ("bars", {"extrapolate": False}), "uniform": ("uniform", {"extrapolate": False})}
"""The runs compared (``refine`` and the options of the run): refinement bar by bar with
Richardson's extrapolation in the step, bar by bar on the grid's own values, and every bar
alike (the rule before both)."""
MEASURED = {"bars, extrapolated": ("bars", {}), "shares, extrapolated": ("shares", {})}
"""With ``--measured``: refinement bar by bar against by measured shares (``refine="shares"``,
the default)."""
TIME_ESTIMATES = {"time by step doubling": ("shares", {"time_estimate": "doubling"}),
                  "time by the adjoint where it agrees": ("shares", {"time_estimate": "adjoint"})}
"""With ``--time-estimate``: the default rule (the adjoint's time errors where they agree with
the half steps) against step doubling alone, the gradients held (the adjoint is a held
run's)."""
KINDS = ["held", "free"]
"""Whether the gradients are held to 5·rtol (``hold_gradients``), in the order run."""


def iterates(sim: flextop.Simulation, quick: bool) -> dict[str, np.ndarray]:
    """The designs MMA passes through at iterations 5, 10, 20 and 30 of each objective
    under each mass law (V ≤ 0.4 per link, from x = 0.4; its 40th is the optimum of
    ``arm_designs``); ``quick``: one law, 5, 10 and 20."""
    out = {}
    for mass in ("du_olhoff",) if quick else ("du_olhoff", "linear"):
        law = flextop.Simulation(sim.spec | {"design": sim.spec["design"] | {"mass": mass}})
        for objective in ("tip_deflection", "compliance"):
            problem = flextop.TopologyProblem(law, objective, flextop.volume_constraints(law, 0.4))
            seen: dict[int, np.ndarray] = {}
            steps = (5, 10, 20) if quick else (5, 10, 20, 30)
            flextop.optimize(problem, np.full(sim.n_design, 0.4), method="mma", max_iter=steps[-1],
                             callback=lambda record: seen.__setitem__(record.iteration, np.array(record.state.x)))
            for k in (k for k in steps if k in seen):  # a run converged before k has no k-th design
                out[f"{objective} iteration {k} ({mass})"] = seen[k]
    return out


def judged(sims: dict[str, flextop.Simulation], x: np.ndarray, ref: tuple[float, np.ndarray, float], hold: bool) -> dict:
    """Per mode: seconds, errors of d and ∇d against the reference, the estimate, the grid's
    unknowns, or the ToleranceError."""
    d_ref, g_ref, _ = ref
    out = {}
    for mode, sim in sims.items():
        try:
            seconds, run = timed(lambda: sim.run_with_sensitivities(x, "tip_deflection", rtol=RTOL, hold_gradients=hold,
                                                                    **MODES[mode][1]))
        except ToleranceError as error:
            out[mode] = {"failed": str(error)}
            continue
        grid = sim.levels.at(run.discretization, x)
        out[mode] = {"seconds": seconds, "error_d": abs(run.values[0] / d_ref - 1.0),
                     "error_grad": float(np.linalg.norm(run.gradients[0] - g_ref) / np.linalg.norm(g_ref)),
                     "estimate": run.errors["tip_deflection"], "unknowns": grid.model.n_dofs / sim.model.n_dofs,
                     "discretization": run.discretization}
    return out


def study(name: str, scene: flextop.Scene | dict, ref: Discretization, designs: dict[str, np.ndarray]) -> list[str]:
    sims = {mode: flextop.Simulation(scene, refine=refine) for mode, (refine, _) in MODES.items()}
    base = flextop.Simulation(scene)
    h = base.spec["simulation"]["h"]
    rows = []
    for label, x in designs.items():
        unit = min(timed(lambda: base.run_with_sensitivities(x, "tip_deflection", h=h))[0] for _ in range(3))
        r = reference(base, x, ref)
        row = {"design": label, "unit": unit} | {kind: judged(sims, x, r, kind == "held") for kind in KINDS}
        rows.append(row)
        print(name, label, {k: {m: v.get("seconds", "failed") for m, v in row[k].items()} for k in KINDS}, flush=True)
    return table(name, rows)


def cell(run: dict, unit: float) -> str:
    if "failed" in run:
        return "ToleranceError"
    return (f"{run['error_d']:.2%} / {run['error_grad']:.2%} (est. {run['estimate']:.2%}) · {run['unknowns']:.2f}× unknowns · "
            f"{run['seconds']:.2f} s = {run['seconds'] / unit:.0f}×")


def table(name: str, rows: list[dict]) -> list[str]:
    columns = [(kind, mode) for kind in KINDS for mode in MODES]
    out = [f"### {name}", "", "Per run: error of d / error of ∇d against the reference (the estimate) · unknowns of the grid "
           "accepted over the scene's · seconds = multiple of the fixed run with gradients on the scene's grid.", "",
           "| design | fixed run (s) | " + " | ".join(f"{mode}, gradients {'held' if kind == 'held' else 'not held'}"
                                                   for kind, mode in columns) + " |",
           "|---|---|" + "---|" * len(columns)]
    for row in rows:
        out.append(f"| {row['design']} | {row['unit']:.3f} | " + " | ".join(cell(row[k][m], row["unit"]) for k, m in columns) + " |")
    out += ["", "| run | ToleranceErrors | worst error of d | worst error of ∇d | worst under-estimate of d (true / est., where "
            "true > rtol/10) | median unknowns | median cost (× fixed run) | total seconds |", "|---|---|---|---|---|---|---|---|"]
    for kind, mode in columns:
        runs = [(row[kind][mode], row["unit"]) for row in rows]
        ok = [(r, u) for r, u in runs if "failed" not in r]
        out.append(f"| {mode}, gradients {'held' if kind == 'held' else 'not held'} | {len(runs) - len(ok)} | "
                   f"{max(r['error_d'] for r, _ in ok):.2%} | {max(r['error_grad'] for r, _ in ok):.2%} | "
                   f"{max((r['error_d'] / r['estimate'] for r, _ in ok if r['error_d'] > RTOL / 10), default=float('nan')):.2f} | "
                   f"{np.median([r['unknowns'] for r, _ in ok]):.2f}× | {np.median([r['seconds'] / u for r, u in ok]):.0f}× | "
                   f"{sum(r['seconds'] for r, _ in ok):.1f} |")
    return out + [""]


def shares() -> None:
    scene = flextop.scenes.robot_arm()
    arm = flextop.Simulation(scene)
    x = np.ones(arm.n_design)
    x[arm.variable_names.index("link1/bar24")] = 0.1
    h = 1.3 / 1088
    base = arm.run_with_sensitivities(x, "tip_deflection", h=h)
    d0, g0 = base.values[0], base.gradients[0]
    every = arm.levels[2].run_with_sensitivities(x, "tip_deflection", h=h)
    rows = []
    for name in arm.bars.name:
        alone = flextop.Scene.from_dict(scene.to_dict())
        alone.split(name, 2)
        run = flextop.Simulation(alone).run_with_sensitivities(x, "tip_deflection", h=h)
        rows.append(((run.values[0] - d0) / d0, np.linalg.norm(run.gradients[0] - g0) / np.linalg.norm(g0)))
    change = np.array(rows)
    need = arm.model.bar_masses(x) / arm.model.bar_frequencies(x) ** 2
    cumulative = np.cumsum(np.sort(change[:, 1])[::-1])
    print(f"change of d: all bars at once {(every.values[0] - d0) / d0:.3e}, sum of the bars alone {change[:, 0].sum():.3e}")
    print("bars carrying 50 % / 80 % of the sum of the changes of ∇d:",
          [int(np.searchsorted(cumulative, p * cumulative[-1])) + 1 for p in (0.5, 0.8)])
    frequencies, masses = arm.model.bar_frequencies(x), arm.model.bar_masses(x)
    for b in np.argsort(-change[:, 1])[:8]:
        print(f"{arm.bars.name[b]:14s} change of ∇d {change[b, 1]:.2e}  f {frequencies[b]:7.1f} Hz  M {masses[b]:.3f} kg  "
              f"rank by need {int((need > need[b]).sum())}")


def dual_study(label: str, sim: flextop.Simulation, x: np.ndarray, h: float) -> str:
    """One row of ``--dual``: the shares of ``sim`` at ``x`` against each bar split alone."""
    base_seconds, _ = timed(lambda: sim.run_with_sensitivities(x, "tip_deflection", h=h))
    fine = sim.levels[2]
    steps = np.full(round(sim.spec["simulation"]["t_end"] / h), h)

    def measure():
        run = fine.run_fixed(x, {}, steps=steps)
        raw = run.raw
        out = flextop._core.bar_shares(sim.model, fine.model, x, ["tip_deflection"], {}, list(steps),
                                       raw["q"], raw["qdot"], raw["qddot"], raw["lam"])
        return run.response("tip_deflection"), out

    seconds, (d_fine, out) = timed(measure)
    eta, d0 = out["shares"][0], out["values"][0]
    change = d_fine - d0
    alone = np.zeros(len(eta))
    bars = sim.model.bars()
    for b, (name, elements, kind) in enumerate(zip(bars["name"], bars["elements"], bars["kind"])):
        if kind != "truss":
            split = dict(sim.spec, splits={**sim.spec.get("splits", {}), name: 2 * int(elements)})
            alone[b] = flextop.Simulation(split).run(x, h=h).response("tip_deflection") - d0
    top = np.argsort(-np.abs(alone))[:10]
    carry = int(np.searchsorted(np.cumsum(np.sort(np.abs(alone))[::-1]), 0.8 * np.abs(alone).sum())) + 1
    ratios = eta[top[:5]] / alone[top[:5]]
    overlap = len(set(top) & set(np.argsort(-np.abs(eta))[:10]))
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.nan_to_num(sim.model.bar_masses(x) / sim.model.bar_frequencies(x) ** 2)
    by_need = len(set(top) & set(np.argsort(-need)[:10]))
    return (f"| {label} | {change / d0:+.2e} | {eta.sum() / change:.3f} | {out['first_order'][0].sum() / change:.3f} | "
            f"{alone.sum() / change:.3f} | {carry} | {ratios.min():.2f}–{ratios.max():.2f} | {overlap}/10 | {by_need}/10 | "
            f"{seconds / base_seconds:.1f} |")


def dual() -> None:
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    h = 1.3 / 1088
    solid = np.ones(arm.n_design)
    solid[arm.variable_names.index("link1/bar24")] = 0.1
    problem = flextop.TopologyProblem(arm, "tip_deflection", flextop.volume_constraints(arm, 0.4))
    optimum = flextop.optimize(problem, np.full(arm.n_design, 0.4), method="mma", max_iter=40).x
    rows = [dual_study(f"arm, {label}", arm, x, h) for label, x in (
        ("solid but link1/bar24 at 0.1", solid), ("uniform 0.1", np.full(arm.n_design, 0.1)),
        ("uniform 0.4", np.full(arm.n_design, 0.4)),
        ("random #0", np.random.default_rng(0).uniform(arm.x_min, 1.0, arm.n_design)),
        ("tip-deflection optimum (MMA, 40 iterations)", optimum))]
    frame = flextop.Simulation(flextop.scenes.stayed_frame())
    stay = np.where(np.array(frame.variable_names) == "stay", 0.1, 1.0)
    rows.append(dual_study("stayed frame, the stay at 0.1", frame, stay, 0.6 / 240))
    beam = flextop.Simulation(flextop.scenes.spun_beam())
    for x in (1.0, 0.3):
        rows.append(dual_study(f"spun beam, uniform {x:g}", beam, np.full(beam.n_design, x), beam.spec["simulation"]["t_end"] / 200))
    lines = ["# Each bar's share of the space error: dual-weighted residuals against bars split alone", "",
             f"`python benches/refinement.py --dual` on {platform.processor() or platform.machine()}, "
             f"{platform.python_version()}. Change: d with every frame bar split in two, relative. Σ shares / change: "
             "the trapezoidal weights (what `bar_shares` returns) and the coarse run's adjoint alone. Σ alone: each bar "
             "split by itself, summed. 80 %: the bars whose own splitting carries 80 % of Σ|alone|. Share / alone: the five "
             "bars of the largest change alone. Top 10: how many of the ten largest changes alone are among the ten "
             "largest shares, and among the ten of largest need `M/f²` (the a-priori indicator). Cost: `bar_shares` (the split run, two adjoint sweeps) over the fixed run with its "
             "gradient.", "",
             "| design | change of d | Σ shares / change | first order only | Σ alone / change | bars for 80 % | "
             "share / alone (top 5) | top 10 by share | top 10 by need | cost |", "|---|---|---|---|---|---|---|---|---|---|", *rows]
    (ROOT / "benches" / "results" / "shares.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


def richardson() -> None:
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    designs = arm_designs(arm, quick=False) | iterates(arm, quick=False)
    chosen = ["tip_deflection optimum (du_olhoff)", "compliance optimum (linear)", "tip_deflection iteration 10 (du_olhoff)"]
    lines = ["# Richardson's extrapolation in the step", "", "`python benches/refinement.py --richardson` on "
             f"{platform.processor() or platform.machine()}, {platform.python_version()}: error of d, raw and extrapolated "
             "from twice the step, on the space grid rtol = 1e-2 chose (refinement 8, graded).", "",
             "| design | steps | raw | extrapolated |", "|---|---|---|---|"]
    for name in chosen:
        x = designs[name]
        grid = arm.levels.at(Discretization(8, 0), x)
        d = {n: grid.run(x, h=1.3 / n).tip_deflection() for n in (68, 136, 272, 544, 1088, 2176, 4352)}
        reference = d[4352] + (d[4352] - d[2176]) / 3
        for n in (136, 272, 544, 1088, 2176):
            extrapolated = d[n] + (d[n] - d[n // 2]) / 3
            lines.append(f"| {name} | {n} | {abs(d[n] / reference - 1):.2e} | {abs(extrapolated / reference - 1):.2e} |")
            print(lines[-1], flush=True)
    (ROOT / "benches" / "results" / "richardson.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


def frame() -> None:
    """The stayed frame (``flextop.scenes.stayed_frame``) solid but for its stay at x = 0.1:
    the run to rtol = 1e-2 with gradients, where its bars are refined, and its errors against
    the stay at 256 elements on twice the steps."""
    sim = flextop.Simulation(flextop.scenes.stayed_frame())
    x = np.where(np.array(sim.variable_names) == "stay", 0.1, 1.0)
    seconds, sens = timed(lambda: sim.run_with_sensitivities(x, "tip_deflection", rtol=RTOL))
    factors = sim.levels.factors(sens.discretization, x)
    fine = flextop.scenes.stayed_frame()
    fine.split("stay", 256)
    ref = flextop.Simulation(fine).run_with_sensitivities(x, "tip_deflection", h=0.6 / (2 * sens.discretization.steps))
    error_grad = np.linalg.norm(sens.gradients - ref.gradients) / np.linalg.norm(ref.gradients)
    refined = ", ".join(f"{name} {f}×" for name, f in zip(sim.bars.name, factors) if f > 1)
    unknowns = sim.levels.at(sens.discretization, x).model.n_dofs / sim.model.n_dofs
    lines = ["# A soft stay in a solid frame", "", f"`python benches/refinement.py --frame` on "
             f"{platform.processor() or platform.machine()}, {platform.python_version()}: rtol = {RTOL:g}, gradients held.", "",
             "| grid accepted | bars refined | unknowns | seconds | error of d (est.) | error of ∇d (est.) |", "|---|---|---|---|---|---|",
             f"| {sens.discretization} | {refined} | {unknowns:.2f}× | {seconds:.1f} | {abs(sens.values[0] / ref.values[0] - 1):.2e} "
             f"({sens.errors['tip_deflection']:.2e}) | {error_grad:.2e} ({sens.gradient_errors['tip_deflection']:.2e}) |"]
    (ROOT / "benches" / "results" / "frame.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


ORACLE_STEPS = tuple(66 * 2**k for k in range(6))
"""The steps of the oracle's ladder: the scene's grid (h = 0.02 s over 1.3 s) to 32× it."""


def ladder(sim: flextop.Simulation, x: np.ndarray) -> dict[str, flextop.Simulation]:
    """The space grids the oracle may choose from, cheapest first."""
    grids = {"m=1": sim}
    grids |= {f"graded {r}": sim.levels.at(Discretization(r, 0), x) for r in (2, 4, 8)}
    return grids | {f"m={m}": sim.levels[m] for m in (2, 4)}


def oracle_design(sim: flextop.Simulation, x: np.ndarray, ref: tuple[float, np.ndarray, float], unit: float) -> dict:
    """The cheapest grid of the ladder within rtol on d and 5·rtol on ∇d, raw or extrapolated
    from its half steps, and the fewest steps that bring the one-element grid within those
    bounds of its own limit in the step."""
    d_ref, g_ref, _ = ref
    t_end = sim.spec["simulation"]["t_end"]
    best = None
    own: dict[int, tuple[float, np.ndarray]] = {}
    for name, grid in ladder(sim, x).items():
        runs: dict[int, tuple[float, float, np.ndarray]] = {}
        for n in ORACLE_STEPS:
            if best is not None and name != "m=1" and 2 * runs.get(n // 2, (0.0,))[0] > best["cost"]:
                break  # a run at n steps would cost more than the cheapest found (twice the run at n/2)
            seconds, run = timed(lambda: grid.run_with_sensitivities(x, "tip_deflection", h=t_end / n))
            runs[n] = (seconds, float(run.values[0]), run.gradients[0])
            if name == "m=1":
                own[n] = runs[n][1:]
            candidates = [(seconds, runs[n][1], runs[n][2], "raw")]
            if n // 2 in runs:
                half = runs[n // 2]
                candidates.append((seconds + half[0], runs[n][1] + (runs[n][1] - half[1]) / 3,
                                   runs[n][2] + (runs[n][2] - half[2]) / 3, "extrapolated"))
            met = False
            for cost, d, g, how in candidates:
                meets = abs(d / d_ref - 1) <= RTOL and np.linalg.norm(g - g_ref) <= 5 * RTOL * np.linalg.norm(g_ref)
                met = met or bool(meets)
                if meets and (best is None or cost < best["cost"]):
                    best = {"cost": cost, "grid": f"{name}, {n} steps, {how}", "unknowns": grid.model.n_dofs / sim.model.n_dofs}
            if met and name != "m=1":
                break  # more steps on this grid cost more (the one-element grid goes on: its limit in the step is wanted)
    top = ORACLE_STEPS[-1]
    limit_d = own[top][0] + (own[top][0] - own[top // 2][0]) / 3
    limit_g = own[top][1] + (own[top][1] - own[top // 2][1]) / 3
    steps = next((n for n in ORACLE_STEPS if abs(own[n][0] / limit_d - 1) <= RTOL
                  and np.linalg.norm(own[n][1] - limit_g) <= 5 * RTOL * np.linalg.norm(limit_g)), None)
    return {"best": best, "time_steps": steps, "unit": unit}


def oracle() -> None:
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    designs = arm_designs(arm, quick=False)
    designs |= {f"uniform {x:g}": np.full(arm.n_design, x) for x in (0.08, 0.12)}
    designs |= iterates(arm, quick=False)
    h = arm.spec["simulation"]["h"]
    lines = ["# What a run to rtol could pay at best", "", "`python benches/refinement.py --oracle` on "
             f"{platform.processor() or platform.machine()}, {platform.python_version()}: rtol = {RTOL:g} on the tip deflection "
             "(d within rtol, ∇d within 5·rtol of the reference: 8× every bar, 2112 steps extrapolated from 1056). The "
             "cheapest grid of the ladder that meets both, its cost over the fixed run (one element per bar, the scene's "
             "step), and the fewest steps at which the one-element grid meets both against its own limit in the step.", "",
             "| design | cheapest grid that meets rtol | unknowns | cost (× fixed run) | steps the time error alone needs |",
             "|---|---|---|---|---|"]
    costs, steps = [], []
    for label, x in designs.items():
        unit = min(timed(lambda: arm.run_with_sensitivities(x, "tip_deflection", h=h))[0] for _ in range(3))
        row = oracle_design(arm, x, reference(arm, x, Discretization(8, 66 * 32)), unit)
        best = row["best"]
        costs.append(best["cost"] / unit if best else float("inf"))
        steps.append(row["time_steps"] or float("inf"))
        lines.append(f"| {label} | {best['grid'] if best else 'none on the ladder'} | "
                     f"{best['unknowns']:.2f}× | {costs[-1]:.1f}× | {row['time_steps'] or '> 2112'} |" if best else
                     f"| {label} | none on the ladder | — | — | {row['time_steps'] or '> 2112'} |")
        print(lines[-1], flush=True)
    lines += ["", f"Median cost of the cheapest grid: {np.median(costs):.1f}× the fixed run; median steps the time error "
              f"alone needs: {np.median(steps):.0f} (the scene's grid: 66); designs whose cheapest grid costs more than 5×: "
              f"{sum(c > 5 for c in costs)} of {len(costs)}."]
    (ROOT / "benches" / "results" / "oracle.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines[-1:]))


LOCAL_TOLS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7)


def fewest_trusted(runs: list[tuple], limit: float) -> tuple | None:
    """The first of ``runs`` (each a run's steps, d, seconds, ..., in order of cost) from
    which every later one has d within rtol of ``limit`` too (the error is not monotone:
    a run that meets it by chance before does not count); ``None`` if the last does not."""
    meets = [abs(run[1] / limit - 1.0) < RTOL for run in runs]
    return next((run for k, run in enumerate(runs) if all(meets[k:])), None)


def adaptive() -> None:
    """Whether steps that vary pay where uniform ones cost most: on the one-element grid of
    each design of the family, the fewest steps from which d is within rtol of that grid's
    own limit in the step (8448 steps extrapolated from 4224) with every finer run too
    (:func:`fewest_trusted`), uniform (66 to 4224 steps) and with local error control
    (``local_tol`` from 1e-3 down to 1e-7), and the seconds of that run. Writes
    benches/results/adaptive.md."""
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    designs = arm_designs(arm, quick=False) | {f"uniform {x:g}": np.full(arm.n_design, x) for x in (0.08, 0.12)}
    designs |= iterates(arm, quick=False)
    t_end = arm.spec["simulation"]["t_end"]
    lines = ["# Local error control against uniform steps", "", "`python benches/refinement.py --adaptive` on "
             f"{platform.processor() or platform.machine()}, {platform.python_version()}: one element per bar; the fewest "
             f"steps from which d is within rtol = {RTOL:g} of the grid's own limit in the step (8448 steps extrapolated "
             "from 4224) with every finer run too, uniform (66 · 2^k) and with local error control (`local_tol` from 1e-3 "
             "down to 1e-7), and that run's seconds.",
             "", "| design | uniform: steps (s) | local error control: steps (s), local_tol |", "|---|---|---|"]
    ratios = []
    for label, x in designs.items():
        fine, coarse = (arm.run(x, h=t_end / n).tip_deflection() for n in (8448, 4224))
        limit = fine + (fine - coarse) / 3
        uniform = [(n, run.tip_deflection(), seconds) for n in (66 * 2**k for k in range(7))
                   for seconds, run in [timed(lambda: arm.run(x, h=t_end / n))]]
        controlled = [(len(run.time) - 1, run.tip_deflection(), seconds, tol) for tol in LOCAL_TOLS
                      for seconds, run in [timed(lambda: arm.run(x, local_tol=tol))]]
        u, found = fewest_trusted(uniform, limit), fewest_trusted(controlled, limit)
        if u and found:
            ratios.append(found[0] / u[0])
        lines.append(f"| {label} | {f'{u[0]} ({u[2]:.2f})' if u else 'not by 4224'} | "
                     + (f"{found[0]} ({found[2]:.2f}), {found[3]:g}" if found else "not by 1e-7") + " |")
        print(lines[-1], flush=True)
    lines += ["", f"Steps with local error control over uniform steps: median {np.median(ratios):.2f}, "
              f"from {min(ratios):.2f} to {max(ratios):.2f} ({len(ratios)} designs where both meet rtol)."]
    (ROOT / "benches" / "results" / "adaptive.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


def with_mass(scene: flextop.Scene, mass: str) -> dict:
    """The scene as a dict whose runs take ``mass``."""
    spec = scene.to_dict()
    spec["simulation"] = {**spec.get("simulation", {}), "mass": mass}
    return spec


def held_newton() -> None:
    """Newton's tolerance on the grid held (``HELD_NEWTON_TOL``) against the default 1e-10:
    d and ∇d (modified Newton, adjoint) and Newton's iterations per step on 30 arm designs
    at 1×, 4× and 8× the elements per bar. Writes benches/results/held_newton.md."""
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    designs = arm_designs(arm, False) | {f"uniform {x:g}": np.full(arm.n_design, x) for x in (0.08, 0.12)}
    designs |= iterates(arm, True)
    tols = (1e-10, HELD_NEWTON_TOL)
    lines = ["# Newton's tolerance on the grid held", "", "`python benches/refinement.py --held-newton` on "
             f"{platform.processor() or platform.machine()}, {platform.python_version()}: modified Newton at "
             f"{HELD_NEWTON_TOL:g} against 1e-10; d and ∇d (adjoint) relative change, Newton iterations per step.", "",
             "| design | m / steps | change of d | change of ∇d (2-norm) | iterations at 1e-10 | at the held tolerance |",
             "|---|---|---|---|---|---|"]
    worst = np.zeros(2)
    for name, x in designs.items():
        for m, steps in ((1, 1088), (4, 1088), (8, 544)):
            level, settings = arm.levels[m], {"h": 1.3 / steps, "newton": "modified"}
            runs = [level.run_with_sensitivities(x, ["tip_deflection"], method="adjoint", tol=tol, **settings) for tol in tols]
            iterations = [level.run_fixed(x, {**settings, "tol": tol}).newton["mean"] for tol in tols]
            change = np.array([abs(runs[1].values[0] / runs[0].values[0] - 1),
                               np.linalg.norm(runs[1].gradients[0] - runs[0].gradients[0]) / np.linalg.norm(runs[0].gradients[0])])
            worst = np.maximum(worst, change)
            lines.append(f"| {name} | {m} / {steps} | {change[0]:.1e} | {change[1]:.1e} | {iterations[0]:.2f} | {iterations[1]:.2f} |")
            print(lines[-1], flush=True)
    lines += ["", f"Worst change: d {worst[0]:.1e}, ∇d {worst[1]:.1e}."]
    (ROOT / "benches" / "results" / "held_newton.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


TIGHT_RTOL = 1e-3


TIGHT_SCENES = {  # name: scene, the reference's steps (extrapolated from half of them), its elements per bar
    "arm": (flextop.scenes.robot_arm, 1088, 32),
    "spun_beam": (flextop.scenes.spun_beam, 960, 32),
    "slider_crank": (flextop.scenes.slider_crank, 3200, 32),  # random #0's rod buckles: 32× fails on 800 steps
}


def tight_designs(scene: str, sim: flextop.Simulation) -> dict[str, np.ndarray]:
    """The arm's family (and the design the rtol 1e-3 optimization of "Optimization to a
    tolerance" ended at before the confirmation); the other scenes' uniform, random and
    tapered designs (``beam_designs``) and their one-element optimum (MMA, 40 iterations
    from 0.5, V ≤ 0.4 per component)."""
    if scene != "arm":
        designs = beam_designs(sim, False)
        optimum = flextop.optimize(flextop.TopologyProblem(sim, "tip_deflection", flextop.volume_constraints(sim, 0.4)),
                                   np.full(sim.n_design, 0.5), method="mma", max_iter=40).x
        return designs | {"the one-element optimum (MMA, 40 iterations from 0.5)": optimum}
    designs = arm_designs(sim, False) | {f"uniform {x:g}": np.full(sim.n_design, x) for x in (0.08, 0.12)}
    designs |= iterates(sim, False)
    rows = json.loads((ROOT / "benches" / "results" / "tolerance_optimization.json").read_text())
    ended = "rtol 1e-3, the default, as the row above"  # the design it ended at, before the confirmation
    if ended in rows:
        designs[f"the end of \"{ended}\""] = np.array(rows[ended]["x"])
    return designs


def tight(scene: str, hold: bool) -> None:
    """A scene's designs (:func:`tight_designs`) at rtol 1e-3 (the default refinement,
    gradients not held, what an optimization asks for) against 32× the elements of every
    bar, :data:`TIGHT_SCENES`' steps extrapolated from half of them (the reference's
    uncertainty: its change from 16×, and from the same elements on twice the steps).
    Writes benches/results/refinement_tight.md for the arm, refinement_tight_SCENE.md
    otherwise. With ``hold`` the gradients are held too (the default of a run) and judged
    against the reference's, extrapolated alike (..._held.md)."""
    make, steps, elements = TIGHT_SCENES[scene]
    sim = flextop.Simulation(make())
    t_end = sim.spec["simulation"]["t_end"]
    flag = ("" if scene == "arm" else f" --scene {scene}") + (" --held" if hold else "")
    lines = [f"# Runs to rtol 1e-3: {scene.replace('_', ' ')}", "",
             f"`python benches/refinement.py --tight{flag}` on {platform.processor() or platform.machine()}, "
             f"{platform.python_version()}: `run_with_sensitivities(x, \"tip_deflection\", rtol={TIGHT_RTOL:g}, "
             f"hold_gradients={hold})` against {elements}× the elements of every bar, {steps} steps extrapolated from "
             f"{steps // 2}" + (" (∇d alike: the error of ∇d in the 2-norm, its estimate, held to 5·rtol)" if hold else "")
             + ".", "",
             f"| design | error of d | estimate | true / estimate | reference's uncertainty ({elements // 2}× against "
             f"{elements}×; twice its steps) | grid | seconds |" + (" error of ∇d | its estimate |" if hold else ""),
             "|---|---|---|---|---|---|---|" + ("---|---|" if hold else "")]
    under, over, total, gradients_over = [], 0, 0.0, 0
    for name, x in tight_designs(scene, sim).items():
        try:
            fine = truth_of(sim.levels[elements], x, t_end, steps)
            uncertainty = max(abs(truth_of(sim.levels[elements // 2], x, t_end, steps) / fine - 1.0),
                              abs(truth_of(sim.levels[elements], x, t_end, 2 * steps) / fine - 1.0))
        except SimulationError as error:
            lines.append(f"| {name} | the reference failed: {error} | | | | | |")
            continue
        try:
            seconds, run = timed(lambda: sim.run_with_sensitivities(x, "tip_deflection", rtol=TIGHT_RTOL, hold_gradients=hold))
        except (ToleranceError, SimulationError) as error:
            lines.append(f"| {name} | {type(error).__name__}: {error} | | | {uncertainty:.1e} | | |")
            continue
        error, estimate = abs(run.values[0] / fine - 1.0), run.errors["tip_deflection"]
        if error > TIGHT_RTOL / 10 and error > uncertainty:
            under.append(error / estimate)
        over += error > TIGHT_RTOL
        total += seconds
        lines.append(f"| {name} | {error:.3%} | {estimate:.3%} | {error / estimate:.2f} | {uncertainty:.1e} | {run.discretization} | "
                     f"{seconds:.1f} |")
        if hold:
            g = gradient_truth_of(sim.levels[elements], x, t_end, steps)
            g_error = float(np.linalg.norm(run.gradients[0] - g) / np.linalg.norm(g))
            gradients_over += g_error > 5 * TIGHT_RTOL
            lines[-1] += f" {g_error:.3%} | {run.gradient_errors['tip_deflection']:.3%} |"
        print(lines[-1], flush=True)
    lines += ["", f"Worst under-estimate (true / estimate where the true error exceeds rtol/10 and the reference's "
              f"uncertainty): {max(under, default=float('nan')):.2f}; runs whose true error is over rtol: {over}; "
              + (f"runs whose ∇d is over 5·rtol: {gradients_over}; " if hold else "") + f"seconds in all: {total:.1f}."]
    stem = ("refinement_tight" if scene == "arm" else f"refinement_tight_{scene}") + ("_held" if hold else "")
    (ROOT / "benches" / "results" / f"{stem}.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


AGREEMENT = (0.67, 1.5)
"""Where the adjoint's estimate ``e(h)`` and the half-step run's ``(f(2h) − f(h))/3`` (both
``e(h)`` in the asymptotic range) agree: the range of their ratio ``--adjoint-time`` counts."""

ADJOINT_LEVELS = 5
"""Step counts of ``--adjoint-time``: the rule's first candidate (the scene's steps rounded up
to a multiple of 4) and its doublings."""


def adjoint_time(scene: str) -> None:
    """The time error estimated by the adjoint (``Simulation.time_errors``: the steps' local
    errors weighted by the run's adjoint) against the step-doubling estimate of a run to a
    tolerance (runs at 2h and 4h, the observed order, ``tolerance.estimate``) and the true
    time error, design by design (:func:`tight_designs`), on the scene's elements at its
    first candidate's steps and their doublings. The truth: d on the same elements, 64 times
    the first candidate's steps extrapolated from 32 times. Prints a table per design and
    writes benches/results/adjoint_time.md (the arm), adjoint_time_SCENE.md otherwise."""
    make = TIGHT_SCENES[scene][0]
    sim = flextop.Simulation(make())
    t_end = sim.spec["simulation"]["t_end"]
    first = start(math.ceil(t_end / sim.spec["simulation"]["h"] - 1e-9)).steps
    levels = [first * 2**k for k in range(ADJOINT_LEVELS)]
    flag = "" if scene == "arm" else f" --scene {scene}"
    lines = [f"# The time error from the adjoint: {scene.replace('_', ' ')}", "",
             f"`python benches/refinement.py --adjoint-time{flag}` on {platform.processor() or platform.machine()}, "
             f"{platform.python_version()}: d (`tip_deflection`) on the scene's elements at {', '.join(map(str, levels))} "
             f"steps; its true time error against {64 * first} steps extrapolated from {32 * first}; the adjoint's "
             "estimate (signed, `Simulation.time_errors`) and step doubling's (its size, from the runs at 2h and 4h as a "
             "run to a tolerance makes them). Each cell: true error, then each estimate over it.", "",
             "| design | " + " | ".join(f"{n} steps: true, adjoint / true, doubling / |true|" for n in levels) + " |",
             "|---|" + "---|" * len(levels)]
    ratios: dict[int, list[tuple[float, float, float]]] = {n: [] for n in levels}
    seconds = {"run": 0.0, "adjoint": 0.0, "doubling": 0.0}
    for name, x in tight_designs(scene, sim).items():
        try:
            fine, coarse = (sim.time_errors(x, "tip_deflection", steps=n)["tip_deflection"][0] for n in (64 * first, 32 * first))
        except SimulationError as error:
            lines.append(f"| {name} | the reference failed: {error} |" + " |" * (len(levels) - 1))
            continue
        limit = fine + (fine - coarse) / 3
        cells = []
        for n in levels:
            try:
                took, out = timed(lambda: sim.time_errors(x, "tip_deflection", steps=n))
                value, adjoint = out["tip_deflection"]
                took_run, _ = timed(lambda: sim.run(x, h=t_end / n))
                took_2, half = timed(lambda: sim.run(x, h=t_end / (n // 2)).tip_deflection())
                took_4, quarter = timed(lambda: sim.run(x, h=t_end / (n // 4)).tip_deflection())
            except SimulationError as error:
                cells.append(f"failed: {type(error).__name__}")
                continue
            seconds["run"] += took_run
            seconds["adjoint"] += took - took_run
            seconds["doubling"] += took_2 + took_4
            doubling = float(estimate([np.array([value])], [np.array([half])], [np.array([quarter])],
                                      [np.array([value])]).time[0])
            true = value - limit
            # Asymptotic, f(2h) − f(h) = 3 e(h): the half-step run's word on the adjoint's.
            agreement = adjoint / ((half - value) / 3) if half != value else float("inf")
            ratios[n].append((true / limit, adjoint / true, doubling / abs(true), agreement))
            cells.append(f"{true / limit:+.1e}, {adjoint / true:.2f}, {doubling / abs(true):.2f}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    low, high = AGREEMENT
    lines += ["", "| steps | designs | median true error | adjoint / true: median, least, most | adjoint of the wrong sign "
              "| doubling / |true|: median, least, most | under-estimates by more than 2×, the wrong sign included (adjoint, "
              f"doubling) | adjoint within [{low:g}, {high:g}] of (f(2h) − f(h))/3: designs, adjoint / true among them: least, most |",
              "|---|---|---|---|---|---|---|---|"]
    for n in levels:
        rows = ratios[n]
        if not rows:
            continue
        true, adj, dbl, agreement = (np.array(column) for column in zip(*rows))
        agreed = (agreement >= low) & (agreement <= high)
        lines.append(f"| {n} | {len(rows)} | {np.median(np.abs(true)):.1e} | {np.median(adj):.2f}, {adj.min():.2f}, "
                     f"{adj.max():.2f} | {int(np.sum(adj < 0))} | {np.median(dbl):.2f}, {dbl.min():.2f}, {dbl.max():.2f} | "
                     f"{int(np.sum(adj < 0.5))}, {int(np.sum(dbl < 0.5))} | {int(agreed.sum())}"
                     + (f", {adj[agreed].min():.2f}, {adj[agreed].max():.2f} |" if agreed.any() else " |"))
    lines += ["", f"Seconds over every design and step count: the runs themselves {seconds['run']:.1f}; beyond them, the "
              f"adjoint's sweeps {seconds['adjoint']:.1f} (a run with gradients makes it anyway), step doubling's companions "
              f"at 2h and 4h {seconds['doubling']:.1f}."]
    stem = "adjoint_time" if scene == "arm" else f"adjoint_time_{scene}"
    (ROOT / "benches" / "results" / f"{stem}.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines[-(len(levels) + 5):]))


def gradient_truth_of(level: flextop.Simulation, x: np.ndarray, t_end: float, steps: int) -> np.ndarray:
    """∇d on ``level``, ``steps`` extrapolated from half of them."""
    fine, coarse = (level.run_with_sensitivities(x, "tip_deflection", h=t_end / n).gradients[0] for n in (steps, steps // 2))
    return fine + (fine - coarse) / 3


def truth_of(level: flextop.Simulation, x: np.ndarray, t_end: float = 1.3, steps: int = 1088) -> float:
    """d on ``level``, ``steps`` extrapolated from half of them."""
    fine, coarse = (level.run(x, h=t_end / n).tip_deflection() for n in (steps, steps // 2))
    return fine + (fine - coarse) / 3


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true", help="fewer designs (a smoke run)")
    parser.add_argument("--richardson", action="store_true", help="Richardson's extrapolation in the step instead")
    parser.add_argument("--shares", action="store_true", help="each bar's share of the space error instead")
    parser.add_argument("--measured", action="store_true", help="refine='bars' against refine='shares' only")
    parser.add_argument("--time-estimate", action="store_true",
                        help="the adjoint's time errors where they agree against step doubling alone, gradients held")
    parser.add_argument("--dual", action="store_true", help="the a-posteriori shares against bars split alone, instead")
    parser.add_argument("--frame", action="store_true", help="the stayed frame: one soft bar among solid ones, instead")
    parser.add_argument("--oracle", action="store_true", help="the cheapest grid that meets rtol on each design, instead")
    parser.add_argument("--mass", choices=["consistent", "lumped", "bar_lumped"], default="consistent",
                        help="the mass matrix of the runs and references")
    parser.add_argument("--held-newton", action="store_true", help="Newton's tolerance on the grid held against 1e-10, instead")
    parser.add_argument("--tight", action="store_true", help="the family at rtol 1e-3 against 32x references, instead")
    parser.add_argument("--adaptive", action="store_true", help="local error control against uniform steps, instead")
    parser.add_argument("--adjoint-time", action="store_true",
                        help="the time error from the adjoint against step doubling and the truth, instead")
    parser.add_argument("--scene", choices=sorted(TIGHT_SCENES), default="arm",
                        help="with --tight or --adjoint-time: whose designs")
    parser.add_argument("--held", action="store_true", help="with --tight: the gradients held too, and judged")
    args = parser.parse_args()
    if args.adjoint_time:
        return adjoint_time(args.scene)
    if args.tight:
        return tight(args.scene, args.held)
    if args.adaptive:
        return adaptive()
    if args.held_newton:
        return held_newton()
    if args.dual:
        return dual()
    if args.frame:
        return frame()
    if args.richardson:
        return richardson()
    if args.shares:
        return shares()
    if args.oracle:
        return oracle()
    if args.measured or args.time_estimate:
        MODES.clear()
        MODES.update(TIME_ESTIMATES if args.time_estimate else MEASURED)
    if args.time_estimate:
        KINDS.remove("free")
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    designs = arm_designs(arm, args.quick)
    designs |= {f"uniform {x:g}": np.full(arm.n_design, x) for x in ((0.08, 0.12) if not args.quick else ())}
    designs |= iterates(arm, args.quick)
    arm_scene, beam_scene = (with_mass(scene, args.mass) for scene in (flextop.scenes.robot_arm(), flextop.scenes.spun_beam()))
    options = (" --quick" if args.quick else "") + (" --measured" if args.measured else "") + \
        (" --time-estimate" if args.time_estimate else "") + \
        ("" if args.mass == "consistent" else f" --mass {args.mass}")
    lines = ["# Refinement bar by bar", "", f"`python benches/refinement.py{options}` on "
             f"{platform.processor() or platform.machine()}, {platform.python_version()}: rtol = {RTOL:g} on the tip "
             f"deflection, refined bar by bar (`refine=\"bars\"`, or by measured shares, `\"shares\"`, the default) or every bar "
             f"alike (`\"uniform\"`), "
             f"mass `{args.mass}`.", ""]
    lines += study("robot arm", arm_scene, Discretization(8, 66 * 32), designs)
    lines += study("spun beam", beam_scene, Discretization(32, 120 * 8), beam_designs(flextop.Simulation(beam_scene), args.quick))
    stem = "refinement_time_estimate" if args.time_estimate else "refinement_shares" if args.measured else "refinement"
    path = ROOT / "benches" / "results" / (f"{stem}.md" if args.mass == "consistent" else f"{stem}_{args.mass}.md")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
