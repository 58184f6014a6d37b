"""Shared fixtures: paths, and small scenes used across the tests."""

import math
from pathlib import Path

import numpy as np
import pytest

import flextop

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
