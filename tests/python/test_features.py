"""Model features checked against theory: gravity, rotary inertia, consistent initial
accelerations, load tables, design groups."""

import numpy as np
import pytest

import flextop

from conftest import cantilever

E, NU, RHO, D = 70e9, 0.32, 2700.0, 0.02
A, I = np.pi * D**2 / 4, np.pi * D**4 / 64
KGA = 6 * (1 + NU) / (7 + 6 * NU) * E / (2 * (1 + NU)) * A


def test_self_weight_of_a_cantilever_matches_timoshenko_theory():
    """Uniform load q = ρAg: tip deflection qL⁴/(8EI) + qL²/(2κGA)."""
    scene = cantilever(1.0, split=16, analysis="static")
    spec = scene.to_dict()
    spec["gravity"] = [0.0, -9.81]
    res = flextop.Simulation(spec).run()
    q = RHO * A * 9.81
    exact = q / (8 * E * I) + q / (2 * KGA)
    assert -res.displacement("tip")[1] == pytest.approx(exact, rel=2e-3)


def test_point_mass_rotary_inertia_enters_the_mass_matrix():
    scene = cantilever(1.0, split=2)
    scene.point_mass("tip", 3.0, inertia=0.25)
    plain = cantilever(1.0, split=2)
    (m1, _, _), (m0, _, _) = flextop.Simulation(scene).linearize(), flextop.Simulation(plain).linearize()
    tip = flextop.Simulation(scene).node("tip")
    diff = (m1 - m0).toarray()
    np.testing.assert_allclose(np.diag(diff)[3 * tip:3 * tip + 3], [3.0, 3.0, 0.25])
    assert np.count_nonzero(diff) == 3


def test_initial_accelerations_and_multipliers_are_consistent(arm):
    """At t = 0 the drives prescribe θ̈ = 2 rad/s² at both joints, and with the structure
    at rest and undeformed the joints' reactions supply all the inertia forces: Σ of the
    shoulder reaction equals the rate of change of the total momentum, M q̈₀ summed."""
    res = arm.run(0.4, t_end=0.02)
    shoulder, e1, e2 = arm.node("link1[0,1]"), arm.node("link1[4,1]"), arm.node("link2[0,1]")
    acc = res.qddot[0].reshape(-1, 3)
    assert acc[shoulder, 2] == pytest.approx(2.0, rel=1e-12)
    assert acc[e2, 2] - acc[e1, 2] == pytest.approx(2.0, rel=1e-12)
    M = arm.linearize(0.4)[0]
    momentum_rate = (M @ res.qddot[0]).reshape(-1, 3)[:, :2].sum(axis=0)
    np.testing.assert_allclose(res.reactions["shoulder"][0, :2], momentum_rate, rtol=1e-9, atol=1e-9)


def test_load_table_scales_the_force_in_time():
    """A static load evaluated at t_end follows its piecewise-linear table: half the table's
    value gives half the (linear-range) deflection."""
    scene = cantilever(1.0, split=4, analysis="static")
    scene.load("tip", force=(0.0, -1.0), table=([0.0, 1.0, 2.0], [0.0, 1.0, 1.0]))
    sim = flextop.Simulation(scene)
    at_full, at_half = sim.run(t_end=1.5), sim.run(t_end=0.5)
    full, half = at_full.displacement("tip")[1], at_half.displacement("tip")[1]
    assert half == pytest.approx(0.5 * full, rel=1e-6)
    # The compliance Fᵀu takes the load at the run's own time: a quarter at half the load.
    assert at_half.response("compliance") == pytest.approx(0.25 * at_full.response("compliance"), rel=1e-6)
    assert at_full.response("compliance") == pytest.approx(-full, rel=1e-12)
    assert full == pytest.approx(-(1.0 / (3 * E * I) + 1.0 / KGA), rel=1e-6)


def test_a_design_group_is_the_sum_of_its_bars():
    """Two bars sharing one variable: its gradient is the sum of the gradients the two bars
    have as separate variables at the same density."""
    def scene(grouped):
        s = flextop.Scene("frame")
        s.section("al", E=E, nu=NU, rho=RHO, diameter=D)
        for name, (x, y) in {"a": (0, 0), "b": (0.5, 0), "c": (1.0, 0.2)}.items():
            s.node(name, x, y)
        s.beam("a", "b", section="al", group="g" if grouped else None, name="ab")
        s.beam("b", "c", section="al", group="g" if grouped else None, name="bc")
        s.pin("hub", "a", drive=flextop.trapezoidal(0.0, 1.0, acceleration=5.0, speed=1.0))
        s.point_mass("c", 1.0)
        s.tip = "c"
        s.simulation(t_end=0.8, h=0.01)
        return flextop.Simulation(s)

    grouped, separate = scene(True), scene(False)
    assert grouped.n_design == 1 and separate.n_design == 2
    fg, gg = grouped.run_with_sensitivities([0.6], ["tip_deflection"])
    fs, gs = separate.run_with_sensitivities([0.6, 0.6], ["tip_deflection"])
    assert fg[0] == pytest.approx(fs[0], rel=1e-12)
    assert gg[0, 0] == pytest.approx(gs[0].sum(), rel=1e-9)
