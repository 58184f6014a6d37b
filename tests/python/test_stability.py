"""Stability at the extremes: spectral radius, step sizes from 1e-5 s to a single step,
densities down to 1e-6 with stiffness ratios up to 1e30, long runs and fast manoeuvres,
kinematic singularities, and degenerate or non-finite inputs."""

import math
import subprocess
import sys

import numpy as np
import pytest

import flextop
from flextop import DesignError, SceneError, SettingsError, SimulationError

from conftest import ROOT, trapezoid

NAN, INF = float("nan"), float("inf")
ARM_THETA, ARM_T = trapezoid(math.pi / 3, math.pi / 2, 2.0, 0.5)  # T = π/6 / 0.5 + 0.25 ≈ 1.297 s


# -- helpers ----------------------------------------------------------------------------


def vibration(res):
    """Kinetic + strain energy (J)."""
    return res.energies["kinetic"] + res.energies["strain"]


def balance(res):
    """Energy balance defect ``T + U − W_drive`` relative to the largest drive work."""
    e = res.energies
    return np.abs(e["kinetic"] + e["strain"] - e["drive_work"]).max() / np.abs(e["drive_work"]).max()


def finite(res):
    return all(np.isfinite(a).all() for a in (res.q, res.qdot, res.qddot, res.lam, vibration(res)))


def arm_constraint_drift(sim, res, theta):
    """Largest violation of the arm's joints over a run: shoulder position, elbow nodes
    apart, shoulder and elbow rotations against ``theta(t)``."""
    shoulder, (a, b) = sim.node("link1[0,1]"), (sim.node("link1[4,1]"), sim.node("link2[0,1]"))
    th = theta(res.time)
    return max(np.abs(res.positions[:, shoulder]).max(),
               np.abs(res.positions[:, a] - res.positions[:, b]).max(),
               np.abs(res.rotations[:, shoulder] - th).max(),
               np.abs(res.rotations[:, b] - res.rotations[:, a] - th).max())


def convergence_ratio(values):
    """``(v_h − v_{h/2}) / (v_{h/2} − v_{h/4})``: 4 for a second-order scheme."""
    a, b, c = values
    return (a - b) / (b - c)


# -- 1. spectral radius ------------------------------------------------------------------


def test_spectral_radius_orders_the_decay_of_vibration_after_the_manoeuvre(arm):
    """Once the drives hold (t > T) the arm vibrates freely: generalized-α dissipates the
    vibration energy fastest for ρ∞ = 0, less for 0.5, and conserves it for ρ∞ = 1."""
    kept = {}
    for rho in (0.0, 0.5, 1.0):
        res = arm.run(0.4, t_end=3.0, h=0.02, rho_inf=rho)
        assert res.newton["max"] <= 6, rho  # 4 observed for every ρ∞
        e = vibration(res)
        after = np.searchsorted(res.time, ARM_T)  # first step wholly after the manoeuvre
        kept[rho] = e[-1] / e[after]
    # observed: 0.657, 0.980, 0.9990
    assert kept[0.0] < 0.8
    assert kept[0.0] < kept[0.5] - 0.1
    assert kept[0.5] < kept[1.0]
    assert abs(kept[1.0] - 1) < 1e-2


# -- 2. step sizes ----------------------------------------------------------------------


def test_tiny_steps_stay_second_order_without_conditioning_blow_up(arm):
    """With h = 1e-5 … 4e-5 the index-3 equations stay well conditioned (scaled rows and
    multipliers): Newton needs ≤ 3 iterations, the tip converges at second order (ratio 4)
    and the multipliers — joint reactions — agree across h instead of growing as 1/h²."""
    runs = {h: arm.run(0.4, t_end=0.02, h=h) for h in (4e-5, 2e-5, 1e-5)}
    for h, res in runs.items():
        assert res.newton["max"] <= 3, h  # 2 observed
        assert finite(res)
        assert np.abs(res.positions[:, arm.node("link1[0,1]")]).max() < 1e-15
    tips = [runs[h].positions[-1, arm.tip] for h in (4e-5, 2e-5, 1e-5)]
    ratio = np.linalg.norm(tips[0] - tips[1]) / np.linalg.norm(tips[1] - tips[2])
    assert 3.5 < ratio < 4.5  # 4.01 observed
    coarse, fine = runs[4e-5], runs[1e-5]
    for name in ("shoulder", "elbow"):  # 2.566 and 1.248 N m at t = 0.02 s, within 2e-6
        assert fine.motor_torques[name][-1] == pytest.approx(coarse.motor_torques[name][-1], rel=1e-4)
    every_fourth = fine.lam[::4]
    assert every_fourth.shape == coarse.lam.shape
    assert np.abs(every_fourth - coarse.lam).max() < 1e-2 * np.abs(fine.lam).max()  # 8e-4 observed


