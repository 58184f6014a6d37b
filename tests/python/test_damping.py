"""Rayleigh damping of beams and of continuum members' cells, C = αM + βK: the modal
damping ratios ζ = α/(2ω) + βω/2 of a cantilever, the energy it dissipates, a rigid spin
left undamped by the stiffness part (a Kelvin–Voigt material in the co-rotated frame, on
the cells' Green–Lagrange strain rate), and exact gradients through it."""

import math
import re

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import curve_fit

import flextop
from flextop import scenes
from flextop.errors import SceneError
from flextop.scenes.builder import Scene

from conftest import assert_tip_gradient_is_exact, fourth_order


def cantilever(alpha: float, beta: float, h: float, t_end: float = 1.0) -> Scene:
    """A 1 m aluminium cantilever of eight elements, started from its equilibrium under a
    1 N tip load that is released over the first step, ringing with Rayleigh damping."""
    scene = Scene("damped cantilever", initial="equilibrium")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.01, rayleigh=(alpha, beta))
    for k in range(9):
        scene.node(f"n{k}", k / 8, 0.0)
    for k in range(8):
        scene.beam(f"n{k}", f"n{k + 1}", section="al", name=f"bar{k}")
    scene.clamp("root", "n0")
    scene.load("n8", force=(0.0, -1.0), table=([0.0, h], [1.0, 0.0]))
    scene.simulation(t_end=t_end, h=h, rho_inf=1.0)
    return scene


