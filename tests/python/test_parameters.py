"""Gradients with respect to scene parameters: springs' k, c and rest, masses and
inertias, motors' torques and servo gains, sections' E, ρ and diameter, the arm of a point
pinned to the ground. Each
against fourth-order central differences of runs with the parameter changed in the scene,
and direct against adjoint; the pendulum's half period against dT/dL = T/(2L)."""

import copy
import math

import numpy as np
import pytest

import flextop
from flextop import scenes
from flextop.errors import SettingsError
from flextop.scenes.builder import Scene

from conftest import fourth_order, on_accepted_grid, slider_crank_with_force_elements


def entry(spec: dict, parameter: str) -> tuple[dict, str | int]:
    """The table and key (or index) of `parameter` in a scene dict."""
    kind, name = parameter.split(":")
    if name in spec.get("sections", {}):
        return spec["sections"][name], kind
    for j in spec.get("joints", []):
        if j["name"] == name and kind in ("end", "acceleration", "speed"):
            return j["drive"], kind
    for s in spec.get("springs", []):
        if s["name"] == name:
            return s, kind
    for m in spec.get("motors", []):
        if m["name"] == name:
            return (m, "torque") if kind == "torque" else (m["servo"], kind)
    body, _, point = name.partition(".")
    for b in spec.get("rigid_bodies", []):
        if b["name"] == body:
            return (b["points"][point], "xy".index(kind[-1])) if point else (b, kind)
    raise KeyError(parameter)


def assert_exact(spec: dict, x: np.ndarray, responses: list[str], parameters: list[str], rel: float = 1e-6,
                 step: float = 1e-3) -> np.ndarray:
    """Direct = adjoint to 1e-9 of each column's largest, and fourth-order central
    differences (steps of `step` of the value) to `rel` of each response's own difference
    (at least 1e-4 of the column's largest) or to their noise (1e-10 of the value over the
    step); returns the gradients."""
    sim = flextop.Simulation(spec)
    direct = sim.run_with_sensitivities(x, responses, parameters=parameters, method="direct")
    adjoint = sim.run_with_sensitivities(x, responses, parameters=parameters, method="adjoint")
    g = direct.parameter_gradients
    assert g.shape == (len(responses), len(parameters))
    for j, p in enumerate(parameters):
        scale = np.abs(g[:, j]).max()
        np.testing.assert_allclose(adjoint.parameter_gradients[:, j], g[:, j], rtol=0, atol=1e-9 * scale)
        table, key = entry(spec, p)
        value = table[key]
        delta = step * abs(value)

        def moved(t, p=p, value=value):
            changed = copy.deepcopy(spec)
            table, key = entry(changed, p)
            table[key] = value + t
            return flextop.Simulation(changed).run_with_sensitivities(x, responses, method="direct").values

        fd = fourth_order(moved, delta)
        # Each response against its own size (floored at 1e-4 of the column's largest, for
        # responses a parameter barely moves), so a large one hides no small one's error;
        # and no finer than the differences' own noise, from values reproducible to 1e-10
        # (Newton's tolerance), as the spatial engine's checks allow.
        scale = np.maximum(np.abs(fd), 1e-4 * np.abs(fd).max())
        noise = 1e-10 * np.abs(direct.values) / delta
        np.testing.assert_array_less(np.abs(g[:, j] - fd), rel * scale + noise + 1e-300, err_msg=p)
        assert np.abs(fd).max() > 0 or p.startswith(("mass:", "inertia:")), p
    return g


FORCE_ELEMENTS = ["k:torsion", "c:torsion", "rest:torsion", "c:friction", "k:return", "length:return",
                  "mass:slider", "mass:crank", "inertia:crank", "torque:push", "kp:servo", "kd:servo"]


@pytest.mark.parametrize("initial", ["rest", "equilibrium"])
def test_gradients_to_force_elements_masses_and_motors_are_exact(initial):
    """Every parameter kind of the slider-crank's force elements, bodies and motors, from
    rest and from the static equilibrium under gravity (q₀ then depends on them)."""
    spec = slider_crank_with_force_elements()
    if initial == "equilibrium":
        spec.update(gravity=[0.0, -9.81], initial="equilibrium")
    g = assert_exact(spec, np.array([0.9, 0.5, 0.7, 0.4]), ["tip_deflection", "torque_squared:crank"], FORCE_ELEMENTS)
    assert np.all(np.abs(g[1]) > 0)  # each one changes the drive's torque