@pytest.fixture(scope="module")
def fine_arm(arm):
    return arm.run(0.4, t_end=1.3, h=0.0025)


@pytest.mark.parametrize("h", [0.05, 0.1, 0.325, 1.3])
@pytest.mark.parametrize("rho", [0.0, 0.8])
def test_huge_steps_complete_with_bounded_error_or_fail_clearly(arm, fine_arm, h, rho):
    """Steps up to the whole manoeuvre (one step of 1.3 s) either complete with finite
    results whose tip error against a fine run stays below twice the elastic deflection
    itself, or raise a SimulationError naming the time — never NaN."""
    try:
        res = arm.run(0.4, t_end=1.3, h=h, rho_inf=rho)
    except SimulationError as error:
        assert "t = " in str(error) and "residual" in str(error)
        return
    assert finite(res) and res.time[-1] == pytest.approx(1.3)
    assert res.newton["max"] <= 12  # 5–8 observed
    k = np.rint(res.time / 0.0025).astype(int)
    error = np.linalg.norm(res.positions[:, arm.tip] - fine_arm.positions[k, arm.tip], axis=1).max()
    deflection = np.linalg.norm(fine_arm.tip_error(), axis=1).max()  # 7.6 cm
    assert error < 2 * deflection  # ≤ 1.65 × observed
    # The constraints are positions: exact at every step, however coarse.
    assert arm_constraint_drift(arm, res, ARM_THETA) < 1e-12


def test_coarse_steps_keep_the_deflection_within_ten_percent(arm, fine_arm):
    """With ρ∞ = 0.8 the mean squared tip deflection d of h = 0.05 and 0.1 s stays within
    10 % of the converged value (0.3 % and 7.6 % observed)."""
    for h in (0.05, 0.1):
        assert arm.run(0.4, h=h).tip_deflection() == pytest.approx(fine_arm.tip_deflection(), rel=0.1), h


# -- 3. extreme densities and stiffness ratios -------------------------------------------


def alternating(sim, low):
    x = np.ones(sim.n_design)
    x[::2] = low
    return x


def test_stiffness_ratio_1e9_is_accurate_and_second_order():
    """p = 3 with x ∈ {1e-3, 1}: stiffness ratio exactly 1e9 between neighbouring bars. The
    run completes, the joints hold to round-off, energy balances, and d converges at second
    order in h."""
    sim = flextop.Simulation(flextop.scenes.robot_arm(p=3, x_min=1e-3))
    x = alternating(sim, 1e-3)
    assert (x.min() / x.max()) ** 3 == pytest.approx(1e-9)
    runs = {h: sim.run(x, h=h) for h in (0.02, 0.01, 0.005)}
    for h, res in runs.items():
        assert finite(res) and res.newton["max"] <= 6, h  # ≤ 5 observed
        assert arm_constraint_drift(sim, res, ARM_THETA) < 1e-12
    assert np.abs(runs[0.01].positions[:, sim.node("link1[0,1]")]).max() < 1e-9
    assert balance(runs[0.01]) < 5e-3  # 1.9e-3 observed
    ratio = convergence_ratio([runs[h].tip_deflection() for h in (0.02, 0.01, 0.005)])
    assert 3.5 < ratio < 4.5  # 3.92 observed


