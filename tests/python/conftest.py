"""Shared fixtures: paths, and small scenes used across the tests."""

import math
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import flextop
from flextop.discretization.refinement import extrapolated

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def trapezoid(start, end, acceleration, speed):
    """θ(t) − θ(0) of a trapezoidal law (triangular when ``speed`` is not reached) and its
    duration ``T``."""
    distance, sign = abs(end - start), math.copysign(1.0, end - start)
    ta = speed / acceleration
    if distance < acceleration * ta**2:
        ta = math.sqrt(distance / acceleration)
        speed = acceleration * ta
    T = distance / speed + ta

    def theta(t):
        t = np.asarray(t, dtype=float)
        rise = 0.5 * acceleration * t**2
        cruise = 0.5 * acceleration * ta**2 + speed * (t - ta)
        fall = distance - 0.5 * acceleration * (T - t) ** 2
        return sign * np.where(t < ta, rise, np.where(t < T - ta, cruise, np.where(t < T, fall, distance)))

    return theta, T


def cantilever(length: float = 1.0, split: int = 8, *, analysis: str = "dynamic") -> flextop.Scene:
    """A clamped aluminium cantilever along x (reference section), free end ``tip``."""
    scene = flextop.Scene("cantilever", analysis=analysis)
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    scene.node("root", 0.0, 0.0)
    scene.node("tip", length, 0.0)
    scene.beam("root", "tip", section="al", split=split, name="beam")
    scene.clamp("clamp", "root")
    return scene


def lattice_cantilever() -> flextop.SpatialScene:
    """A 4 × 2 × 2 lattice cantilever of 72 steel tubes (edges, face and body diagonals),
    0.6 m long, clamped at one face, pushed down (200 N) and sideways (100 N) at the other:
    static, x_min = 1e-3."""
    scene = flextop.SpatialScene("lattice cantilever", analysis="static")
    scene.section("steel", E=2.1e11, rho=7850.0, nu=0.3, shape="tube", outer=0.012, inner=0.010)
    scene.ground_structure("box", nx=4, ny=2, nz=2, length=0.6, height=0.15, width=0.15, section="steel",
                           connectivity="diagonals")
    for j in range(2):
        for k in range(2):
            scene.weld(f"wall{j}{k}", f"box[0,{j},{k}]")
    scene.load("down", "box[3,0,0]", force=(0.0, -200.0, 0.0))
    scene.load("side", "box[3,1,1]", force=(0.0, 0.0, 100.0))
    scene.design(x_min=1e-3)
    return scene


@pytest.fixture(scope="session")
def arm() -> flextop.Simulation:
    return flextop.Simulation(flextop.scenes.robot_arm())


@pytest.fixture(scope="session")
def arm_references():
    """d of the arm at x = 0.4 and 1 on 4× the elements per bar and 2176 steps, with the
    time error removed by Richardson extrapolation from 1088 steps."""
    sim = flextop.Simulation(flextop.scenes.robot_arm(split=4))
    out = {}
    for x in (0.4, 1.0):
        fine, coarse = (sim.run(x, h=1.3 / n).tip_deflection() for n in (2176, 1088))
        out[x] = fine + (fine - coarse) / 3
    return out