def test_gradients_to_a_section_are_exact():
    """The slider-crank's rod: E (G follows through ν), ρ and the diameter move its
    stiffness, inertia and volume; the mean compliance reads the strain energy's own
    dependence on E."""
    spec = scenes.slider_crank(t_end=0.03, h=5e-4).to_dict()
    responses = ["tip_deflection", "torque_squared:crank", "compliance", "volume"]
    g = assert_exact(spec, np.array([0.9, 0.5, 0.7, 0.4]), responses, ["E:steel", "rho:steel", "diameter:steel"])
    assert g[3, 0] == 0 and g[3, 1] == 0 and g[3, 2] > 0


@pytest.mark.parametrize("initial", ["rest", "equilibrium"])
def test_gradients_to_drive_laws_are_exact(initial):
    """The arm's trapezoidal drives: the shoulder's end, acceleration and speed and the
    elbow's end move the driven rows (Φ = h(q) − g(t), and g̈(0) in the initial
    accelerations); a drive's work reads its rate ġ too, and the tip deflection the rigid
    trajectory (Φ_ρ ρ_p = e g_p at each state). A driven joint's final position is its
    law's: its gradient is ∂g/∂p exactly."""
    spec = scenes.robot_arm(t_end=1.2).to_dict()
    spec.update(gravity=[0.0, -9.81], initial=initial)
    sim = flextop.Simulation(spec)
    x = np.linspace(0.3, 1.0, sim.n_design)
    responses = ["compliance", "torque_squared:shoulder", "drive_work:elbow", "joint_position:shoulder",
                 "tip_deflection"]
    parameters = ["end:shoulder", "acceleration:shoulder", "speed:shoulder", "end:elbow"]
    g = assert_exact(spec, x, responses, parameters)
    assert np.all(g[4] != 0)  # the rigid trajectory the tip deflects from moves with the law
    # The shoulder decelerates at t = 1.2 s: s = D − ½a(T − t)², T = D/v + v/a.
    law = spec["joints"][0]["drive"]
    d, a, v = law["end"] - law["start"], law["acceleration"], law["speed"]
    rest = d / v + v / a - 1.2
    assert 0 < rest < v / a
    exact = [1 - a * rest / v, -0.5 * rest**2 + rest * v / a, -a * rest * (1 / a - d / v**2), 0.0]
    np.testing.assert_allclose(g[3], exact, rtol=1e-12, atol=1e-15)


def compound_pendulum(initial: str = "rest") -> dict:
    """A body with rotary inertia, turned, on a pin at its point, a torsion spring-damper
    and a ramped motor there, under gravity; from rest at its reference, or from the
    equilibrium the spring holds."""
    scene = Scene("compound pendulum", gravity=(0.0, -9.81), initial=initial)
    # Turned by 0.4 rad: the point is given in the body's frame, as arm_x and arm_y are.
    c, s = math.cos(0.4), math.sin(0.4)
    pivot = (-0.5 * c + 0.3 * s, 0.5 * s + 0.3 * c)
    scene.rigid_body("bob", mass=1.2, inertia=0.05, position=(0.5, -0.3), angle=0.4, points={"pivot": pivot})
    scene.pin("pivot", "bob.pivot")
    scene.joint_spring("spring", "pivot", k=20.0, c=0.3)
    scene.motor("kick", "pivot", torque=3.0, table=([0.0, 0.4], [0.0, 1.0]))
    scene.simulation(t_end=0.4, h=1e-3, rho_inf=0.9)
    return scene.to_dict()


@pytest.mark.parametrize("initial", ["rest", "equilibrium"])
def test_gradients_to_a_pivot_place_mass_and_inertia_are_exact(initial):
    """Moving the point pinned to the ground moves the pivot: the rows' pseudo-loads (and
    the initial accelerations' at acceleration level) give exact gradients, also from an
    equilibrium where the body has turned, so that the rows themselves change."""
    parameters = ["arm_x:bob.pivot", "arm_y:bob.pivot", "mass:bob", "inertia:bob", "k:spring", "c:spring",
                  "torque:kick"]
    assert_exact(compound_pendulum(initial), np.zeros(0), ["joint_position:pivot"], parameters)