@pytest.mark.parametrize("offset", [0, 1], ids=["even-bars-void", "odd-bars-void"])
def test_density_1e6_with_p5_completes_and_converges(offset):
    """x_min = 1e-6, p = 5, every other bar void: stiffness ratio 1e-30, fragments held only
    by voids float almost freely. The run completes with finite results (or fails with a
    clear SimulationError), the joints hold, and the energy balance error — the scheme's
    own — vanishes at second order."""
    sim = flextop.Simulation(flextop.scenes.robot_arm(p=5, x_min=1e-6))
    x = np.ones(sim.n_design)
    x[offset::2] = 1e-6
    defects = []
    for h in (0.01, 0.005, 0.0025):
        try:
            res = sim.run(x, h=h)
        except SimulationError as error:
            assert "t = " in str(error)
            return
        assert finite(res) and res.newton["max"] <= 6  # ≤ 4 observed
        assert arm_constraint_drift(sim, res, ARM_THETA) < 1e-12
        e = res.energies
        defects.append(np.abs(e["kinetic"] + e["strain"] - e["drive_work"]).max())
    # even bars void: 2.3e-2, 5.5e-3, 1.4e-3 J against 0.33 J of drive work
    assert 3.5 < defects[0] / defects[1] < 5 and 3.5 < defects[1] / defects[2] < 5


def test_all_bars_at_1e6_with_p5_leave_the_tip_mass_behind():
    """Every bar at x = 1e-6 with p = 5 (stiffness 1e-30 of full): nothing can push the 5 kg
    tip mass, so it stays at rest at its start (0, √3) while the drives turn the links; the
    drives do almost no work."""
    sim = flextop.Simulation(flextop.scenes.robot_arm(p=5, x_min=1e-6))
    res = sim.run(1e-6, h=0.02)
    assert finite(res)
    np.testing.assert_allclose(res.positions[:, sim.tip], np.broadcast_to([0.0, math.sqrt(3)], (len(res.time), 2)), atol=1e-6)
    assert arm_constraint_drift(sim, res, ARM_THETA) < 1e-12
    assert np.abs(res.energies["drive_work"]).max() < 1e-9  # 8e-13 J observed


# -- 4. long runs and fast manoeuvres -----------------------------------------------------


@pytest.fixture(scope="module")
def long_runs(arm):
    """100 × the manoeuvre: 130 s, 6500 steps of 0.02 s, the arm holding still after T."""
    return {rho: arm.run(0.4, t_end=130.0, h=0.02, rho_inf=rho) for rho in (0.8, 1.0)}


@pytest.mark.parametrize("rho", [0.8, 1.0])
def test_long_run_keeps_constraints_at_round_off_and_energy_bounded(arm, long_runs, rho):
    """Over 6500 steps the joints stay satisfied to round-off at every step (they are
    position constraints), Newton stays cheap, and the vibration energy after the manoeuvre
    never grows: it decays for ρ∞ = 0.8 and stays within 1 % for ρ∞ = 1."""
    res = long_runs[rho]
    assert len(res.time) == 6501 and res.time[-1] == pytest.approx(130.0)
    assert finite(res)
    assert res.newton["max"] <= 6  # 4 observed
    assert arm_constraint_drift(arm, res, ARM_THETA) < 1e-12  # 3e-16 observed
    e = vibration(res)
    after = np.searchsorted(res.time, ARM_T)
    assert e[after:].max() <= e[after] * (1 + 1e-3)  # ρ∞ = 1: 1 + 1.1e-4 observed
    if rho == 1.0:
        assert np.abs(e[after:] / e[after] - 1).max() < 1e-2  # 5.2e-3 observed
    else:
        assert e[-1] < 0.95 * e[after]  # 0.913 observed


@pytest.mark.parametrize("rho", [
    0.8,
    1.0,
])
def test_held_drives_do_no_work(long_runs, rho):
    """After the manoeuvre the drive angles are constant, so the motors do no work: the
    recorded drive work stays constant to 1e-3 of the vibration energy over 130 s."""
    res = long_runs[rho]
    after = np.searchsorted(res.time, ARM_T)
    w = res.energies["drive_work"]
    assert np.abs(w[after:] - w[after]).max() < 1e-3 * vibration(res)[after]  # ρ∞ = 0.8: 5.8e-4 J of 1.37 J


