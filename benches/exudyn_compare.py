#!/usr/bin/env python
"""flextop vs Exudyn on the two-link robot arm (docs/reference-scenes.md).

    python benches/exudyn_compare.py            # full run (~2-3 min on 2 cores), writes
                                                # benches/results/exudyn_compare.md
    python benches/exudyn_compare.py --quick    # reduced run, prints only (add --output PATH to write)

Both codes simulate the *same* model: the Exudyn model is built from flextop's own model data
(``sim.model.reference_positions``, ``sim.model.elements()``, ``sim.model.joints()`` and the
scene dict), so node numbering, geometry, section, SIMP scaling (x = 0.4 everywhere, p = 3:
EA, EI, kGA x 0.064; rhoA, rhoI x 0.4), tip mass and drives are identical. Exudyn node ``i`` is
flextop node ``i``; every node is a ``NodeRigidBody2D`` (reference rotation 0) and every bar is
split into beam elements exactly as flextop splits it (``flextop.scenes.robot_arm(split=m)``).

Exudyn's ``ObjectBeamGeometricallyExact2D`` (Simo-Reissner, shear deformable) is used in its two
variants, both with ``includeReferenceRotations=False`` so nodes can be shared by bars at any
angle:

* ``linear``: 2-node element, linear interpolation of displacement and rotation, one-point
  (reduced) integration of the elastic forces, consistent mass (incl. rotary inertia rho I);
  ``m`` elements per bar on flextop's ``split=m`` nodes.
* ``quadratic``: 3-node element (quadratic interpolation, 3-point Gauss); ``k`` elements per bar
  on flextop's ``split=2k`` nodes (the element's middle node is flextop's interior node).

Joints: shoulder = two ``CoordinateConstraint`` on x, y of the pinned node against a ground
node plus one on its rotation with ``offsetUserFunction`` = theta1(t) - theta1(0); elbow = three
``CoordinateConstraint`` between the coincident nodes' x, y, rotation coordinates, the rotation
one with offset theta2(t) - theta2(0) (Exudyn: c = q_m1 - q_m0 - UF(t), m0 = link 1's node, m1 =
link 2's node, i.e. the same phi_b - phi_a as flextop's hinge). Tip mass: ``ObjectMassPoint2D``.

Integrator: Exudyn ``GeneralizedAlpha`` (Chung-Hulbert, spectralRadius = rho_inf, index-3
position-level constraints, ``useIndex2Constraints=False``, fixed step, no adaptive step), modified
Newton (Exudyn's default), sparse LU (``EigenSparse``, analysed pattern reused), one thread.

Both codes' tip trajectories are post-processed by the same function here: e(t) = r_tip - r_rigid
with r_rigid from the prescribed angles (cross-checked against ``sim.rigid_trajectory``), d =
(1/t_f) * trapezoid(|e|^2). Timings: ``time.perf_counter`` around ``sim.run`` (flextop) and around
``exudyn.SolveDynamic`` (Exudyn "solve"); "total" adds model construction (flextop:
``Simulation(scene)``; Exudyn: building the mbs + ``Assemble``). Each timing is the minimum over
a few repetitions for short runs.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import flextop

try:
    import exudyn as exu
    from exudyn.itemInterface import (CoordinateConstraint, MarkerNodeCoordinate, NodePointGround,
                                      NodeRigidBody2D, ObjectBeamGeometricallyExact2D, ObjectMassPoint2D,
                                      SensorNode)
except ImportError:  # pragma: no cover
    sys.exit("exudyn is not installed: pip install exudyn (1.13.x)")

HERE = Path(__file__).resolve().parent
DEFAULT_OUTPUT = HERE / "results" / "exudyn_compare.md"

X_DENSITY = 0.4
RHO_INF = 0.8
H0 = 0.02

# Newton settings. flextop: its default relative tolerance 1e-10 (inf-norms of force residual and
# constraint violation relative to the largest force / length scale). Exudyn: residual = L2 norm of
# [force residual; constraint violation]; converged if residual/initial <= REL or residual <= ABS.
# The residual stalls at ~1e-8..1e-5 (round-off, grows with the DOF count), so ABS cannot be
# much tighter; the tolerance check below shows these values change d by < 1e-7 (relative).
FLEXTOP_TOL = 1e-10
EXU_REL_TOL = 1e-8
EXU_ABS_TOL = 1e-4


# ---------------------------------------------------------------------------------------------
# scene data (read from flextop's scene, not retyped)

def trapezoidal_offset(drive: dict):
    """theta(t) - theta(t_start) of a trapezoidal velocity law (rest -> accelerate -> cruise ->
    decelerate -> rest); triangular if the cruise speed is not reached."""
    th0, th1 = drive["start"], drive["end"]
    acc, vmax, t0 = drive["acceleration"], drive["speed"], drive.get("t_start", 0.0)
    dth = th1 - th0
    sgn = 1.0 if dth >= 0 else -1.0
    dist = abs(dth)
    if vmax * vmax / acc > dist:  # triangular
        vmax = math.sqrt(acc * dist)
    ta = vmax / acc
    T = dist / vmax + ta

    def f(t: float) -> float:
        s = t - t0
        if s <= 0.0:
            return 0.0
        if s < ta:
            v = 0.5 * acc * s * s
        elif s < T - ta:
            v = 0.5 * acc * ta * ta + vmax * (s - ta)
        elif s < T:
            r = T - s
            v = dist - 0.5 * acc * r * r
        else:
            v = dist
        return sgn * v

    return f


@dataclass
class SceneData:
    """Everything both codes need, taken from flextop's robot-arm scene."""
    scene_dict: dict
    E: float
    nu: float
    rho: float
    diameter: float
    p: float
    t_end: float
    length: float
    theta0: tuple
    drives: dict = field(default_factory=dict)      # joint name -> callable offset(t)
    point_masses: list = field(default_factory=list)  # (node name, mass)

    @property
    def section(self) -> dict:
        """Per-length section values at density X_DENSITY (SIMP)."""
        G = self.E / (2 * (1 + self.nu))
        A = math.pi * self.diameter ** 2 / 4
        I = math.pi * self.diameter ** 4 / 64
        kappa = 6 * (1 + self.nu) / (7 + 6 * self.nu)
        fs, fm = X_DENSITY ** self.p, X_DENSITY
        return dict(EA=fs * self.E * A, EI=fs * self.E * I, GAk=fs * kappa * G * A, rhoA=fm * self.rho * A,
                    rhoI=fm * self.rho * I)

    def rigid_tip(self, t: np.ndarray) -> np.ndarray:
        """r_rigid(t) of the two-link arm's tip from the prescribed angles."""
        th1 = self.theta0[0] + np.array([self.drives["shoulder"](s) for s in t])
        th2 = self.theta0[1] + np.array([self.drives["elbow"](s) for s in t])
        L = self.length
        return np.stack([L * np.cos(th1) + L * np.cos(th1 + th2), L * np.sin(th1) + L * np.sin(th1 + th2)], axis=1)


