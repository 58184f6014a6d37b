"""Gradients of spatial motions to their drives' laws: a trapezoidal drive's ``end``,
``acceleration`` and ``speed`` on a revolute joint (the spatial slider-crank, its rod on a
ball and a Cardan joint; the spatial robot arm's tip deflection, whose rigid trajectory
the law moves too) and on a prismatic one (a cart carrying a flexible mast), against
fourth-order differences of runs with the law changed in the scene, and direct against
adjoint, also where the run restarts at the law's kinks; at an equilibrium, the closed
form. Names the scene lacks are refused."""

import copy
import math

import numpy as np
import pytest

from flextop import SettingsError, SpatialScene, SpatialSimulation
from flextop.scenes import motion_table, spatial_robot_arm, spatial_slider_crank, trapezoidal

LAW = ("end", "acceleration", "speed")


def kinks(law: dict) -> list[float]:
    """Where a trapezoidal law changes phase (s): its start, ``t_a``, ``T − t_a`` and ``T``
    after it (the start where it is not 0)."""
    distance, a, v = abs(law["end"] - law["start"]), law["acceleration"], law["speed"]
    t_a = v / a if distance * a >= v * v else math.sqrt(distance / a)
    total = distance / v + v / a if distance * a >= v * v else 2 * t_a
    t0 = law.get("t_start", 0.0)
    return [t0 + t for t in (t_a, total - t_a, total)] + ([t0] if t0 > 0 else [])


def cart(law: dict) -> dict:
    """A 2 kg cart driven along a tilted line by ``law`` (m), a 0.5 m steel mast of 1 cm
    diameter welded upright on it (its first mode near 29 Hz), under gravity."""
    scene = SpatialScene("cart", gravity=(0.0, 0.0, -9.81))
    scene.section("steel", E=2.1e11, rho=7850.0, nu=0.3, diameter=0.01)
    scene.rigid_body("cart", mass=2.0, inertia=(0.01, 0.02, 0.02), position=(0.0, 0.0, 0.0),
                     points={"mast": (0.0, 0.0, 0.0)})
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("top", (0.0, 0.0, 0.5))
    scene.beam("mast", "root", "top", section="steel", split=2)
    scene.weld("clamp", "cart.mast", "root")
    scene.prismatic("slide", "ground", "cart", axis=(1.0, 0.3, 0.2), drive=law)
    scene.simulation(t_end=0.75, h=0.004, rho_inf=0.8)
    return scene.to_dict()


def crank(**law) -> dict:
    return spatial_slider_crank(turn=2.0, t_end=0.6, h=0.004, **law).to_dict()


def assert_exact(spec: dict, joint: str, responses: list[str], step: float, x=None) -> np.ndarray:
    """Direct = adjoint to 1e-9, and fourth-order differences (steps of ``step`` of each
    value) to 1e-6, of each response's own gradient, beside the differences' noise (values
    reproducible to 1e-10, Newton's tolerance, over the step); the grid's nodes stay 0.1 of
    a step from every kink of the law as it is moved, so that no run restarts and the runs
    differenced are one scheme."""
    entry = next(j for j in spec["joints"] if j["name"] == joint)
    h = spec["simulation"]["h"]
    parameters = [f"{kind}:{joint}" for kind in LAW]
    sim = SpatialSimulation(spec)
    direct = sim.run_with_sensitivities(x, responses, parameters, method="direct")
    adjoint = sim.run_with_sensitivities(x, responses, parameters, method="adjoint")
    g, values = direct.gradient, np.abs(direct.values)
    for j, kind in enumerate(LAW):
        delta = step * abs(entry["drive"][kind])
        noise = 1e-10 * values / delta
        assert np.all(np.abs(adjoint.gradient[:, j] - g[:, j]) <= 1e-9 * np.abs(g[:, j]) + 1e-6 * noise), kind

        def moved(k: float, kind=kind, delta=delta) -> np.ndarray:
            changed = copy.deepcopy(spec)
            law = next(j for j in changed["joints"] if j["name"] == joint)["drive"]
            law[kind] += k * delta
            phase = np.array(kinks(law)) / h % 1.0
            assert np.all((phase > 0.1) & (phase < 0.9)), (kind, k, phase)
            return SpatialSimulation(changed).run_with_sensitivities(x, responses, []).values

        fd = (moved(-2) - 8 * moved(-1) + 8 * moved(1) - moved(2)) / (12 * delta)
        assert np.all(np.abs(g[:, j] - fd) <= 1e-6 * np.abs(fd) + noise), (kind, g[:, j], fd, noise)
    return g


def test_gradients_to_a_revolute_drives_law_are_exact():
    """The crank's law moves the slider, the rod and the torque the drive gives, also the
    work through the run's end (after the law's end, by its rate at t_a)."""
    spec = crank(acceleration=34.0, speed=6.3)
    g = assert_exact(spec, "crank", ["x:slider", "z:rod", "torque_squared:crank", "kinetic_energy"], step=3e-5)
    # The law is done before the run ends: the slider ends where the law's end puts it, the
    # other parameters' derivatives round-off (1e-20); the torque feels every parameter.
    assert abs(g[0, 0]) > 1e-3 and np.all(np.abs(g[2]) > 1e-3)