@pytest.mark.parametrize("acceleration, speed, h", [(20.0, 0.5, 0.02), (20.0, 5.0, 0.005)])
def test_fast_manoeuvres_keep_constraints_and_energy(acceleration, speed, h):
    """Ten times the acceleration (and of the speed): the joints still hold to round-off,
    Newton converges in a few iterations, the energy balances, and the vibration left after
    the manoeuvre never grows."""
    sim = flextop.Simulation(flextop.scenes.robot_arm(acceleration=acceleration, speed=speed))
    theta, T = trapezoid(math.pi / 3, math.pi / 2, acceleration, speed)
    res = sim.run(0.4, t_end=T + 1.5, h=h)
    assert finite(res)
    assert res.newton["max"] <= 8  # 4 and 3 observed
    assert arm_constraint_drift(sim, res, theta) < 1e-12
    assert balance(res) < 1e-2  # 5.8e-3 and 5.2e-3 observed
    e = vibration(res)
    after = np.searchsorted(res.time, T)
    assert e[after:].max() <= e[after] * (1 + 2e-3)  # 1 + 4e-5 and 1 + 6e-4 observed


# -- 5. near kinematic singularities ------------------------------------------------------


def stretching_arm():
    """The reference arm (θ1: π/3 → π/2) whose elbow opens from π/3 to 0: it ends fully
    stretched along the y axis, tip at (0, 2)."""
    scene = flextop.Scene("stretching_arm")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    link1 = scene.ground_structure("link1", nx=5, ny=3, length=1.0, height=0.1, section="al", angle=math.pi / 3)
    link2 = scene.ground_structure("link2", nx=5, ny=3, length=1.0, height=0.1, section="al",
                                   origin=link1.node(4, 1), angle=2 * math.pi / 3)
    scene.point_mass(link2.node(4, 1), 5.0)
    scene.pin("shoulder", link1.node(0, 1), drive=flextop.trapezoidal(math.pi / 3, math.pi / 2, acceleration=2.0, speed=0.5))
    scene.hinge("elbow", link1.node(4, 1), link2.node(0, 1), drive=flextop.trapezoidal(math.pi / 3, 0.0, acceleration=2.0, speed=1.0))
    scene.tip = link2.node(4, 1)
    return scene


def test_arm_driven_into_the_stretched_configuration_stays_regular():
    """An open chain driven at both joints has no singularity when stretched: the rigid
    trajectory matches the two-link kinematics to round-off up to the stretched end (0, 2),
    and the flexible run converges at second order in h."""
    sim = flextop.Simulation(stretching_arm())
    t = np.linspace(0.0, 2.0, 101)
    th1 = math.pi / 3 + trapezoid(math.pi / 3, math.pi / 2, 2.0, 0.5)[0](t)
    th2 = math.pi / 3 + trapezoid(math.pi / 3, 0.0, 2.0, 1.0)[0](t)  # elbow angle, → 0
    exact = np.c_[np.cos(th1) + np.cos(th1 + th2), np.sin(th1) + np.sin(th1 + th2)]
    np.testing.assert_allclose(sim.rigid_trajectory(sim.tip, t), exact, atol=1e-12)
    np.testing.assert_allclose(exact[-1], [0.0, 2.0], atol=1e-15)
    runs = {h: sim.run(0.4, t_end=2.0, h=h) for h in (0.02, 0.01, 0.005)}
    for h, res in runs.items():
        assert finite(res) and res.newton["max"] <= 6, h  # 4 observed
    assert balance(runs[0.005]) < 2e-3  # 7e-4 observed
    ratio = convergence_ratio([runs[h].tip_deflection() for h in (0.02, 0.01, 0.005)])
    assert 3.5 < ratio < 4.5  # 4.07 observed


# A crank–rocker four-bar: ground pins A = (0, 0) and D = (d, 0), crank AB = a driven at A,
# coupler BC = b, rocker CD = c. Coupler and rocker are collinear (toggle) when |BD| = b + c:
# a² + d² − 2ad cos θ* = (b + c)², the crank's limit angle.
A, B, C, D = 0.4, 0.6, 0.6, 1.0
TOGGLE = math.acos((A**2 + D**2 - (B + C) ** 2) / (2 * A * D))  # 1.9284 rad
CRANK_START = math.pi / 2


def four_bar_joint_c(theta):
    """Position of the coupler–rocker joint C for crank angle ``theta`` (upper branch)."""
    b_pos, d_pos = np.array([A * math.cos(theta), A * math.sin(theta)]), np.array([D, 0.0])
    v = d_pos - b_pos
    length = np.linalg.norm(v)
    along = (B**2 - C**2 + length**2) / (2 * length)
    across = math.sqrt(max(B**2 - along**2, 0.0))
    u = v / length
    return b_pos + along * u + across * np.array([-u[1], u[0]])


