"""The restart of generalized-α at a kink of a drive's law (`src/solver/kink.rs`): joint
reactions after the kink against closed-form inverse dynamics, and gradients through the
restart."""

import numpy as np
import pytest

import flextop
from conftest import assert_exact_gradients
from flextop.scenes.builder import trapezoidal
from test_mechanisms import closed_form, rigid_slider_crank
from test_parameters import assert_exact

KINK = 0.05  # s: the crank reaches 150 rad/s at 3000 rad/s²

def crank_torque_errors(h: float, rho_inf: float) -> np.ndarray:
    """The issue's rigid slider-crank, its crank driven from rest at 3000 rad/s² up to
    150 rad/s: the error of the crank torque at every state, relative to its peak, against
    closed-form inverse dynamics along the computed crank angle and rate with the law's own
    acceleration (the state on the kink reports the left limit, the ramp's)."""
    sim = rigid_slider_crank(h, trapezoidal(0.0, 1000.0, acceleration=3000.0, speed=150.0), 2 * KINK, rho_inf)
    res = sim.run()
    crank = 3 * sim.node("crank") + 2
    law = np.where(res.time < KINK + 1e-9, 3000.0, 0.0)
    *_, exact = closed_form(res.q[:, crank], res.qdot[:, crank], law)
    return np.abs(res.motor_torques["O"] - exact) / np.abs(exact).max()