def test_the_half_period_of_a_pendulum_grows_as_the_root_of_its_length():
    """T ∝ √(L/g): at the bottom, a quarter period in, the angle's gradient to the pivot's
    place over the angular rate gives dT/dL, which tends to T/(2L) at second order."""
    length, g = 1.0, 9.81
    quarter = scenes.pendulum_period(length, g, math.pi / 2) / 4
    errors = []
    for h in (2e-3, 1e-3, 5e-4):
        sim = flextop.Simulation(scenes.pendulum(length=length, g=g, periods=0.25, h=h))
        out = sim.run_with_sensitivities(np.zeros(0), ["joint_position:pivot"], parameters=["arm_x:bob.pivot"])
        # φ(T(L); L) = −π/2: dT/dL = −(∂φ/∂L)/φ̇ with L = −arm_x and φ̇ = −√(2g/L) there.
        slope = out.parameter_gradient("joint_position:pivot", "arm_x:bob.pivot") / -math.sqrt(2 * g / length)
        errors.append(abs(slope / (quarter / (2 * length)) - 1))
    assert 3.8 < errors[0] / errors[1] < 4.2 and 3.8 < errors[1] / errors[2] < 4.2
    assert errors[2] < 5e-6


@pytest.mark.parametrize("shear", ["nu", "G"])
def test_gradients_of_a_static_scene_to_its_parameters_are_exact(shear):
    """A cantilever on a pin held by a torsion spring, a body welded at its tip under
    gravity, a spring to a wall and a motor's torque at the pin: the compliance Fᵀu (whose
    load holds the body's and the beams' weight and the torque) and the tip's
    displacement, the beams' stresses; the section with ν given (G follows E) or G given
    (κ(ν) follows E)."""
    scene = Scene("sprung cantilever", analysis="static", gravity=(0.0, -9.81))
    elastic = {"nu": 0.32} if shear == "nu" else {"G": 26e9}
    scene.section("al", E=70e9, rho=2700.0, diameter=0.01, **elastic)
    for k in range(3):
        scene.node(f"n{k}", 0.3 * k, 0.0)
    for k in range(2):
        scene.beam(f"n{k}", f"n{k + 1}", section="al", split=2, name=f"bar{k}")
    scene.rigid_body("bob", mass=0.8, inertia=1e-3, position=(0.6, 0.0))
    scene.rigid_body("wall", mass=1.0, inertia=1.0, position=(0.6, 0.5))
    scene.weld("w", "n2", "bob")
    scene.clamp("wall", "wall")
    scene.pin("root", "n0")
    scene.joint_spring("torsion", "root", k=400.0, rest=0.01)
    scene.spring("hang", "bob", "wall", k=300.0, length=0.45)
    scene.motor("lift", "root", torque=1.5)
    spec = scene.to_dict()
    responses = ["compliance", "displacement:n2:0,1", "stress", "shear"]
    parameters = ["k:torsion", "rest:torsion", "k:hang", "length:hang", "mass:bob", "torque:lift",
                  "E:al", "rho:al", "diameter:al"]
    assert_exact(spec, np.array([0.8, 0.6]), responses, parameters)


@pytest.mark.parametrize("name, message", [
    ("k", "write KIND:ENTRY"),
    ("stiffness:torsion", "unknown kind 'stiffness'"),
    ("k:nope", "no spring 'nope'"),
    ("length:torsion", "this spring's rest is its `rest`"),
    ("rest:return", "this spring's rest is its `length`"),
    ("mass:nope", "no node or rigid body 'nope'"),
    ("mass:rod0", "'rod0' carries no point mass"),
    ("torque:servo", "a servo has gains kp and kd"),
    ("kp:push", "a torque motor has no gains"),
    ("arm_x:crank.pin", "joint 'A' ties the point to another body"),
    ("arm_x:crank.nope", "body 'crank' has no point 'nope'"),
    ("arm_y:crank", "write BODY.POINT"),
    ("arm_x:crank.pivot", "a response follows a rigid trajectory"),
    ("E:nope", "no section 'nope'"),
    ("end:crank", "'crank' has a table: only a trapezoidal drive"),
    ("speed:A", "'A' has no drive"),
    ("end:nope", "no joint 'nope'"),
])
def test_bad_parameters_raise_settings_error_naming_them(name, message):
    sim = flextop.Simulation(slider_crank_with_force_elements())
    with pytest.raises(SettingsError) as error:
        sim.run_with_sensitivities(np.full(4, 0.5), ["tip_deflection"], parameters=[name])
    assert f"parameter '{name}'" in str(error.value) and message in str(error.value)