def four_bar(crank_end, split=4):
    b_pos, c_pos = (A * math.cos(CRANK_START), A * math.sin(CRANK_START)), four_bar_joint_c(CRANK_START)
    scene = flextop.Scene("four_bar")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    scene.node("A", 0.0, 0.0)
    scene.node("B_crank", *b_pos)
    scene.node("B_coupler", *b_pos)
    scene.node("C_coupler", *c_pos)
    scene.node("C_rocker", *c_pos)
    scene.node("D", D, 0.0)
    scene.beam("A", "B_crank", section="al", split=split, name="crank")
    scene.beam("B_coupler", "C_coupler", section="al", split=split, name="coupler")
    scene.beam("C_rocker", "D", section="al", split=split, name="rocker")
    scene.pin("motor", "A", drive=flextop.trapezoidal(CRANK_START, crank_end, acceleration=2.0, speed=0.5))
    scene.hinge("B", "B_crank", "B_coupler")
    scene.hinge("C", "C_coupler", "C_rocker")
    scene.pin("D", "D")
    scene.tip = "C_rocker"
    return scene


def test_an_extra_pin_that_locks_the_four_bar_is_named_when_the_scene_is_built():
    """In the frames' rigid coordinates the lock's rows depend on the others (9 coordinates,
    11 rows, rank 9: one row repeats D's pin of the rocker, the other conflicts with the
    drive); in the flexible model they do not, so it runs, while the rigid kinematics of the
    tip deflection fails, naming the joints."""
    free = flextop.Simulation(four_bar(2.2))
    assert free.mechanism == {"frames": 3, "mobility": 0, "redundant_rows": 0, "repeated_rows": 0, "over_constraining": []}
    scene = four_bar(2.2)
    scene.pin("lock", "C_rocker")
    with pytest.warns(flextop.errors.MechanismWarning, match=r"'motor', 'B', 'C', 'D', 'lock' over-constrain .* \(1 redundant"):
        sim = flextop.Simulation(scene)
    # The lock and D both pin the rocker to the ground: one row repeats, and the other
    # redundancy (the driven loop, now locked) is still named.
    assert sim.mechanism["redundant_rows"] == 2 and sim.mechanism["repeated_rows"] == 1
    res = sim.run(h=0.01, t_end=0.5)  # the flexible model runs: the drive bends the locked links
    assert np.isfinite(res.q).all() and res.newton["max"] <= 6
    with pytest.raises(flextop.SimulationError, match="'lock' over-constrain the rigid mechanism"):
        res.tip_deflection()


def test_toggle_angle_is_the_crank_limit():
    """At θ* coupler and rocker are collinear: |C − B| + |D − C| = |D − B| = b + c."""
    c_pos = four_bar_joint_c(TOGGLE)
    b_pos = np.array([A * math.cos(TOGGLE), A * math.sin(TOGGLE)])
    assert np.linalg.norm(c_pos - b_pos) + np.linalg.norm([D, 0.0] - c_pos) == pytest.approx(B + C, abs=1e-12)
    assert np.linalg.norm([D, 0.0] - b_pos) == pytest.approx(B + C, abs=1e-12)


def test_flexible_four_bar_driven_into_its_toggle_converges():
    """Driven exactly into the toggle (where the rigid rocker's acceleration is unbounded),
    the flexible four-bar still converges in a few Newton iterations per step, with finite
    results and an energy-balance error vanishing at second order."""
    sim = flextop.Simulation(four_bar(TOGGLE))
    T = trapezoid(CRANK_START, TOGGLE, 2.0, 0.5)[1]
    defects = []
    for h in (0.01, 0.005, 0.0025):
        try:
            res = sim.run(None, t_end=T + 0.2, h=h)
        except SimulationError as error:  # acceptable only with a clear message
            assert "t = " in str(error) and "residual" in str(error)
            return
        assert finite(res) and res.newton["max"] <= 8  # 4 observed
        e = res.energies
        defects.append(np.abs(e["kinetic"] + e["strain"] - e["drive_work"]).max() / np.abs(e["drive_work"]).max())
    assert defects[-1] < 2e-3
    assert 3.5 < defects[0] / defects[1] < 5 and 3.5 < defects[1] / defects[2] < 5  # 4.15, …