def scene_data() -> SceneData:
    d = flextop.scenes.robot_arm().to_dict()
    (sec,) = d["sections"].values()
    gs = {g["name"]: g for g in d["ground_structures"]}
    sd = SceneData(scene_dict=d, E=sec["E"], nu=sec["nu"], rho=sec["rho"], diameter=sec["diameter"],
                   p=d["design"]["p"], t_end=d["simulation"]["t_end"], length=gs["link1"]["length"],
                   theta0=(gs["link1"]["angle"], gs["link2"]["angle"] - gs["link1"]["angle"]))
    for j in d["joints"]:
        assert j["drive"]["kind"] == "trapezoidal", j
        sd.drives[j["name"]] = trapezoidal_offset(j["drive"])
    sd.point_masses = [(pm["node"], pm["mass"]) for pm in d["point_masses"]]
    return sd


def tip_deflection(t: np.ndarray, e: np.ndarray) -> float:
    return float(np.trapezoid(np.sum(e ** 2, axis=1), t) / (t[-1] - t[0]))


# ---------------------------------------------------------------------------------------------
# runs

@dataclass
class Run:
    code: str           # "flextop" | "Exudyn"
    element: str        # "co-rot. Timoshenko" | "GE2D linear" | "GE2D quadratic"
    per_bar: int        # elements per bar
    split: int          # node intervals per bar (flextop split)
    h: float
    ndof: int
    d: float = float("nan")
    t: np.ndarray | None = None
    r: np.ndarray | None = None       # tip positions (n_t, 2)
    solve: float = float("nan")
    total: float = float("nan")
    cpu: float = float("nan")        # process CPU time of the fastest run/solve
    newton: str = ""
    ok: bool = True
    note: str = ""

    @property
    def label(self) -> str:
        return f"{self.code} {self.element} m={self.per_bar} h={self.h:g}"


_SIMS: dict[int, flextop.Simulation] = {}


def simulation(split: int) -> flextop.Simulation:
    if split not in _SIMS:
        _SIMS[split] = flextop.Simulation(flextop.scenes.robot_arm(split=split))
    return _SIMS[split]