def on_accepted_grid(sim, d, x, responses, t_end: float, design=None, **settings):
    """What a run to a tolerance that accepted ``d`` for ``x`` returns, made again on that
    grid (at ``design``, default ``x``): the grid's run with gradients, extrapolated from half
    its steps where ``d`` is."""
    grid = sim.levels.at(d, x)
    made = [grid.run_with_sensitivities(x if design is None else design, responses, h=t_end / n, **settings)
            for n in ((d.steps, d.steps // 2) if d.extrapolated else (d.steps,))]
    return extrapolated(*made) if d.extrapolated else made[0]


def fourth_order(f, h: float):
    """The fourth-order central difference `(f(−2h) − 8f(−h) + 8f(h) − f(2h)) / 12h` of `f`
    at 0 (`f` of an offset: of a design along one variable, of a scene value)."""
    return (f(-2 * h) - 8 * f(-h) + 8 * f(h) - f(2 * h)) / (12 * h)


def assert_tip_gradient_is_exact(sim, x, direct, variables, tol: float = 1e-6) -> None:
    """The tip deflection's gradient ``direct`` (shape ``(1, n)``) at ``x`` against
    fourth-order differences along each of ``variables`` (step 1e-3), to ``tol`` of itself
    or of the gradient's largest entry."""
    for j in variables:
        def value(t, j=j):
            y = x.copy()
            y[j] += t
            return sim.run_with_sensitivities(y, ["tip_deflection"], method="direct")[0][0]
        assert fourth_order(value, 1e-3) == pytest.approx(direct[0, j], rel=tol, abs=tol * np.abs(direct).max())


def assert_worst_case_differences(problem, x, base, directions: int) -> None:
    """A worst-case scenario problem's constraint gradients at ``x`` (evaluation ``base``)
    against central differences along random directions (the densities' entries scaled by
    0.05, β's not), to 1e-5."""
    rng = np.random.default_rng(7)
    for _ in range(directions):
        v = rng.standard_normal(problem.n)
        v[:-1] *= 0.05
        eps = 1e-6
        plus, minus = problem.evaluate(x + eps * v), problem.evaluate(x - eps * v)
        fd = (plus.g - minus.g) / (2 * eps)
        exact = base.dg @ v
        assert np.allclose(fd, exact, rtol=1e-5, atol=1e-8 * np.max(np.abs(exact))), (fd, exact)
        assert (plus.f0 - minus.f0) / (2 * eps) == pytest.approx(base.df0 @ v, rel=1e-9)


def slider_crank_with_force_elements() -> dict:
    """The flexible slider-crank with a torsion spring-damper at the crank pin, a damper on
    the slider's travel, a spring from a wall to the slider, a ramped force on the slider
    and a PD servo at the rod's end."""
    spec = flextop.scenes.slider_crank(t_end=0.03, h=5e-4).to_dict()
    spec["rigid_bodies"].append({"name": "wall", "mass": 1.0, "inertia": 0.1, "position": [0.6, 0.0]})
    spec["joints"].append({"kind": "clamp", "name": "wall", "node": "wall"})
    spec["motors"] = [{"name": "push", "joint": "slide", "torque": 0.5, "table": {"t": [0.0, 0.03], "scale": [0.0, 1.0]}},
                      {"name": "servo", "joint": "B", "servo": {"kp": 0.2, "kd": 0.01, "motion": {
                          "kind": "trapezoidal", "start": 0.0, "end": 0.1, "acceleration": 50.0, "speed": 5.0}}}]
    spec["springs"] = [{"name": "torsion", "joint": "A", "k": 0.5, "c": 0.02, "rest": 0.02},
                       {"name": "friction", "joint": "slide", "c": 5.0},
                       {"name": "return", "nodes": ["slider", "wall"], "k": 200.0, "length": 0.14}]
    return spec


HEARS_CTRL_C = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
"""The first lines of a child process that is sent Ctrl-C. One started where SIGINT is ignored
(a background job, ``nohup``) inherits it ignored, and Python then installs no
``KeyboardInterrupt`` handler: the signal would go unheard and the test wait for ever."""


def seconds_to_interrupt(code: str, wait: float, exit_within: float, start_within: float = 120.0) -> float:
    """Runs the Python ``code`` in a subprocess that hears Ctrl-C (:data:`HEARS_CTRL_C`) — it
    prints ``ready``, works until a ``KeyboardInterrupt`` and then prints ``interrupted
    <time.monotonic()>`` —, sends it a SIGINT ``wait`` s after ``ready``, and returns the
    seconds from the signal to the interrupt; the process must then exit cleanly within
    ``exit_within`` s. Every wait has a deadline (``ready`` within ``start_within`` s, the
    rest within ``exit_within`` s) that fails the test."""
    process = subprocess.Popen([sys.executable, "-c", HEARS_CTRL_C + code], stdout=subprocess.PIPE, text=True)
    try:
        lines = _lines(process)
        assert _line(lines, start_within, "ready").strip() == "ready"
        time.sleep(wait)
        sent = time.monotonic()
        process.send_signal(signal.SIGINT)
        word, at = _line(lines, exit_within, "interrupted").split()
        assert word == "interrupted"
        try:
            assert process.wait(timeout=exit_within) == 0
        except subprocess.TimeoutExpired:
            pytest.fail(f"the child did not exit within {exit_within:g} s of its interrupt")
        return float(at) - sent
    finally:
        process.kill()
        process.wait()


def _lines(process: subprocess.Popen) -> queue.Queue:
    """The lines ``process`` prints, read on a thread of their own so that a wait for one
    can have a deadline; ``""`` once it closes its output."""
    lines: queue.Queue = queue.Queue()

    def read() -> None:
        for line in process.stdout:
            lines.put(line)
        lines.put("")

    threading.Thread(target=read, daemon=True).start()
    return lines


def _line(lines: queue.Queue, within: float, what: str) -> str:
    """The next of ``lines``, or a failed test if none comes within ``within`` s or the
    child ends first."""
    try:
        line = lines.get(timeout=within)
    except queue.Empty:
        pytest.fail(f"the child printed no {what!r} line within {within:g} s")
    if not line:
        pytest.fail(f"the child ended before printing {what!r}")
    return line


def assert_exact_gradients(sim, x: np.ndarray, responses: list[str], columns) -> None:
    """The gradients of ``responses`` at ``x``: the same values from both methods, direct =
    adjoint to 1e-9 of the largest entry, and fourth-order differences (step 5e-4) along the
    design variables ``columns`` within 1e-6 of each entry (or of 1e-3 of its row's largest)."""
    run = lambda xx, method="adjoint": sim.run_with_sensitivities(xx, responses, method=method, tol=1e-12)  # noqa: E731
    (f_adj, g_adj), (f_dir, g_dir) = run(x), run(x, "direct")
    np.testing.assert_array_equal(f_adj, f_dir)
    np.testing.assert_allclose(g_dir, g_adj, rtol=0, atol=1e-9 * np.abs(g_adj).max())
    for j in columns:
        step = np.zeros_like(x)
        step[j] = 1.0
        fd = fourth_order(lambda h: run(x + h * step)[0], 5e-4)
        for k, name in enumerate(responses):
            assert abs(fd[k] - g_adj[k, j]) <= 1e-6 * max(abs(g_adj[k, j]), 1e-3 * np.abs(g_adj[k]).max()), (name, j)