def test_rigid_four_bar_near_its_toggle_is_accurate():
    """1e-6 rad short of the toggle the kinematics is regular (barely): the rigid trajectory
    of C matches the circle intersection to 1e-9 m."""
    end = TOGGLE - 1e-6
    sim = flextop.Simulation(four_bar(end))
    T = trapezoid(CRANK_START, end, 2.0, 0.5)[1]
    t = np.linspace(0.0, T + 0.1, 101)
    theta = CRANK_START + trapezoid(CRANK_START, end, 2.0, 0.5)[0](t)
    exact = np.array([four_bar_joint_c(th) for th in theta])
    np.testing.assert_allclose(sim.rigid_trajectory("C_rocker", t), exact, atol=1e-9)


def test_rigid_four_bar_at_its_toggle_reports_the_singularity():
    """Driven to the toggle, where the joints' Jacobian loses rank, the rigid kinematics is
    singular: rigid_trajectory raises SimulationError naming the kinematic singularity."""
    sim = flextop.Simulation(four_bar(TOGGLE))
    T = trapezoid(CRANK_START, TOGGLE, 2.0, 0.5)[1]
    t = np.linspace(0.0, T + 0.1, 201)
    assert np.any(t >= T)
    with pytest.raises(SimulationError, match="kinematic singularity"):
        sim.rigid_trajectory("C_rocker", t)


def test_rigid_four_bar_driven_past_its_toggle_names_the_singularity():
    """Past the toggle the crank angle cannot be reached by the rigid mechanism: the error
    names the kinematic singularity it went through."""
    sim = flextop.Simulation(four_bar(TOGGLE + 1e-3))
    T = trapezoid(CRANK_START, TOGGLE + 1e-3, 2.0, 0.5)[1]
    with pytest.raises(SimulationError, match="kinematic singularity"):
        sim.rigid_trajectory("C_rocker", np.linspace(0.0, T, 201))


def parallelogram():
    """A four-bar with a = c = 0.5, b = d = 1 — a parallelogram — whose crank turns from
    π/3 to −π/3: at θ = 0 all four bars are collinear, a change point where the
    parallelogram and anti-parallelogram branches cross."""
    scene = flextop.Scene("parallelogram")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    b_pos = (0.5 * math.cos(math.pi / 3), 0.5 * math.sin(math.pi / 3))
    c_pos = (b_pos[0] + 1.0, b_pos[1])
    for name, pos in (("A", (0.0, 0.0)), ("B1", b_pos), ("B2", b_pos), ("C2", c_pos), ("C3", c_pos), ("D", (1.0, 0.0))):
        scene.node(name, *pos)
    scene.beam("A", "B1", section="al", split=4)
    scene.beam("B2", "C2", section="al", split=4)
    scene.beam("C3", "D", section="al", split=4)
    scene.pin("motor", "A", drive=flextop.trapezoidal(math.pi / 3, -math.pi / 3, acceleration=2.0, speed=0.5))
    scene.hinge("B", "B1", "B2")
    scene.hinge("C", "C2", "C3")
    scene.pin("D", "D")
    return scene


def test_parallelogram_change_point_is_reported_by_the_rigid_kinematics():
    """Sampled exactly at the change point (θ = 0 at t = T/2), the rigid kinematics raises
    SimulationError naming the kinematic singularity and its time; the flexible run goes
    through it on the parallelogram branch, C ending at (1 + cos(−π/3)/2, sin(−π/3)/2)."""
    sim = flextop.Simulation(parallelogram())
    T = trapezoid(math.pi / 3, -math.pi / 3, 2.0, 0.5)[1]
    with pytest.raises(SimulationError, match=r"kinematic singularity") as info:
        sim.rigid_trajectory("C3", np.linspace(0.0, T, 101))  # t[50] = T/2
    assert f"t = {T / 2:.6f} s" in str(info.value)
    res = sim.run(None, t_end=T + 0.1, h=0.01)
    assert finite(res) and res.newton["max"] <= 8  # 4 observed
    np.testing.assert_allclose(res.positions[-1, sim.node("C3")], [1.25, -math.sqrt(3) / 4], atol=1e-4)