def test_gradients_of_stresses_and_buckling_to_a_section_are_exact():
    """The slider-crank's rod: E, ρ and the diameter move its fibre stresses (N/A ± Mc/I,
    c = d/2), its shear stress (k V/A) and its buckling ratio (P L²/π²EI) through the
    section forces and through the points' coefficients."""
    spec = scenes.slider_crank(t_end=0.06, h=5e-4).to_dict()  # the rod is pushed by 0.06 s
    responses = ["stress", "shear", "buckling", "stress:rod/bar1", "stress:ks=50,scale=1e8"]
    # The p-means and the KS mean curve sharply: differences of 1e-3 of the value are off
    # by 5e-6 (the gradient agrees with 1e-4 to 3e-8).
    g = assert_exact(spec, np.array([0.9, 0.5, 0.7, 0.4]), responses, ["E:steel", "rho:steel", "diameter:steel"],
                     step=1e-4)
    assert np.all(g[:, 2] != 0)


def test_section_parameters_refuse_what_is_not_built():
    """A rigid frame's body follows its section; a section given by A, I, κ has no
    diameter."""
    scene = Scene("frame")
    scene.section("s", E=1e9, rho=1e3, A=1e-4, I=1e-9, kappa=0.8, nu=0.3)
    scene.node("a", 0.0, 0.0)
    scene.node("b", 1.0, 0.0)
    scene.beam("a", "b", section="s")
    scene.clamp("root", "a")
    scene.load("b", force=(0.0, -1.0))
    scene.simulation(t_end=0.01, h=1e-3)
    with pytest.raises(SettingsError, match="given by A, I and kappa, not a diameter"):
        flextop.Simulation(scene).run_with_sensitivities(np.ones(1), ["compliance"], parameters=["diameter:s"])
    base = scenes.robot_arm(t_end=0.04).to_dict()
    rigid = {**base, "ground_structures": [{**base["ground_structures"][0], "rigid": True}, base["ground_structures"][1]]}
    sim = flextop.Simulation(rigid)
    with pytest.raises(SettingsError, match="a ground structure declared rigid is made of it"):
        sim.run_with_sensitivities(np.full(sim.n_design, 0.5), ["compliance"], parameters=["rho:aluminium"])


