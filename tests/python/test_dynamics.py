"""Dynamics: results and energies."""

import numpy as np
import pytest

import flextop

from conftest import trapezoid

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


def test_modified_newton_reaches_the_states_of_full_newton(arm):
    """``newton="modified"`` keeps the step's first factorization while the residual falls
    tenfold per iteration: the same states to the tolerance, more (cheaper) iterations."""
    full, modified = arm.run(0.4), arm.run(0.4, newton="modified")
    assert np.abs(modified.q - full.q).max() < 1e-8
    assert modified.response("tip_deflection") == pytest.approx(full.response("tip_deflection"), rel=1e-9)
    assert modified.newton["total"] > full.newton["total"]
    with pytest.raises(flextop.SettingsError, match="newton: must be one of 'full', 'modified'"):
        arm.run(0.4, newton="exact")