def repeat_min(fn, min_total: float, max_rep: int):
    """Runs fn() (returning (result, t_solve, t_total, cpu_solve)) until min_total seconds are spent
    or max_rep runs are done; returns the last result, the minimum times and the CPU time of the
    fastest solve."""
    best_s, best_t, cpu, spent, n, out = math.inf, math.inf, math.nan, 0.0, 0, None
    while n < max_rep and (n == 0 or spent < min_total):
        out, ts, tt, tc = fn()
        if ts < best_s:
            best_s, cpu = ts, tc
        best_t = min(best_t, tt)
        spent += tt
        n += 1
    return out, best_s, best_t, cpu


def run_flextop(sd: SceneData, m: int, h: float, *, tol: float = FLEXTOP_TOL, reps: int = 5) -> Run:
    def once():
        t0 = time.perf_counter()
        sim = flextop.Simulation(flextop.scenes.robot_arm(split=m))
        x = np.full(sim.n_design, X_DENSITY)
        c1, t1 = time.process_time(), time.perf_counter()
        res = sim.run(x, h=h, rho_inf=RHO_INF, tol=tol)
        t2, c2 = time.perf_counter(), time.process_time()
        return (sim, res), t2 - t1, t2 - t0, c2 - c1

    (sim, res), ts, tt, tc = repeat_min(once, 0.5, reps)
    _SIMS.setdefault(m, sim)
    t = np.asarray(res.time)
    r = np.asarray(res.positions[:, sim.tip])
    e = r - sd.rigid_tip(t)
    d = tip_deflection(t, e)
    # cross-checks of this script's post-processing against flextop's own
    assert abs(d - res.tip_deflection()) <= 1e-12 * d, (d, res.tip_deflection())
    assert np.abs(sd.rigid_tip(t) - sim.rigid_trajectory(sim.tip, t)).max() < 1e-12
    nw = res.newton
    return Run("flextop", "co-rot. Timoshenko", m, m, h, sim.model.n_dofs, d, t, r, ts, tt, tc,
               newton=f"{nw['total']} it", note=f"tol {tol:g}")