def test_a_run_to_a_tolerance_gives_the_parameter_gradients_of_the_grid_it_accepted():
    """With rtol, the parameters' gradients are those of the discretization accepted:
    the same bits as a run made there directly."""
    sim = flextop.Simulation(slider_crank_with_force_elements())
    x, asked = np.array([0.9, 0.5, 0.7, 0.4]), ["k:return", "E:steel"]
    out = sim.run_with_sensitivities(x, ["tip_deflection"], parameters=asked, rtol=1e-2)
    d = out.discretization
    again = on_accepted_grid(sim, d, x, ["tip_deflection"], 0.03, parameters=asked)
    np.testing.assert_array_equal(out.parameter_gradients, again.parameter_gradients)
    assert out.parameters == tuple(asked) and np.all(out.parameter_gradients != 0)


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_kinetic_energy_and_energy_drawn_have_exact_gradients(mass):
    """∫ T dt is the trapezoidal integral of the run's kinetic energy (its G reads q̇, which
    the direct method's q̇' and the adjoint's q̄̇ carry); the energy the crank's drive draws
    exceeds its net work (it brakes at times). Gradients to densities and to masses, ρ and
    the diameter: direct = adjoint (stored, checkpointed), fourth-order differences."""
    spec = slider_crank_with_force_elements()
    spec["simulation"]["mass"] = mass
    sim = flextop.Simulation(spec)
    x = np.array([0.9, 0.5, 0.7, 0.4])
    responses = ["kinetic_energy", "energy_drawn:crank", "drive_work:crank"]
    res = sim.run(x)
    kinetic = res.energies["kinetic"]
    trapezoid = float(np.sum(0.5 * (kinetic[1:] + kinetic[:-1]) * np.diff(res.time)))
    assert res.response("kinetic_energy") == pytest.approx(trapezoid, rel=1e-12)
    assert res.response("energy_drawn:crank") > res.response("drive_work:crank") > 0
    parameters = ["mass:slider", "inertia:crank", "rho:steel", "diameter:steel", "c:friction"]
    g = assert_exact(spec, x, responses, parameters)
    assert np.all(g[0, :4] > 0)  # more inertia, more kinetic energy
    sensitivities = [sim.run_with_sensitivities(x, responses, method=m, memory="checkpoints") for m in ("direct", "adjoint")]
    np.testing.assert_allclose(sensitivities[1].gradients, sensitivities[0].gradients, rtol=1e-9)
    values = lambda y: sim.run_with_sensitivities(y, responses, method="direct").values  # noqa: E731
    step = 1e-4
    for i in range(4):
        unit = np.eye(4)[i]
        fd = fourth_order(lambda t: values(x + t * unit), step)
        np.testing.assert_allclose(sensitivities[0].gradients[:, i], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_a_held_drive_and_a_static_kinetic_energy_are_refused():
    """A drive that starts where it ends has no law to differentiate; a static scene has no
    kinetic energy."""
    spec = scenes.robot_arm(t_end=0.2).to_dict()
    spec["joints"][0]["drive"]["end"] = spec["joints"][0]["drive"]["start"]
    sim = flextop.Simulation(spec)
    with pytest.raises(SettingsError, match="is held"):
        sim.run_with_sensitivities(np.full(sim.n_design, 0.5), ["compliance"], parameters=["end:shoulder"])
    static = flextop.Simulation({**spec, "analysis": "static"})
    with pytest.raises(SettingsError, match="no motion: kinetic energy"):
        static.run_with_sensitivities(np.full(static.n_design, 0.5), ["kinetic_energy"])


def test_a_drive_that_cannot_change_alone_has_no_tip_deflection_rate():
    """A parallelogram of two rockers with a driven pin and a second, agreeing drive on the
    coupler's hinge: the rigid mechanism follows both only while they agree, so neither law
    can move alone and the rigid trajectory has no rate to one of them (a least-squares
    rate would split the change between the two). Refused by name."""
    scene = Scene("parallelogram")
    scene.section("al", E=7e10, rho=2700.0, nu=0.32, diameter=0.02)
    for i in range(2):
        for name, y in (("b", 0.0), ("t", 0.5), ("c", 0.5)):
            scene.node(f"{name}{i}", float(i), y)
        scene.beam(f"b{i}", f"t{i}", section="al", split=2)
    scene.node("m1", 0.5, 0.5)
    scene.beam("c0", "m1", section="al", split=2)
    scene.beam("m1", "c1", section="al", split=2)
    law = {"kind": "trapezoidal", "start": 0.0, "end": 0.77, "acceleration": 7.3, "speed": 1.9}
    scene.hinge("h0", "t0", "c0")
    scene.hinge("h1", "t1", "c1", drive={**law, "end": -0.77})
    scene.pin("p0", "b0", drive=law)
    scene.pin("p1", "b1")
    scene.point_mass("m1", 2.0)
    scene.tip = "m1"
    scene.simulation(t_end=0.6, h=0.01, rho_inf=0.8)
    with pytest.warns(Warning, match="over-constrain the rigid mechanism"):
        sim = flextop.Simulation(scene)
    x = np.full(sim.n_design, 0.8)
    with pytest.raises(flextop.errors.SimulationError, match="the drive of joint 'p0' is redundant"):
        sim.run_with_sensitivities(x, ["tip_deflection"], parameters=["end:p0"])
    sim.run_with_sensitivities(x, ["compliance"], parameters=["end:p0"])  # without a rigid trajectory it runs
