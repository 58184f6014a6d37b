"""Dynamics: natural frequencies against Timoshenko beam theory, results and energies."""

import numpy as np
import pytest
from scipy.optimize import brentq

import flextop

from conftest import cantilever, trapezoid

E, NU, RHO, D = 70e9, 0.32, 2700.0, 0.02
G = E / (2 * (1 + NU))
A, I = np.pi * D**2 / 4, np.pi * D**4 / 64
KAPPA = 6 * (1 + NU) / (7 + 6 * NU)


def timoshenko_cantilever_frequencies(length: float, count: int) -> np.ndarray:
    """Bending frequencies (Hz) of a clamped-free Timoshenko beam with rotary inertia.

    Harmonic solutions ``w = Σ C f(x)`` with ``f ∈ {cosh αx, sinh αx, cos βx, sin βx}``,
    where ``α² = S₁ > 0`` and ``−β² = S₂ < 0`` are the roots of
    ``κGA·EI S² + ω²(κGA ρI + ρA EI) S + ρAω²(ρIω² − κGA) = 0``; the rotation follows from
    ``ψ' = w'' + (ρAω²/κGA) w``. The clamped (w = ψ = 0) and free (ψ' = 0, w' − ψ = 0) end
    conditions give a 4×4 determinant whose sign changes bracket the frequencies.
    """
    kga, ei, ra, ri = KAPPA * G * A, E * I, RHO * A, RHO * I

    def det(omega):
        w2 = omega**2
        S = np.roots([kga * ei, w2 * (kga * ri + ra * ei), ra * w2 * (ri * w2 - kga)])
        alpha, beta = np.sqrt(S.max()), np.sqrt(-S.min())
        c = ra * w2 / kga
        a, b = (alpha**2 + c) / alpha, (c - beta**2) / beta  # ψ coefficients
        L = length
        ch, sh, co, si = np.cosh(alpha * L), np.sinh(alpha * L), np.cos(beta * L), np.sin(beta * L)
        # columns: cosh, sinh, cos, sin;  w, ψ = a·(sinh, cosh) + b·(sin, −cos)
        m = np.array([
            [1.0, 0.0, 1.0, 0.0],                                             # w(0)
            [0.0, a, 0.0, -b],                                                 # ψ(0)
            [(alpha**2 + c) * ch, (alpha**2 + c) * sh, (c - beta**2) * co, (c - beta**2) * si],  # ψ'(L)
            [alpha * sh - a * sh, alpha * ch - a * ch, -beta * si - b * si, beta * co + b * co],  # w'(L) − ψ(L)
        ])
        return np.linalg.det(m / np.abs(m).max(axis=1, keepdims=True)) / np.cosh(alpha * L)

    grid = np.linspace(1.0, 2 * np.pi * 8000.0, 40000)
    values = [det(w) for w in grid]
    roots = [brentq(det, grid[i], grid[i + 1], xtol=1e-12) for i in range(len(grid) - 1) if values[i] * values[i + 1] < 0]
    return np.array(roots[:count]) / (2 * np.pi)


def test_timoshenko_reference_reduces_to_euler_bernoulli_when_slender():
    f = timoshenko_cantilever_frequencies(4.0, 1)[0]
    eb = 1.8751040687**2 / (2 * np.pi) * np.sqrt(E * I / (RHO * A * 4.0**4))
    assert f == pytest.approx(eb, rel=1e-4)


@pytest.mark.parametrize("length", [1.0, 0.25])
def test_cantilever_bending_frequencies_match_timoshenko_theory(length):
    exact = timoshenko_cantilever_frequencies(length, 3)
    sim = flextop.Simulation(cantilever(length, split=24))
    computed = sim.natural_frequencies(3)
    np.testing.assert_allclose(computed, exact, rtol=1e-2)
    # and they converge with refinement
    coarse = flextop.Simulation(cantilever(length, split=6)).natural_frequencies(3)
    assert np.all(np.abs(computed - exact) < np.abs(coarse - exact))


def test_results_carry_the_run(arm):
    res = arm.run(0.4)
    n = len(res.time)
    assert res.time[-1] == pytest.approx(1.3) and n == 66
    assert res.q.shape == (n, 90) and res.positions.shape == (n, 30, 2)
    np.testing.assert_allclose(res.positions[0], arm.model.reference_positions)
    # Constraints hold: the shoulder stays put, the drives follow θ(t) − θ(0).
    shoulder = arm.node("link1[0,1]")
    assert np.abs(res.positions[:, shoulder]).max() < 1e-12
    theta = reference_angle(res.time) - np.pi / 3
    np.testing.assert_allclose(res.rotations[:, shoulder], theta, atol=1e-12)
    elbow = arm.node("link1[4,1]"), arm.node("link2[0,1]")
    np.testing.assert_allclose(res.rotations[:, elbow[1]] - res.rotations[:, elbow[0]], theta, atol=1e-12)
    # Motor torques and the drive work agree: W = ∫ τ θ̇ dt.
    omega = np.gradient(theta, res.time)
    assert set(res.motor_torques) == {"shoulder", "elbow"}
    assert res.reactions["elbow"].shape == (n, 3)
    assert res.newton["mean"] >= 1 and res.newton["max"] <= 5  # 4 observed; max_iter is 20
    e = res.energies
    balance = e["kinetic"] + e["strain"] - e["drive_work"]
    assert np.abs(balance).max() < 0.05 * e["drive_work"].max()
    work = np.trapezoid(res.motor_torques["shoulder"] * omega + res.motor_torques["elbow"] * omega, res.time)
    assert work == pytest.approx(e["drive_work"][-1], rel=0.05)


def reference_angle(t):
    """θ(t) of the reference trapezoidal law (π/3 → π/2, 2 rad/s², 0.5 rad/s)."""
    return np.pi / 3 + trapezoid(np.pi / 3, np.pi / 2, 2.0, 0.5)[0](t)


def test_rigid_trajectory_matches_the_arm_kinematics(arm):
    t = np.linspace(0, 1.3, 27)
    th = reference_angle(t)
    exact = np.c_[np.cos(th) + np.cos(2 * th), np.sin(th) + np.sin(2 * th)]
    np.testing.assert_allclose(arm.rigid_trajectory(arm.tip, t), exact, atol=1e-12)


def test_tip_deflection_of_the_reference_arm(arm):
    d = arm.run(0.4).tip_deflection()
    fine = arm.run(0.4, h=0.0025).tip_deflection()
    assert d == pytest.approx(fine, rel=2e-3), "h = 0.02 is converged in time"
    assert 1e-3 < d < 1e-2