def build_exudyn(sd: SceneData, split: int, element: str):
    """Exudyn model on flextop's split=`split` nodes; returns (mbs, tip sensor, ndof)."""
    sim = simulation(split)
    X = np.asarray(sim.model.reference_positions)
    el = sim.model.elements()
    en = np.asarray(el["nodes"]).astype(int)
    ebar = np.asarray(el["bar"])
    s = sd.section

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[float(X[i, 0]), float(X[i, 1]), 0.0]))
             for i in range(len(X))]

    def beam(node_ids, length):
        mbs.AddObject(ObjectBeamGeometricallyExact2D(
            nodeNumbers=[nodes[i] for i in node_ids], length=length, massPerLength=s["rhoA"],
            crossSectionInertia=s["rhoI"], bendingStiffness=s["EI"], axialStiffness=s["EA"],
            shearStiffness=s["GAk"], includeReferenceRotations=False,
            visualization={"show": False, "drawHeight": 0.0, "color": [-1.0, -1.0, -1.0, -1.0]}))

    if element == "linear":
        for a, b in en:
            beam((a, b), float(np.linalg.norm(X[b] - X[a])))
    else:  # quadratic: consecutive pairs of flextop's elements of one bar form a 3-node element
        assert split % 2 == 0
        for j in range(0, len(en), 2):
            (a, c), (c2, b) = en[j], en[j + 1]
            assert ebar[j] == ebar[j + 1] and c == c2
            beam((a, c, b), float(np.linalg.norm(X[b] - X[a])))

    for name, mass in sd.point_masses:
        mbs.AddObject(ObjectMassPoint2D(nodeNumber=nodes[sim.node(name)], mass=mass))

    ground = mbs.AddNode(NodePointGround())
    mground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))

    def marker(node, coord):
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[node], coordinate=coord))

    def offset_uf(f):
        return lambda mbs_, t, itemNumber, lOffset: f(t)

    for name, kind, jnodes, _first, _nrows, driven in sim.model.joints():
        drive = sd.drives.get(name) if driven else None
        if kind in ("pin", "clamp"):
            (n,) = jnodes
            for c in (0, 1):
                mbs.AddObject(CoordinateConstraint(markerNumbers=[mground, marker(n, c)]))
            if kind == "clamp" or drive is not None:
                kw = {"offsetUserFunction": offset_uf(drive)} if drive is not None else {}
                mbs.AddObject(CoordinateConstraint(markerNumbers=[mground, marker(n, 2)], **kw))
        elif kind == "hinge":
            a, b = jnodes
            for c in (0, 1):
                mbs.AddObject(CoordinateConstraint(markerNumbers=[marker(a, c), marker(b, c)]))
            if drive is not None:  # c = q_b - q_a - UF(t)
                mbs.AddObject(CoordinateConstraint(markerNumbers=[marker(a, 2), marker(b, 2)],
                                                   offsetUserFunction=offset_uf(drive)))
        else:
            raise ValueError(f"joint kind {kind!r} not mapped")

    sensor = mbs.AddSensor(SensorNode(nodeNumber=nodes[sim.tip], storeInternal=True,
                                      outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    return mbs, sensor, mbs.systemData.ODE2Size()


def exudyn_settings(sd: SceneData, h: float, *, rel_tol: float, abs_tol: float, modified: bool,
                    threads: int) -> "exu.SimulationSettings":
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.startTime, ti.endTime = 0.0, sd.t_end
    ti.numberOfSteps = int(round(sd.t_end / h))
    ti.adaptiveStep = False
    ti.verboseMode = 0
    ga = ti.generalizedAlpha
    ga.spectralRadius = RHO_INF
    ga.useIndex2Constraints = False
    ga.useNewmark = False
    ga.computeInitialAccelerations = True
    ti.newton.relativeTolerance = rel_tol
    ti.newton.absoluteTolerance = abs_tol
    ti.newton.useModifiedNewton = modified
    ti.newton.maxIterations = 25
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    ss.linearSolver.reuseAnalyzedPattern = True
    ss.parallel.numberOfThreads = threads
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = 0.5 * h  # every step is stored
    return ss


def run_exudyn(sd: SceneData, per_bar: int, h: float, element: str, *, rel_tol: float = EXU_REL_TOL,
               abs_tol: float = EXU_ABS_TOL, modified: bool = True, threads: int = 1, reps: int = 3,
               initial_acc: np.ndarray | None = None) -> Run:
    split = per_bar if element == "linear" else 2 * per_bar
    info = {}

    def once():
        t0 = time.perf_counter()
        mbs, sensor, ndof = build_exudyn(sd, split, element)
        ss = exudyn_settings(sd, h, rel_tol=rel_tol, abs_tol=abs_tol, modified=modified, threads=threads)
        if initial_acc is not None:
            mbs.systemData.SetODE2Coordinates_tt(list(initial_acc), configuration=exu.ConfigurationType.Initial)
            ss.timeIntegration.generalizedAlpha.computeInitialAccelerations = False
        c1, t1 = time.process_time(), time.perf_counter()
        exu.SolveDynamic(mbs, ss, solverType=exu.DynamicSolverType.GeneralizedAlpha, storeSolver=True)
        t2, c2 = time.perf_counter(), time.process_time()
        it = mbs.sys["dynamicSolver"].it
        info.update(newton=f"{it.newtonStepsCount} it / {it.newtonJacobiCount} jac", ndof=ndof)
        return mbs.GetSensorStoredData(sensor), t2 - t1, t2 - t0, c2 - c1

    name = "GE2D " + element
    try:
        data, ts, tt, tc = repeat_min(once, 1.0, reps)
    except exu.SolverError as err:  # Newton failed: report, do not retry silently
        return Run("Exudyn", name, per_bar, split, h, info.get("ndof", 0), ok=False, note=f"failed: {err}")
    t, r = np.asarray(data[:, 0]), np.asarray(data[:, 1:3])
    n = int(round(sd.t_end / h))
    assert len(t) == n + 1 and np.allclose(t, np.arange(n + 1) * h, atol=1e-9), (len(t), n)
    d = tip_deflection(t, r - sd.rigid_tip(t))
    return Run("Exudyn", name, per_bar, split, h, info["ndof"], d, t, r, ts, tt, tc, newton=info["newton"],
               note=f"rel {rel_tol:g} abs {abs_tol:g}" + ("" if modified else " full Newton"))


def traj_diff(a: Run, b: Run) -> float:
    """max |r_a(t) - r_b(t)| over the times common to both runs (step sizes divide each other)."""
    if a.t is None or b.t is None:
        return float("nan")
    hc = max(a.h, b.h)
    ia = np.round(np.arange(0, a.t[-1] + 0.5 * hc, hc) / a.h).astype(int)
    ib = np.round(np.arange(0, b.t[-1] + 0.5 * hc, hc) / b.h).astype(int)
    assert np.allclose(a.t[ia], b.t[ib], atol=1e-9)
    return float(np.linalg.norm(a.r[ia] - b.r[ib], axis=1).max())


def richardson(runs: list[Run], element: str, h: float):
    """m -> infinity estimate of d at step h from the two finest m, assuming O(1/m^2) (the observed
    rate of all three elements once m is large enough; rough when the finest m are small)."""
    rs = sorted((r for r in runs if r.element == element and r.h == h and r.ok), key=lambda r: r.per_bar)
    if len(rs) < 2:
        return None
    a, b = rs[-2], rs[-1]
    ratio = (b.per_bar / a.per_bar) ** 2
    return b.d + (b.d - a.d) / (ratio - 1.0), a.per_bar, b.per_bar


def finest(runs: list[Run], pred) -> Run | None:
    ok = [r for r in runs if r.ok and pred(r)]
    return max(ok, key=lambda r: r.split) if ok else None


# ---------------------------------------------------------------------------------------------
# report

def machine() -> str:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        nproc = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover
        nproc = os.cpu_count()
    return f"nproc {nproc}, CPU {cpu}, {platform.system()} {platform.release()}, Python {platform.python_version()}"


def pct(x: float) -> str:
    return "—" if not np.isfinite(x) else f"{100 * x:+.3f} %"


def ms(x: float) -> str:
    return "—" if not np.isfinite(x) else f"{1e3 * x:.1f}"


def mm(x: float) -> str:
    return "—" if not np.isfinite(x) else f"{1e3 * x:.3f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="reduced set of runs (prints only unless --output)")
    ap.add_argument("--output", type=Path, default=None, help=f"Markdown output (default {DEFAULT_OUTPUT} "
                    "for the full run)")
    ap.add_argument("--exudyn-threads", type=int, default=1, help="Exudyn parallel.numberOfThreads (default 1)")
    args = ap.parse_args(argv)
    output = args.output if args.output is not None else (None if args.quick else DEFAULT_OUTPUT)
    th = args.exudyn_threads
    t_start = time.perf_counter()
    sd = scene_data()

    if args.quick:
        plan_ft = [(m, h) for m in (1, 2, 4, 8) for h in (0.02, 0.01)]
        ref_ft = (16, 0.005)
        plan_lin = [(m, 0.02) for m in (1, 2, 4, 8)]
        plan_quad = [(k, h) for k in (1, 2) for h in (0.02, 0.01)]
        ref_ex = (4, 0.005)
        targets = (0.02, 0.005)
    else:
        plan_ft = [(m, h) for m in (1, 2, 4, 8, 16, 32) for h in (0.02, 0.01, 0.005)]
        ref_ft = (64, 0.0025)
        plan_lin = [(m, h) for m in (1, 2, 4, 8, 16, 32) for h in (0.02, 0.01)] + [(64, 0.02)]
        plan_quad = [(k, h) for k in (1, 2, 4, 8) for h in (0.02, 0.01, 0.005)]
        ref_ex = (8, 0.0025)
        targets = (0.02, 0.005, 0.001)

    def log(msg):
        print(f"[{time.perf_counter() - t_start:7.1f} s] {msg}", flush=True)

    runs: list[Run] = []
    for m, h in plan_ft:
        runs.append(run_flextop(sd, m, h))
        log(f"{runs[-1].label}: d={runs[-1].d:.8e} run {runs[-1].solve:.3f} s")
    rft = run_flextop(sd, *ref_ft, reps=1)
    log(f"reference {rft.label}: d={rft.d:.8e} run {rft.solve:.3f} s")
    for m, h in plan_lin:
        runs.append(run_exudyn(sd, m, h, "linear", threads=th))
        log(f"{runs[-1].label}: d={runs[-1].d:.8e} solve {runs[-1].solve:.3f} s {runs[-1].note}")
    for k, h in plan_quad:
        runs.append(run_exudyn(sd, k, h, "quadratic", threads=th))
        log(f"{runs[-1].label}: d={runs[-1].d:.8e} solve {runs[-1].solve:.3f} s {runs[-1].note}")
    rex = run_exudyn(sd, *ref_ex, "quadratic", threads=th, reps=1)
    log(f"reference {rex.label}: d={rex.d:.8e} solve {rex.solve:.3f} s {rex.note}")
    if not rex.ok:
        print("Exudyn reference failed:", rex.note)
        return 1

    # ---- diagnostics: solver tolerances, initial accelerations, threads
    diag = []
    m_chk = 4
    a = next(r for r in runs if r.code == "flextop" and r.per_bar == m_chk and r.h == H0)
    b = run_flextop(sd, m_chk, H0, tol=1e-12, reps=1)
    diag.append(("flextop tol 1e-10 -> 1e-12", f"m={m_chk}", f"{(b.d - a.d) / a.d:+.1e}", mm(traj_diff(a, b))))
    for elem, pb in (("linear", m_chk), ("quadratic", 1)):
        a = next(r for r in runs if r.element == "GE2D " + elem and r.per_bar == pb and r.h == H0)
        b = run_exudyn(sd, pb, H0, elem, rel_tol=1e-10, abs_tol=1e-6, modified=False, threads=th, reps=1)
        if b.ok:
            diag.append((f"Exudyn {elem}: rel/abs 1e-8/1e-4 modified Newton -> 1e-10/1e-6 full Newton",
                         f"m={pb}", f"{(b.d - a.d) / a.d:+.1e}", mm(traj_diff(a, b))))
        else:
            diag.append((f"Exudyn {elem}: tight tolerance", f"m={pb}", b.note, "—"))
    # Exudyn's computeInitialAccelerations ignores the drives' prescribed acceleration
    # (theta'' = 2 rad/s^2 at t=0); flextop starts from consistent accelerations. With linear
    # elements both mass matrices are identical, so flextop's q''(0) is consistent for Exudyn too.
    sim2 = simulation(2)
    res2 = sim2.run(np.full(sim2.n_design, X_DENSITY), h=H0, rho_inf=RHO_INF)
    a = next(r for r in runs if r.element == "GE2D linear" and r.per_bar == 2 and r.h == H0)
    b = run_exudyn(sd, 2, H0, "linear", threads=th, reps=1, initial_acc=np.asarray(res2.qddot[0]))
    diag.append(("Exudyn: a0 from its EOM (drive acceleration ignored) -> consistent a0 (flextop's)",
                 "m=2", f"{(b.d - a.d) / a.d:+.1e}", mm(traj_diff(a, b))))
    a = next(r for r in runs if r.element == "GE2D linear" and r.per_bar == 8 and r.h == H0)
    th2 = 2 if th == 1 else 1
    b = run_exudyn(sd, 8, H0, "linear", threads=th2, reps=1)
    diag.append((f"Exudyn threads {th} -> {th2} (solve time {a.solve:.3f} s -> "
                 f"{b.solve:.3f} s)", "m=8", f"{(b.d - a.d) / a.d:+.1e}", mm(traj_diff(a, b))))
    log("diagnostics done")

    d_star = 0.5 * (rft.d + rex.d)
    own = {"flextop": rft, "Exudyn": rex}
    other = {"flextop": rex, "Exudyn": rft}

    lines = []
    w = lines.append
    w("# flextop vs Exudyn: two-link robot arm (x = 0.4 on every bar)")
    w("")
    w(f"- Command: `python {' '.join([Path(sys.argv[0]).as_posix()] + list(sys.argv[1:] if argv is None else argv))}`"
      f"{' (quick)' if args.quick else ''}")
    w(f"- Date: {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}")
    w(f"- Machine: {machine()}")
    w(f"- Versions: flextop {getattr(flextop, '__version__', '?')}, exudyn {exu.__version__}, numpy {np.__version__}")
    w(f"- Wall time of this benchmark: {time.perf_counter() - t_start:.0f} s")
    w("")
    w("## Settings")
    w("")
    s = sd.section
    w(f"- Scene: `flextop.scenes.robot_arm(split=m)`, t in [0, {sd.t_end:g}] s, no gravity, 5 kg tip mass; "
      f"section at x = {X_DENSITY} (SIMP p = {sd.p:g}): EA = {s['EA']:.6g} N, EI = {s['EI']:.6g} N m², "
      f"κGA = {s['GAk']:.6g} N, ρA = {s['rhoA']:.6g} kg/m, ρI = {s['rhoI']:.6g} kg m.")
    w(f"- Both: generalized-α (Chung–Hulbert) with ρ∞ = {RHO_INF}, index-3 position-level constraints, fixed "
      "step h, start undeformed at rest.")
    w(f"- flextop: co-rotational beam with exact linear Timoshenko local stiffness, consistent linear-interpolation "
      f"mass (ρA, ρI); `sim.run(x, h=h, rho_inf={RHO_INF}, tol={FLEXTOP_TOL:g})` (relative Newton tolerance, full "
      "Newton, consistent initial accelerations incl. the drives').")
    w("- Exudyn: `ObjectBeamGeometricallyExact2D` (Simo–Reissner, shear deformable, rotary inertia ρI, "
      "`includeReferenceRotations=False`) on `NodeRigidBody2D` nodes; **linear** = 2-node element (linear "
      "interpolation, 1-point reduced integration of elastic forces, consistent mass); **quadratic** = 3-node "
      "element (quadratic interpolation, 3-point Gauss; 5-point Gauss mass), m elements per bar on flextop's "
      "split = 2m nodes (integration rules as in Exudyn's C++ source). "
      "Joints: `CoordinateConstraint` (x, y, and the rotation with `offsetUserFunction` = θ(t) − θ(0)); tip mass "
      "`ObjectMassPoint2D`.")
    w(f"- Exudyn solver: `SolveDynamic(GeneralizedAlpha)`, spectralRadius {RHO_INF}, `useIndex2Constraints=False` "
      f"(index 3), `adaptiveStep=False`, Newton relativeTolerance {EXU_REL_TOL:g} / absoluteTolerance "
      f"{EXU_ABS_TOL:g} (L2 norm of [force residual; constraint violation]), modified Newton (Exudyn default), "
      f"`EigenSparse` with `reuseAnalyzedPattern`, {th} thread(s), `computeInitialAccelerations=True`.")
    w("- d = (1/t_f) ∫|e|² dt by the trapezoid rule on the step times, e = r_tip − r_rigid, computed by the "
      "same function for both codes.")
    w(f"- References: flextop m = {ref_ft[0]}, h = {ref_ft[1]:g}; Exudyn quadratic m = {ref_ex[0]}, "
      f"h = {ref_ex[1]:g}. Common converged value d* = mean of the two references.")
    w("- Times: flextop 'run' = `sim.run` (everything), 'total' adds `Simulation(scene)`; Exudyn 'solve' = "
      "`SolveDynamic` only, 'total' adds building the mbs and `Assemble`. Minimum over up to 5 (flextop) / 3 "
      "(Exudyn) repetitions of runs shorter than 0.5 s / 1 s.")
    w("")
    w("## References and agreement")
    w("")
    w("| | d (m²) | vs d* | max \\|r_tip − r_tip(other ref)\\| (mm) | run/solve (ms) | total (ms) | DOFs |")
    w("|---|---|---|---|---|---|---|")
    for r in (rft, rex):
        w(f"| {r.label} | {r.d:.8e} | {pct(r.d / d_star - 1)} | {mm(traj_diff(r, other[r.code]))} | {ms(r.solve)} "
          f"| {ms(r.total)} | {r.ndof} |")
    w("")
    w(f"- d* = {d_star:.8e} m²; the two references differ by {rft.d / rex.d - 1:+.1e} (relative) in d and by "
      f"{mm(traj_diff(rft, rex))} mm in the tip trajectory (max over t; the tip deflection itself reaches "
      f"{mm(np.linalg.norm(rft.r - sd.rigid_tip(rft.t), axis=1).max())} mm).")
    for elem, code in (("co-rot. Timoshenko", "flextop"), ("GE2D linear", "Exudyn"), ("GE2D quadratic", "Exudyn")):
        for h in sorted({r.h for r in runs if r.element == elem}, reverse=True):
            rr = richardson(runs, elem, h)
            if rr:
                w(f"- Richardson m → ∞ (order 2, m = {rr[1]}, {rr[2]}) at h = {h:g}, {code} {elem}: "
                  f"d = {rr[0]:.8e} m² ({pct(rr[0] / d_star - 1)} vs d*)")
    w("")
    w("Same step size, finest discretization of each code (isolates the beam formulations from the time "
      "discretization, which dominates the trajectory error at h = 0.02 s):")
    w("")
    w("| h (s) | flextop | Exudyn | d flextop (m²) | d Exudyn (m²) | Δd/d | max\\|Δr_tip\\| (mm) |")
    w("|---|---|---|---|---|---|---|")
    hs = sorted({r.h for r in runs} | {rft.h, rex.h}, reverse=True)
    for h in hs:
        fa = finest(runs + [rft], lambda r: r.code == "flextop" and r.h == h)
        for elem in ("GE2D quadratic", "GE2D linear"):
            ea = finest(runs + [rex], lambda r: r.element == elem and r.h == h)
            if fa and ea:
                w(f"| {h:g} | m={fa.per_bar} | {elem.split()[-1]} m={ea.per_bar} | {fa.d:.8e} | {ea.d:.8e} | "
                  f"{pct(ea.d / fa.d - 1)} | {mm(traj_diff(fa, ea))} |")
    w("")
    w("## All runs")
    w("")
    w("Errors of d relative to each code's own reference, to the other code's reference and to d*; trajectory "
      "differences are max over the common step times of the tip position difference.")
    w("")
    w("| code | element | el./bar | h (s) | DOFs | d (m²) | err vs own ref | err vs other ref | err vs d* | "
      "max\\|Δr\\| own ref (mm) | max\\|Δr\\| other ref (mm) | Newton | run/solve (ms) | total (ms) |")
    w("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in runs:
        if not r.ok:
            w(f"| {r.code} | {r.element} | {r.per_bar} | {r.h:g} | {r.ndof} | {r.note} | | | | | | | | |")
            continue
        w(f"| {r.code} | {r.element} | {r.per_bar} | {r.h:g} | {r.ndof} | {r.d:.6e} | {pct(r.d / own[r.code].d - 1)} "
          f"| {pct(r.d / other[r.code].d - 1)} | {pct(r.d / d_star - 1)} | {mm(traj_diff(r, own[r.code]))} "
          f"| {mm(traj_diff(r, other[r.code]))} | {r.newton} | {ms(r.solve)} | {ms(r.total)} |")
    w("")
    w("## Run time at equal accuracy")
    w("")
    w("Cheapest run (by run/solve time) of each code whose d is within the target of d*; ratio = Exudyn / "
      "flextop (solve-only, and total incl. model construction).")
    w("")
    w("| target \\|d/d* − 1\\| | flextop: setting, err, run (ms) | Exudyn best: setting, err, solve (ms) | "
      "ratio (solve) | ratio (total) | Exudyn linear only: setting, solve (ms), ratio |")
    w("|---|---|---|---|---|---|")
    ratios = []
    for tgt in targets:
        def cheapest(pred):
            ok = [r for r in runs if r.ok and pred(r) and abs(r.d / d_star - 1) <= tgt]
            return min(ok, key=lambda r: r.solve) if ok else None

        f = cheapest(lambda r: r.code == "flextop")
        e = cheapest(lambda r: r.code == "Exudyn")
        el = cheapest(lambda r: r.element == "GE2D linear")
        fs_ = f"m={f.per_bar}, h={f.h:g}, {pct(f.d / d_star - 1)}, {ms(f.solve)}" if f else "not reached"
        es_ = f"{e.element.split()[-1]} m={e.per_bar}, h={e.h:g}, {pct(e.d / d_star - 1)}, {ms(e.solve)}" if e else "not reached"
        r1 = f"**{e.solve / f.solve:.1f}**" if (e and f) else "—"
        r2 = f"{e.total / f.total:.1f}" if (e and f) else "—"
        ls_ = (f"m={el.per_bar}, h={el.h:g}, {ms(el.solve)}, {el.solve / f.solve:.1f}" if (el and f)
               else "not reached")
        w(f"| {100 * tgt:g} % | {fs_} | {es_} | {r1} | {r2} | {ls_} |")
        ratios.append((tgt, f, e))
    w("")
    w("## Checks")
    w("")
    w("| change | setting | Δd/d | max\\|Δr_tip\\| (mm) |")
    w("|---|---|---|---|")
    for c in diag:
        w(f"| {c[0]} | {c[1]} | {c[2]} | {c[3]} |")
    w("")
    w("Notes:")
    w("")
    ft0 = [r for r in runs if r.code == "flextop" and r.h == H0]
    spread = max(abs(r.d / rft.d - 1) for r in ft0)
    w(f"- Discretization: flextop's element is exact for end-loaded bars in the linear range, so at h = {H0:g} its d "
      f"is within {100 * spread:.2f} % of its reference for every m in {sorted(r.per_bar for r in ft0)} "
      "(refinement only improves inertia and geometric nonlinearity). "
      "Exudyn's 2-node element with one-point integration cannot bend with a linearly varying moment inside "
      "one element (double curvature is carried by shear only), so one element per bar is far too stiff and "
      "it converges as O(1/m²); the 3-node element converges much faster. Both converge to the same d.")
    w("- Trajectory differences against the references are dominated by the time discretization at h = 0.02 s "
      "(phase error and numerical damping of the second elastic mode, ~5.7 Hz, i.e. ~9 steps per period), "
      "for both codes alike; d is far less sensitive to it. Compare the codes at equal h (table above).")
    cw = {c: [r.cpu / r.solve for r in runs if r.code == c and r.ok and r.solve > 0.1] for c in own}
    w("- Threads: CPU time / wall time of the runs longer than 0.1 s: flextop "
      f"{np.mean(cw['flextop']):.2f}, Exudyn {np.mean(cw['Exudyn']):.2f} (both effectively single-threaded).")
    w("- Initial accelerations: Exudyn's `computeInitialAccelerations` ignores the drives' prescribed "
      "acceleration at t = 0 (documented limitation); the check above shows the effect on d is negligible.")
    w(f"- Exudyn's Newton residual stalls at round-off level (about 1e-8 for small models up to ~1e-5 for "
      f"the largest), so the absolute tolerance cannot be tighter than ~1e-4 for all sizes; the tolerance "
      "checks above show the chosen values do not affect d.")
    text = "\n".join(lines) + "\n"
    print()
    print(text)
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text(text)
        print(f"written to {output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