def ring_down(sim: flextop.Simulation, held: set[int], alpha: float, beta: float,
              h: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """The two lowest modes' ω (rad/s) and damping ratios, fitted to the free decay (after
    the first step, when the load is gone) of the run's modal coordinates ηₖ = φₖᵀ M q
    (mass-normalized modes of the structure with the coordinates ``held`` and those without
    mass left out), and the run's energies."""
    res = sim.run()
    m, k, _ = (a.toarray() for a in sim.linearize())
    free = np.array([d for d in range(m.shape[0]) if m[d, d] > 0.0 and d not in held])
    w2, shapes = eigh(k[np.ix_(free, free)], m[np.ix_(free, free)])
    omegas, zetas = np.sqrt(w2[:2]), []
    late = res.time >= h
    for w, shape in zip(omegas, shapes.T):
        phi = np.zeros(m.shape[0])
        phi[free] = shape
        eta = res.q @ (m @ phi)
        guess = alpha / (2 * w) + beta * w / 2
        ring = lambda t, a, z, wd, p: a * np.exp(-z * w * t) * np.cos(wd * t + p)  # noqa: B023, E731
        fit, _ = curve_fit(ring, res.time[late], eta[late], p0=[eta[0], guess, w, 0.0])
        zetas.append(fit[1])
    return omegas, np.array(zetas), res.energies


def modal_damping(alpha: float, beta: float, h: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`ring_down` of the beam cantilever (its clamped node's three coordinates held)."""
    return ring_down(flextop.Simulation(cantilever(alpha, beta, h)), {0, 1, 2}, alpha, beta, h)


def test_rayleigh_damping_gives_the_modal_damping_ratios_of_theory():
    """ζ = α/(2ω) + βω/2 for the two lowest modes of the cantilever (ζ₁ ≈ 0.9 %, ζ₂ ≈ 2.9 %,
    both parts acting): the first to 1e-4 of itself, the second converging at second
    order in the step to 5e-4 at h = 0.125 ms; what the damping dissipates closes the
    energy balance."""
    alpha, beta = 0.4, 2e-4
    errors = []
    for h in (2.5e-4, 1.25e-4):
        omegas, zetas, energies = modal_damping(alpha, beta, h)
        theory = alpha / (2 * omegas) + beta * omegas / 2
        errors.append(np.abs(zetas / theory - 1))
    assert errors[0][0] < 1e-4 and errors[1][0] < 1e-4
    assert 3.5 < errors[0][1] / errors[1][1] < 4.5 and errors[1][1] < 5e-4
    balance = energies["kinetic"] + energies["strain"] - energies["damping_work"]
    assert np.abs(balance - balance[0]).max() < 1e-4 * balance[0]
    assert energies["damping_work"][-1] < -0.5 * balance[0]  # most of it dissipated in 1 s


def spinning_bar(alpha: float, beta: float) -> Scene:
    """A flexible bar pinned at one end, spun at 5 rad/s without gravity."""
    scene = Scene("spinning bar")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02, rayleigh=(alpha, beta))
    for k in range(3):
        scene.node(f"n{k}", 0.25 * k, 0.0)
    for k in range(2):
        scene.beam(f"n{k}", f"n{k + 1}", section="al", split=2, name=f"bar{k}")
    scene.pin("root", "n0")
    scene.initial_rate("root", 5.0)
    scene.simulation(t_end=0.5, h=1e-3, rho_inf=0.9)
    return scene


def test_stiffness_proportional_damping_leaves_a_rigid_spin_alone():
    """β damps the deformation rate in the co-rotated frame: a bar spinning freely keeps its
    spin rate to 1e-6 (only the ringing of its sudden centrifugal stretch is damped, 1e-5
    of its kinetic energy); α damps the absolute velocity, as air drag would, and slows the
    spin as e^(−αt), to 1e-5."""
    spin, dissipated = {}, {}
    for alpha, beta in ((0.0, 0.0), (0.0, 1e-3), (0.5, 0.0)):
        sim = flextop.Simulation(spinning_bar(alpha, beta))
        res = sim.run()
        spin[alpha, beta] = res.qdot[-1, 3 * sim.node("n2") + 2]
        dissipated[alpha, beta] = -res.energies["damping_work"][-1] / res.energies["kinetic"][0]
    assert abs(spin[0.0, 1e-3] / spin[0.0, 0.0] - 1) < 1e-6
    assert 0 < dissipated[0.0, 1e-3] < 1e-5
    assert spin[0.5, 0.0] / spin[0.0, 0.0] == pytest.approx(math.exp(-0.5 * 0.5), rel=1e-5)


def test_gradients_through_rayleigh_damping_are_exact():
    """The flexible slider-crank with the rod damped by α and β: densities and the
    parameters E, ρ, α and β, direct = adjoint (stored and checkpointed) and fourth-order
    central differences. The stiffness part's derivative that the symmetric matrix leaves
    out is solved for exactly."""
    spec = scenes.slider_crank(t_end=0.03, h=5e-4).to_dict()
    spec["sections"]["steel"]["rayleigh"] = [20.0, 2e-4]
    sim = flextop.Simulation(spec)
    x = np.array([0.9, 0.5, 0.7, 0.4])
    responses, parameters = ["tip_deflection", "torque_squared:crank"], ["E:steel", "rho:steel", "alpha:steel", "beta:steel"]
    direct = sim.run_with_sensitivities(x, responses, parameters=parameters, method="direct")
    for memory in ("store", "checkpoints"):
        adjoint = sim.run_with_sensitivities(x, responses, parameters=parameters, method="adjoint", memory=memory)
        for a, d in ((adjoint.gradients, direct.gradients), (adjoint.parameter_gradients, direct.parameter_gradients)):
            np.testing.assert_allclose(a, d, rtol=0, atol=1e-9 * np.abs(d).max())
    value = lambda y, s=spec: flextop.Simulation(s).run_with_sensitivities(y, responses, method="direct").values  # noqa: E731
    step = 1e-4
    for i in range(4):
        unit = np.eye(4)[i]
        fd = fourth_order(lambda t: value(x + t * unit), step)
        np.testing.assert_allclose(direct.gradients[:, i], fd, rtol=0, atol=1e-6 * np.abs(fd).max())
    for j, (key, index) in enumerate([("E", None), ("rho", None), ("rayleigh", 0), ("rayleigh", 1)]):
        table = spec["sections"]["steel"]
        base = table[key] if index is None else table[key][index]

        def moved(t, key=key, index=index, base=base, table=table):
            entry = base + t if index is None else [base + t if i == index else v for i, v in enumerate(table[key])]
            return value(x, {**spec, "sections": {"steel": {**table, key: entry}}})

        fd = fourth_order(moved, 1e-3 * base)
        np.testing.assert_allclose(direct.parameter_gradients[:, j], fd, rtol=0, atol=1e-6 * np.abs(fd).max())
    plain = flextop.Simulation(scenes.slider_crank(t_end=0.03, h=5e-4)).run(x).response("tip_deflection")
    assert abs(direct.values[0] - plain) > 1e-3 * plain  # the damping acts


@pytest.mark.parametrize("rayleigh, message", [
    ([-0.1, 0.0], "sections.al.rayleigh[0]: must be non-negative"),
    ([0.0, -1e-4], "sections.al.rayleigh[1]: must be non-negative"),
])
def test_negative_rayleigh_coefficients_raise_scene_error(rayleigh, message):
    spec = cantilever(0.0, 0.0, 1e-3).to_dict()
    spec["sections"]["al"]["rayleigh"] = rayleigh
    with pytest.raises(SceneError, match=re.escape(message)):
        flextop.Simulation(spec)


def test_exact_damped_solves_settle_at_round_off():
    """A spinning bar under a ramped tip load with β damping at a coarse step: the gradients'
    iteration stalls at round-off (a change near 1e-14 of the solution) and counts as
    settled; direct = adjoint."""
    spec = spinning_bar(0.0, 1e-3).to_dict()
    spec["simulation"].update(h=1e-2, t_end=0.05)
    spec["loads"] = [{"node": "n2", "force": [0.0, 50.0], "table": {"t": [0.0, 0.05], "scale": [0.0, 1.0]}}]
    sim = flextop.Simulation(spec)
    x = np.array([0.8, 0.6])
    out = [sim.run_with_sensitivities(x, ["compliance"], parameters=["beta:al"], method=m) for m in ("direct", "adjoint")]
    np.testing.assert_allclose(out[0].gradients, out[1].gradients, rtol=1e-9)
    np.testing.assert_allclose(out[0].parameter_gradients, out[1].parameter_gradients, rtol=1e-9)


def member_cantilever(alpha: float, beta: float, h: float) -> Scene:
    """A 1 m × 50 mm aluminium plate, 10 mm thick, of 20 × 2 cells, pinned along its root
    edge, started from its equilibrium under a 10 N tip load released over the first step,
    ringing with its cells' Rayleigh damping for 0.2 s."""
    scene = Scene("damped member", initial="equilibrium")
    plate = scene.member("plate", nx=20, ny=2, length=1.0, height=0.05, thickness=0.01, E=70e9, nu=0.32, rho=2700.0,
                         rayleigh=(alpha, beta), solid_at_joints=False)
    for j in range(3):
        scene.pin(f"root{j}", plate.node(0, j))
    scene.load(plate.node(20, 1), force=(0.0, -10.0), table=([0.0, h], [1.0, 0.0]))
    scene.simulation(t_end=0.2, h=h, rho_inf=1.0)
    return scene


def member_modal_damping(alpha: float, beta: float, h: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`ring_down` of :func:`member_cantilever` (its pinned translations held)."""
    sim = flextop.Simulation(member_cantilever(alpha, beta, h))
    pinned = {3 * sim.node(f"plate[0,{j}]") + c for j in range(3) for c in (0, 1)}
    return ring_down(sim, pinned, alpha, beta, h)


def test_a_members_rayleigh_damping_gives_the_modal_damping_ratios_of_theory():
    """A plate's cells damped by ``rayleigh = (α, β)`` (the stiffness part a Kelvin–Voigt
    material on the Green–Lagrange strain rate): the two lowest modes ring down at
    ζ = α/(2ω) + βω/2 (ζ₁ ≈ 1.9 %, ζ₂ ≈ 9.6 %), the first to 3e-4 at h = 0.1 ms, both
    converging at second order in the step; kinetic plus strain energy less what the damping
    dissipated stays put (to 1e-3, also falling with the step) while most of it is
    dissipated."""
    alpha, beta = 2.0, 1e-4
    errors, drift = [], []
    for h in (2e-4, 1e-4):
        omegas, zetas, energies = member_modal_damping(alpha, beta, h)
        errors.append(np.abs(zetas / (alpha / (2 * omegas) + beta * omegas / 2) - 1))
        balance = energies["kinetic"] + energies["strain"] - energies["damping_work"]
        drift.append(np.abs(balance - balance[0]).max() / balance[0])
    assert errors[1][0] < 3e-4
    assert (3.5 < errors[0] / errors[1]).all() and (errors[0] / errors[1] < 4.5).all()
    assert drift[1] < 1e-3 and drift[0] / drift[1] > 3.0
    assert energies["damping_work"][-1] < -0.8 * balance[0]


def spinning_plate(alpha: float, beta: float) -> Scene:
    """A 0.4 m × 40 mm plate hung from an averaging ring on its root edge, pinned at the
    ring's centre and spun at 5 rad/s without gravity."""
    scene = Scene("spinning plate")
    plate = scene.member("plate", nx=8, ny=2, length=0.4, height=0.04, thickness=0.01, E=70e9, nu=0.32, rho=2700.0,
                         rayleigh=(alpha, beta))
    hub = scene.ring("hub", [plate.node(0, j) for j in range(3)], kind="averaging")
    scene.pin("root", hub)
    scene.initial_rate("root", 5.0)
    scene.simulation(t_end=0.5, h=1e-3, rho_inf=0.9)
    return scene


def test_a_members_stiffness_damping_leaves_a_rigid_spin_alone():
    """β damps the cells' strain rate, which a rigid spin does not have: the plate keeps its
    spin rate to 1e-6 (only the ringing of its centrifugal stretch is damped); α damps the
    absolute velocity and slows the spin as e^(−αt), to 1e-4."""
    spin = {}
    for alpha, beta in ((0.0, 0.0), (0.0, 1e-3), (0.5, 0.0)):
        sim = flextop.Simulation(spinning_plate(alpha, beta))
        spin[alpha, beta] = sim.run().qdot[-1, 3 * sim.node("hub") + 2]
    assert abs(spin[0.0, 1e-3] / spin[0.0, 0.0] - 1) < 1e-6
    assert spin[0.5, 0.0] / spin[0.0, 0.0] == pytest.approx(math.exp(-0.5 * 0.5), rel=1e-4)


def test_gradients_through_a_members_rayleigh_damping_are_exact():
    """The continuum arm (6 × 2 cells per link) with its cells damped by α and β: the tip
    deflection's gradient by direct and adjoint (stored and checkpointed) sensitivities to
    1e-9, and by fourth-order differences to 1e-6; the damping changes d."""
    spec = scenes.continuum_robot_arm(nx=6, ny=2, h=0.026).to_dict()
    plain = flextop.Simulation(spec)
    for member in spec["members"]:
        member["rayleigh"] = [5.0, 2e-3]
    sim = flextop.Simulation(spec)
    x = np.random.default_rng(3).uniform(0.3, 1.0, sim.n_design)
    f, direct = sim.run_with_sensitivities(x, ["tip_deflection"], method="direct")
    for memory in ("store", "checkpoints"):
        _, adjoint = sim.run_with_sensitivities(x, ["tip_deflection"], method="adjoint", memory=memory)
        np.testing.assert_allclose(adjoint, direct, rtol=0, atol=1e-9 * np.abs(direct).max())
    assert_tip_gradient_is_exact(sim, x, direct, (0, 9, 17))
    assert abs(f[0] - plain.run_with_sensitivities(x, ["tip_deflection"])[0][0]) > 1e-3 * f[0]


@pytest.mark.parametrize("rayleigh, message", [
    ([-0.1, 0.0], "members[0] (plate).rayleigh[0]: must be non-negative"),
    ([0.0, float("nan")], "members[0] (plate).rayleigh[1]"),
])
def test_bad_member_rayleigh_coefficients_are_named(rayleigh, message):
    spec = member_cantilever(0.0, 0.0, 1e-3).to_dict()
    spec["members"][0]["rayleigh"] = rayleigh
    with pytest.raises(SceneError, match=re.escape(message)):
        flextop.Simulation(spec)