# -- 6. degenerate geometry and non-finite inputs (complements test_scenes.py) ----------


def arm_with(mutate):
    spec = flextop.scenes.robot_arm().to_dict()
    mutate(spec)
    return spec


def add_load(**entry):
    return lambda s: s.setdefault("loads", []).append({"node": "link2[4,1]", "force": [0.0, 0.0], "moment": 0.0, **entry})


def table_drive(t, theta, **velocities):
    return lambda s: s["joints"][0].update(drive=flextop.motion_table(t, theta, **velocities))


@pytest.mark.parametrize(
    "mutate, culprit",
    [
        (lambda s: s["ground_structures"][0].update(origin=[NAN, 0.0]), "ground_structures[0] (link1).origin[0]"),
        (lambda s: s["ground_structures"][0].update(angle=INF), "ground_structures[0] (link1).angle"),
        (lambda s: s["ground_structures"][1].update(length=INF), "ground_structures[1] (link2).length"),
        (lambda s: s["ground_structures"][0].update(length=0.0), "ground_structures[0] (link1).length"),
        (lambda s: s["joints"][0]["drive"].update(start=NAN), "joints[0].drive.start"),
        (lambda s: s["joints"][0]["drive"].update(end=INF), "joints[0].drive.end"),
        (lambda s: s["joints"][0]["drive"].update(acceleration=NAN), "joints[0].drive.acceleration"),
        (lambda s: s["joints"][1]["drive"].update(speed=INF), "joints[1].drive.speed"),
        (lambda s: s["joints"][1]["drive"].update(t_start=NAN), "joints[1].drive.t_start"),
        (table_drive([0.0, NAN, 1.0], [0.0, 0.1, 0.2]), "joints[0].drive.t[1]"),
        (table_drive([0.0, 0.5, 1.0], [0.0, INF, 0.2]), "joints[0].drive.theta[1]"),
        (table_drive([0.0, 0.5, 1.0], [0.0, 0.1, 0.2], start_velocity=NAN), "joints[0].drive.start_velocity"),
        (table_drive([0.0, 0.5, 0.5], [0.0, 0.1, 0.2]), "joints[0].drive.t[2]"),
        (add_load(force=[NAN, 0.0]), "loads[0].force[0]"),
        (add_load(force=[0.0, INF]), "loads[0].force[1]"),
        (add_load(moment=NAN), "loads[0].moment"),
        (add_load(force=[1.0, 0.0], table={"t": [0.0, 1.0], "scale": [0.0, NAN]}), "loads[0].table.scale[1]"),
        (add_load(force=[1.0, 0.0], table={"t": [0.0, INF], "scale": [0.0, 1.0]}), "loads[0].table.t[1]"),
        (lambda s: s["point_masses"][0].update(inertia=NAN), "point_masses[0].inertia"),
        (lambda s: s["point_masses"][0].update(inertia=INF), "point_masses[0].inertia"),
        (lambda s: s["point_masses"][0].update(mass=NAN), "point_masses[0].mass"),
        (lambda s: s.update(gravity=[0.0, NAN]), "gravity[1]"),
        (lambda s: s["sections"]["aluminium"].update(diameter=INF), "sections.aluminium.diameter"),
        (lambda s: s["sections"]["aluminium"].update(E=INF), "sections.aluminium.E"),
        (lambda s: s["simulation"].update(t_end=NAN), "simulation.t_end"),
        (lambda s: s["simulation"].update(h=INF), "simulation.h"),
        (lambda s: s["design"].update(p=INF), "design.p"),
        (lambda s: s["design"].update(x_min=NAN), "design.x_min"),
    ],
)
def test_non_finite_scene_values_are_rejected_naming_the_culprit(mutate, culprit):
    """Every NaN or infinite number of a scene — positions, motion laws, loads, masses —
    is a SceneError whose message names the entry."""
    with pytest.raises(SceneError) as info:
        flextop.Simulation(arm_with(mutate))
    assert culprit in str(info.value)


def two_node_scene(a, b):
    scene = flextop.Scene("bar")
    scene.section("s", E=70e9, nu=0.3, rho=2700.0, diameter=0.02)
    scene.node("a", *a)
    scene.node("b", *b)
    scene.beam("a", "b", section="s")
    scene.clamp("c", "a")
    return scene