@pytest.mark.parametrize("rho_inf, h", [(0.9, 1.5625e-5), (0.5, 6.25e-5)])
def test_crank_torque_after_a_kink_matches_inverse_dynamics_at_every_step(rho_inf, h):
    """Without the restart the torque alternates in sign after the kink, 7.8 % of its peak
    whatever the step (decaying by about ρ∞ per step). With it the error is a
    discretization error of first order (generalized-α's start-up transient on an index-3
    system, here driven by the jump of the slider's jerk): within 1e-3 of the peak at every
    state at these steps, the first after the kink included, and about halved with the
    step."""
    fine, coarse = crank_torque_errors(h, rho_inf), crank_torque_errors(2 * h, rho_inf)
    after = round(KINK / h) + 1  # the first state after the kink
    assert fine.max() < 1e-3, fine.max()
    assert coarse[after // 2 + 1] > 1.8 * fine[after]
    assert coarse[after // 2 + 1:].max() > 1.7 * fine[after:].max()

def kinked_flexible_slider_crank() -> dict:
    """The flexible slider-crank with its crank driven by the trapezoidal law above, the
    kink on the grid at step 100."""
    spec = flextop.scenes.slider_crank(t_end=0.06, h=5e-4).to_dict()
    spec["joints"][0]["drive"] = trapezoidal(0.0, 1000.0, acceleration=3000.0, speed=150.0)
    return spec

def test_gradients_through_a_restart_are_exact():
    """The restart's jump depends on the rod's densities (its mass matrix) and on the
    configuration (the hinges' Hessians): direct = adjoint to 1e-9 and fourth-order
    differences to 1e-6, for densities and for parameters that change the mass; without
    the restart's derivative the first density's compliance gradient is off by more."""
    spec = kinked_flexible_slider_crank()
    sim = flextop.Simulation(spec)
    x = np.linspace(0.4, 0.9, sim.n_design)
    responses = ["compliance", "torque_squared:crank", "tip_deflection"]
    assert_exact_gradients(sim, x, responses, range(sim.n_design))
    assert_exact(spec, x, responses, ["mass:slider", "rho:steel", "E:steel"])


def test_the_torque_peak_after_a_kink_is_held_to_the_tolerance():
    """A run to a tolerance holds the peaks of peak-limited responses (here the crank's
    torque, largest at the kink, the rod's stress and the force of the crank's hinge on
    the rod) to rtol as it holds values: within
    rtol of a reference on 8× the elements per bar and 8000 steps, whose own peaks move by
    less than 0.1 % on 16× and 16000 steps, and the estimates not below half the errors."""
    spec = kinked_flexible_slider_crank()
    spec["simulation"]["t_end"] = 0.1
    names = ["torque:crank", "stress", "reaction:A"]
    x = np.linspace(0.4, 0.9, flextop.Simulation(spec).n_design)
    out = flextop.Simulation(spec).run_with_sensitivities(x, names, rtol=1e-2, hold_gradients=False)
    reference = flextop.scenes.slider_crank(t_end=0.1, h=1.25e-5, split=8).to_dict()
    reference["joints"] = spec["joints"]
    peaks = flextop.Simulation(reference).run_with_sensitivities(x, names).peaks
    for name in names:
        error = abs(out.peaks[name] - peaks[name]) / abs(peaks[name])
        assert error <= 1e-2, (name, error)
        assert out.peak_errors[name] >= error / 2, (name, out.peak_errors[name], error)


def test_a_checkpointed_adjoint_and_a_run_with_local_error_control_restart_alike():
    """The adjoint's replays from checkpoints repeat the restart bit for bit (values equal,
    gradients = the stored sweep's to 1e-12); a run with local error control lands on the
    kink and restarts there, and its gradients, exact for the steps that ran, match the
    direct method's to 1e-9 and fourth-order differences on those steps to 1e-6."""
    spec = kinked_flexible_slider_crank()
    sim = flextop.Simulation(spec)
    x = np.linspace(0.4, 0.9, sim.n_design)
    names = ["compliance", "torque_squared:crank"]
    stored = sim.run_with_sensitivities(x, names, method="adjoint", memory="store")
    replayed = sim.run_with_sensitivities(x, names, method="adjoint", memory="checkpoints")
    np.testing.assert_array_equal(replayed.values, stored.values)
    np.testing.assert_allclose(replayed.gradients, stored.gradients, rtol=0, atol=1e-12 * np.abs(stored.gradients).max())
    adaptive = sim.run_with_sensitivities(x, names, local_tol=1e-4, method="adjoint")
    assert np.any(np.isclose(np.cumsum(adaptive.steps), KINK, rtol=0, atol=1e-12))
    direct = sim.run_with_sensitivities(x, names, local_tol=1e-4, method="direct")
    np.testing.assert_allclose(direct.gradients, adaptive.gradients, rtol=0, atol=1e-9 * np.abs(direct.gradients).max())
    on_steps = lambda xx: sim.sensitivities_fixed(xx, names, {"method": "direct"}, adaptive.steps).values  # noqa: E731
    for j in (0, sim.n_design - 1):
        step = np.zeros(sim.n_design)
        step[j] = 1.0
        fd = (on_steps(x - 2e-4 * step) - 8 * on_steps(x - 1e-4 * step) + 8 * on_steps(x + 1e-4 * step)
              - on_steps(x + 2e-4 * step)) / 12e-4
        np.testing.assert_allclose(adaptive.gradients[:, j], fd, rtol=1e-6)


def test_a_pendulums_pin_transmits_its_tension_3mg_cos_theta():
    """Released at rest from the horizontal, a point mass on a rigid link pulls its pin with
    the tension m g (3 cos θ − 2 cos θ₀) = 3 m g cos θ: ``reaction:pivot`` reads it at every
    state (its p = 2 mean against the trapezoidal mean of that law along the computed θ to
    1e-6, its peak 3 m g at the bottom to 1e-6)."""
    length, mass, g = 1.0, 2.0, 9.81
    sim = flextop.Simulation(flextop.scenes.pendulum(length=length, mass=mass, g=g, periods=0.5, h=1e-4))
    res = sim.run()
    cos_theta = -res.q[:, 3 * sim.node("bob") + 1] / length  # the bob starts at (L, 0)
    tension = 3 * mass * g * cos_theta
    t = res.time
    rms = np.sqrt(np.sum(0.5 * (tension[1:] ** 2 + tension[:-1] ** 2) * np.diff(t)) / t[-1])
    out = sim.run_with_sensitivities(np.zeros(0), ["reaction:pivot:p=2"])
    assert out.values[0] == pytest.approx(rms, rel=1e-6)
    assert out.peaks["reaction:pivot:p=2"] == pytest.approx(3 * mass * g, rel=1e-6)


def test_gradients_of_a_joints_reaction_are_exact():
    """The crank pin's and the rod's end hinge's forces on the kinked flexible slider-crank,
    through the restart: direct = adjoint to 1e-9 and fourth-order differences to 1e-6."""
    sim = flextop.Simulation(kinked_flexible_slider_crank())
    x = np.linspace(0.4, 0.9, sim.n_design)
    assert_exact_gradients(sim, x, ["reaction:A", "reaction:B:p=4"], range(sim.n_design))


def test_a_reaction_needs_a_joint_that_holds_a_position():
    sim = flextop.Simulation(kinked_flexible_slider_crank())
    with pytest.raises(flextop.SettingsError, match="unknown joint 'nope'"):
        sim.run_with_sensitivities(np.full(sim.n_design, 0.5), ["reaction:nope"])