def test_gradients_to_a_prismatic_drives_law_through_a_flexible_mast_are_exact():
    spec = cart(trapezoidal(0.0, 0.3, acceleration=2.8, speed=0.69))
    # Newton to 1e-12: the mast's strain energy (6e-5 J) is small beside the forces Newton's
    # 1e-10 is relative to; at 1e-10 the differences' noise reached 1.4e-6 of its gradient.
    spec["simulation"]["tol"] = 1e-12
    g = assert_exact(spec, "slide", ["x:top", "strain_energy", "torque_squared:slide", "kinetic_energy"], step=3e-5)
    assert np.all(g[1] != 0)


def test_the_tip_deflection_of_the_spatial_arm_moves_with_its_base_drives_law():
    """The payload's deflection from its rigid trajectory (paper Eq. 40): the base's law
    moves both the flexible run and the rigid trajectory it is measured from."""
    spec = spatial_robot_arm(nx=3, t_end=0.72, h=0.012).to_dict()
    x = np.linspace(0.4, 1.0, SpatialSimulation(spec).n_design)
    g = assert_exact(spec, "turn", ["tip_deflection", "torque_squared:turn"], step=3e-5, x=x)
    assert np.all(g[0] != 0)


def test_at_an_equilibrium_after_the_law_the_drive_moves_the_cart_by_its_end():
    """Held at t_end, after the law has ended, the cart stands at the law's end: the mast's
    top moves along the slide's axis, x by its direction cosine per metre of ``end``; the
    speed and acceleration move nothing."""
    spec = cart(trapezoidal(0.0, 0.3, acceleration=2.8, speed=0.69))
    for method in ("direct", "adjoint"):
        out = SpatialSimulation(spec).run_with_sensitivities(
            None, ["x:top"], [f"{kind}:slide" for kind in LAW], equilibrium=True, method=method)
        np.testing.assert_allclose(out.gradient[0], [1 / math.sqrt(1 + 0.3**2 + 0.2**2), 0.0, 0.0], rtol=1e-9, atol=1e-12)


def test_at_an_equilibrium_after_the_law_the_crank_holds_the_slider_where_its_kinematics_say():
    """The crank's law ends at θ = 2 rad before t_end; held there, the slider stands at
    ``x = r cos θ + √(l² − r² sin² θ)`` (the pin at ``r (cos θ, sin θ cos α, −sin θ sin α)``),
    so ``dx/d end = −r sin θ − r² sin θ cos θ / √(l² − r² sin² θ)``: the revolute drive's
    row turns with the law (``λ ∂B/∂p`` in the force rows as well)."""
    r, l, theta = 0.15, 0.3, 2.0
    spec = crank()
    exact = -r * math.sin(theta) - r * r * math.sin(theta) * math.cos(theta) / math.sqrt(l * l - (r * math.sin(theta))**2)
    for method in ("direct", "adjoint"):
        out = SpatialSimulation(spec).run_with_sensitivities(
            None, ["x:slider"], [f"{kind}:crank" for kind in LAW], equilibrium=True, method=method)
        np.testing.assert_allclose(out.gradient[0], [exact, 0.0, 0.0], rtol=1e-8, atol=1e-12)


def test_where_the_run_restarts_at_the_laws_kinks_direct_equals_adjoint():
    """The default crank's law (t_a = 0.1 s) lands its first kink on the grid, where the
    run restarts: the jump, differentiated in both sweeps, agrees between them."""
    spec = spatial_slider_crank(t_end=0.3).to_dict()
    sim = SpatialSimulation(spec)
    parameters = [f"{kind}:crank" for kind in LAW]
    responses = ["x:slider", "torque_squared:crank", "kinetic_energy"]
    direct = sim.run_with_sensitivities(None, responses, parameters, method="direct").gradient
    adjoint = sim.run_with_sensitivities(None, responses, parameters, method="adjoint").gradient
    assert np.all(np.abs(adjoint - direct) <= 1e-9 * np.abs(direct)), (direct, adjoint)
    assert np.all(direct[:, 1:] != 0)


@pytest.mark.parametrize("responses, parameter, message", [
    (["x:slider"], "end:slide", "'slide' has no drive"),
    (["x:slider"], "speed:gear", "'gear' is no joint"),
    (["x:slider"], "end:pin", "'pin' has no drive"),
])
def test_drive_parameters_the_scene_lacks_are_named(responses, parameter, message):
    sim = SpatialSimulation(spatial_slider_crank(t_end=0.05))
    with pytest.raises(SettingsError, match=message):
        sim.run_with_sensitivities(None, responses, [parameter])


def test_a_table_drive_has_no_law_parameters():
    spec = crank()
    spec["joints"][0]["drive"] = motion_table([0.0, 0.1, 0.2], [0.0, 0.5, 1.5])
    with pytest.raises(SettingsError, match="'crank' has a table"):
        SpatialSimulation(spec).run_with_sensitivities(None, ["x:slider"], ["end:crank"], t_end=0.05)
