"""Statics against an independent exact linear Timoshenko frame solution."""

import numpy as np
import pytest

import flextop

from conftest import cantilever


def timoshenko_frame_element(p1, p2, E, G, A, I, kappa):
    """Global 6×6 stiffness of the exact (interdependent interpolation) Timoshenko frame
    element: axial EA/L, bending with Φ = 12EI/(κGAL²) (Przemieniecki)."""
    d = np.subtract(p2, p1)
    L = np.hypot(*d)
    c, s = d / L
    phi = 12 * E * I / (kappa * G * A * L**2)
    k = E * I / ((1 + phi) * L**3)
    a = E * A / L
    local = np.array([
        [a, 0, 0, -a, 0, 0],
        [0, 12 * k, 6 * L * k, 0, -12 * k, 6 * L * k],
        [0, 6 * L * k, (4 + phi) * L**2 * k, 0, -6 * L * k, (2 - phi) * L**2 * k],
        [-a, 0, 0, a, 0, 0],
        [0, -12 * k, -6 * L * k, 0, 12 * k, -6 * L * k],
        [0, 6 * L * k, (2 - phi) * L**2 * k, 0, -6 * L * k, (4 + phi) * L**2 * k],
    ])
    r = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    t = np.kron(np.eye(2), r)
    return t.T @ local @ t


def linear_frame_tip_deflection(sim, x, p, force, clamp, load_node):
    """Direct stiffness method on the bars of ``sim`` (one element each), SIMP-scaled."""
    E, nu, d = 70e9, 0.32, 0.02
    G, A, I = E / (2 * (1 + nu)), np.pi * d**2 / 4, np.pi * d**4 / 64
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    pos = np.asarray(sim.model.reference_positions)
    n = 3 * len(pos)
    K = np.zeros((n, n))
    bars = sim.bars
    for (a, b), v in zip(np.asarray(bars.nodes, dtype=int), bars.variable):
        dofs = [3 * a, 3 * a + 1, 3 * a + 2, 3 * b, 3 * b + 1, 3 * b + 2]
        K[np.ix_(dofs, dofs)] += x[v] ** p * timoshenko_frame_element(pos[a], pos[b], E, G, A, I, kappa)
    f = np.zeros(n)
    f[3 * load_node:3 * load_node + 2] = force
    free = np.setdiff1d(np.arange(n), [3 * clamp, 3 * clamp + 1, 3 * clamp + 2])
    u = np.zeros(n)
    u[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    return u[3 * load_node:3 * load_node + 3]


def test_static_truss_one_element_per_bar_is_converged_and_exact():
    x = np.random.default_rng(7).uniform(0.2, 1.0, 74)
    force = (0.0, -1.0)  # small load: the linear regime
    tips = {}
    for split in (1, 16):
        sim = flextop.Simulation(flextop.scenes.static_truss(split=split, force=force))
        tips[split] = sim.run(x).displacement("truss[4,1]")
    sim1 = flextop.Simulation(flextop.scenes.static_truss(force=force))
    exact = linear_frame_tip_deflection(sim1, x, 3.0, force, sim1.node("truss[0,1]"), sim1.node("truss[4,1]"))
    assert abs(tips[1][1] / tips[16][1] - 1) < 0.02, "m = 1 within 2 % of the refined deflection"
    assert abs(tips[16][1] / exact[1] - 1) < 1e-3, (tips[16], exact)
    assert abs(tips[1][2] / exact[2] - 1) < 1e-3, "rotation too"


def test_reference_truss_deflection_at_uniform_density():
    sim = flextop.Simulation(flextop.scenes.static_truss())
    tip = sim.run(0.4).displacement("truss[4,1]")
    exact = linear_frame_tip_deflection(sim, np.full(sim.n_design, 0.4), 3.0, (0.0, -100.0), sim.node("truss[0,1]"), sim.node("truss[4,1]"))
    assert tip[1] == pytest.approx(exact[1], rel=1e-3)
    assert tip[1] < 0


def test_load_stepping_reaches_large_rotations():
    scene = cantilever(1.0, 16, analysis="static")
    ei = 70e9 * np.pi * 0.02**4 / 64
    scene.load("tip", moment=np.pi * ei)  # half circle
    sim = flextop.Simulation(scene)
    res = sim.run(load_steps=8)
    assert res.displacement("tip")[2] == pytest.approx(np.pi, rel=1e-9)
    assert res.positions[sim.node("tip")] == pytest.approx([0.0, 2 / np.pi], abs=2e-3)


def test_a_roller_support_slides_and_turns_freely():
    """A simply supported beam, pinned at one end and on a roller at the other, under a
    central load: mid-span deflection PL³/(48EI) (Timoshenko's shear part made negligible),
    the roller's end sliding inwards by the bending's second-order shortening and turning
    by PL²/(16EI), free of the roller."""
    load, e, i = 100.0, 210e9, 1e-7
    s = flextop.Scene("simply supported", analysis="static")
    s.section("steel", E=e, rho=7800.0, nu=0.3, A=1e-3, I=i, kappa=1e6)
    for name, x in (("a", 0.0), ("m", 0.5), ("b", 1.0)):
        s.node(name, x, 0.0)
    s.beam("a", "m", section="steel", split=4)
    s.beam("m", "b", section="steel", split=4)
    s.pin("left", "a")
    s.roller("right", "b", axis=(1.0, 0.0))
    s.load("m", force=(0.0, -load))
    r = flextop.Simulation(s).run()
    assert r.displacement("m")[1] == pytest.approx(-load / (48 * e * i), rel=1e-6)
    u, v, phi = r.displacement("b")
    # The chord shortens by ∫ ½ w'² dx = (P/16EI)² L⁵ · 4/15; eight elements, to 3 %.
    assert v == pytest.approx(0.0, abs=1e-20) and u == pytest.approx(-(load / (16 * e * i)) ** 2 * 4 / 15, rel=3e-2)
    assert phi == pytest.approx(load / (16 * e * i), rel=1e-6)


def test_static_reactions_of_a_redundant_truss_have_exact_gradients():
    """The ten-bar truss is statically indeterminate: its members' and supports' reactions
    move with the densities. Their gradients (which read the multipliers' derivatives)
    against central differences, and direct against adjoint; before, both methods returned
    zero for the multipliers' share."""
    sim = flextop.Simulation(flextop.scenes.ten_bar_truss())
    x = np.random.default_rng(0).uniform(0.4, 1.0, sim.n_design)
    responses = ["reaction:joint3/m2", "reaction:support5", "compliance"]
    f, direct = sim.run_with_sensitivities(x, responses, method="direct")
    _, adjoint = sim.run_with_sensitivities(x, responses, method="adjoint")
    scale = np.abs(direct).max(axis=1, keepdims=True)
    assert np.all(np.abs(direct - adjoint) <= 1e-9 * scale)
    h = 1e-5
    for i in (0, 1, 5):
        step = h * np.eye(sim.n_design)[i]
        fd = (sim.run_with_sensitivities(x + step, responses)[0] - sim.run_with_sensitivities(x - step, responses)[0]) / (2 * h)
        assert np.all(np.abs(direct[:, i] - fd) <= 1e-6 * scale[:, 0]), (i, direct[:, i], fd)
    assert np.abs(direct[0]).max() > 1e3  # the share the multipliers carry: 1.1e4 … 5e4 N