@pytest.mark.parametrize(
    "a, b, culprit",
    [((NAN, 0.0), (1.0, 0.0), "nodes[0] (a).x"), ((0.0, 0.0), (INF, 0.0), "nodes[1] (b).x"),
     ((0.0, 0.0), (1.0, -INF), "nodes[1] (b).y"), ((3.0, 4.0), (3.0, 4.0 + 1e-15), "zero-length bar: nodes 'a' and 'b' coincide")],
)
def test_non_finite_or_coincident_node_positions_are_rejected(a, b, culprit):
    """A node at NaN or infinity, or a bar whose ends agree to round-off, is a SceneError
    naming the node or bar."""
    with pytest.raises(SceneError) as info:
        flextop.Simulation(two_node_scene(a, b))
    assert culprit in str(info.value)


def test_tiny_bar_at_the_origin_is_rejected_as_zero_length():
    """A 1e-20 m bar hanging off the arm's shoulder (at the origin) is degenerate at the
    scale of a 2 m arm: SceneError naming the zero-length bar."""
    scene = flextop.scenes.robot_arm()
    scene.node("stub", 1e-20, 0.0)
    scene.beam("link1[0,1]", "stub", section="aluminium", name="stub")
    with pytest.raises(SceneError, match="zero-length bar"):
        flextop.Simulation(scene)


def test_huge_bar_is_not_reported_as_coincident_nodes():
    """Nodes (0, 0) and (1e200, 0) are 1e200 m apart: whatever the engine thinks of such a
    bar, it must not say the nodes coincide."""
    with pytest.raises(SceneError) as info:
        flextop.Simulation(two_node_scene((0.0, 0.0), (1e200, 0.0)))
    assert "coincide" not in str(info.value)


@pytest.mark.parametrize(
    "x, kwargs, error, culprit",
    [
        (INF, {}, DesignError, "x[0] (link1/bar0) = inf"),
        (-INF, {}, DesignError, "x[0] (link1/bar0) = -inf"),
        (0.4, {"h": INF}, SettingsError, "h: step size must be positive and finite, got inf"),
        (0.4, {"rho_inf": NAN}, SettingsError, "rho_inf: must lie in [0, 1], got NaN"),
        (0.4, {"rho_inf": INF}, SettingsError, "rho_inf"),
        (0.4, {"t_end": NAN}, SettingsError, "t_end: must be positive and finite, got NaN"),
        (0.4, {"t_end": INF}, SettingsError, "t_end"),
        (0.4, {"tol": NAN}, SettingsError, "tol"),
        (0.4, {"max_iter": -1}, SettingsError, "max_iter"),
        (0.4, {"h": 0.5, "t_end": 0.3}, SettingsError, "h: step size 0.5 exceeds t_end 0.3"),
    ],
)
def test_non_finite_run_settings_are_rejected_naming_the_culprit(arm, x, kwargs, error, culprit):
    """Infinite densities and NaN/infinite step, spectral radius, end time or tolerance
    raise DesignError or SettingsError naming the value."""
    with pytest.raises(error) as info:
        arm.run(x, **kwargs)
    assert culprit in str(info.value)


def limit_memory():  # the child of the next test: at most 512 MB of address space
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (1 << 29, 1 << 29))


def test_absurd_step_count_is_refused_promptly():
    """A step size that needs 1e12 steps cannot be stored: the run refuses it at once with
    a SettingsError naming h instead of running until memory is exhausted. (Run in a child
    process limited to 512 MB so that a regression cannot take the machine down.)"""
    code = (
        "import flextop\n"
        "sim = flextop.Simulation(flextop.scenes.robot_arm())\n"
        "try:\n"
        "    sim.run(0.4, t_end=1.0, h=1e-12)\n"
        "except flextop.SettingsError as e:\n"
        "    print('SettingsError', e)\n"
    )
    try:
        out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=10,
                             preexec_fn=limit_memory)
    except subprocess.TimeoutExpired:
        pytest.fail("the run with 1e12 steps was still going after 10 s")
    assert out.returncode == 0, out.stderr[:200]
    assert out.stdout.startswith("SettingsError h")
