"""Mechanisms of rigid bodies, sliders and welds against closed-form solutions: the rigid
pendulum's elliptic-integral motion, the rigid slider-crank's kinematics and inverse
dynamics, a slider driven along an arm that a driven pin turns, a beam welded to a body;
exact gradients through them; and the errors of bad bodies and joints."""

import math

import numpy as np
import pytest
from scipy.special import ellipj, ellipk

import flextop
from flextop import scenes
from flextop.errors import SceneError
from flextop.scenes.builder import Scene, trapezoidal

from conftest import fourth_order, slider_crank_with_force_elements


def pendulum_error(h: float) -> float:
    """Largest error in the angle (rad) over one period of the pendulum released at 90°."""
    length, g = 1.0, 9.81
    sim = flextop.Simulation(scenes.pendulum(length=length, g=g, h=h))
    res = sim.run()
    bob = sim.node("bob")
    x, y = res.q[:, 3 * bob] + length, res.q[:, 3 * bob + 1]
    theta = np.arctan2(x, -y)
    k, w0 = math.sin(math.pi / 4), math.sqrt(g / length)
    sn = ellipj(ellipk(k * k) - w0 * res.time, k * k)[0]
    return float(np.abs(theta - 2 * np.arcsin(k * sn)).max())


def test_rigid_pendulum_follows_the_elliptic_solution_at_second_order():
    """A point mass on a rigid massless link released at 90°: θ(t) = 2 asin(k sn(K − ω₀t, k)),
    k = sin 45°, over one period 4K/ω₀; the global error falls fourfold per halved step."""
    coarse, fine = pendulum_error(4e-3), pendulum_error(2e-3)
    assert 1.9 < math.log2(coarse / fine) < 2.1
    assert pendulum_error(2e-4) < 1e-6


R, L = 0.15, 0.30
M1, M2, M3 = 0.5, 1.0, 0.8
I1, I2 = M1 * R**2 / 12, M2 * L**2 / 12


def rigid_slider_crank(h: float, drive: dict | None = None, t_end: float = 0.5, rho_inf: float = 0.5) -> flextop.Simulation:
    """Crank, rod and slider of rigid bodies, the crank's pin driven by ``drive`` (default:
    from rest at 200 rad/s² up to 20 rad/s)."""
    scene = Scene("rigid slider-crank")
    scene.rigid_body("crank", mass=M1, inertia=I1, position=(R / 2, 0), points={"o": (-R / 2, 0), "a": (R / 2, 0)})
    scene.rigid_body("rod", mass=M2, inertia=I2, position=(R + L / 2, 0), points={"a": (-L / 2, 0), "b": (L / 2, 0)})
    scene.rigid_body("slider", mass=M3, position=(R + L, 0))
    scene.pin("O", "crank.o", drive=drive or trapezoidal(0.0, 100.0, acceleration=200.0, speed=20.0))
    scene.hinge("A", "crank.a", "rod.a")
    scene.hinge("B", "rod.b", "slider")
    scene.prismatic("P", "slider", axis=(1, 0))
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf, tol=1e-12)
    return flextop.Simulation(scene.to_dict())


def closed_form(theta, w, alpha):
    """Slider position, velocity and acceleration and the crank torque of the rigid
    slider-crank at crank angle θ, rate ω and acceleration α (no gravity): positions as
    functions of θ differentiated by hand, the torque by virtual work
    τ = Σ m aᵢ·∂rᵢ/∂θ + Σ I ψ̈ᵢ ∂ψᵢ/∂θ."""
    c, s = np.cos(theta), np.sin(theta)
    root = np.sqrt(L**2 - R**2 * s**2)
    root_1 = -(R**2) * s * c / root
    x, x_1 = R * c + root, -R * s + root_1
    x_2 = -R * c - R**2 * (c**2 - s**2) / root - R**4 * s**2 * c**2 / root**3
    root_2 = x_2 + R * c
    psi_1, psi_2 = -R * c / root, R * s / root - R**3 * s * c**2 / root**3
    crank_1, crank_2 = R / 2 * np.array([-s, c]), R / 2 * np.array([-c, -s])
    rod_1, rod_2 = np.array([-R * s + root_1 / 2, R / 2 * c]), np.array([-R * c + root_2 / 2, -R / 2 * s])
    acc = lambda d1, d2: d2 * w**2 + d1 * alpha  # noqa: E731
    torque = (M1 * (acc(crank_1, crank_2) * crank_1).sum(0) + I1 * alpha + M2 * (acc(rod_1, rod_2) * rod_1).sum(0)
              + I2 * acc(psi_1, psi_2) * psi_1 + M3 * acc(x_1, x_2) * x_1)
    return x, x_1 * w, acc(x_1, x_2), torque


def slider_crank_errors(h: float) -> np.ndarray:
    """Largest errors, relative to the largest values after the drive's kink at 0.1 s has
    died out (t ≥ 0.2 s), of the slider's velocity and acceleration and the crank torque;
    and the absolute error of the slider's position over the whole run."""
    sim = rigid_slider_crank(h)
    res = sim.run()
    crank, slider = 3 * sim.node("crank") + 2, 3 * sim.node("slider")
    x, v, a, torque = closed_form(res.q[:, crank], res.qdot[:, crank], res.qddot[:, crank])
    late = res.time >= 0.2
    rel = lambda got, want: np.abs(got - want)[late].max() / np.abs(want[late]).max()  # noqa: E731
    return np.array([rel(res.qdot[:, slider], v), rel(res.qddot[:, slider], a),
                     rel(res.motor_torques["O"], torque), np.abs(R + L + res.q[:, slider] - x).max()])


def test_rigid_slider_crank_matches_closed_form_kinematics_and_inverse_dynamics():
    coarse, fine = slider_crank_errors(5e-4), slider_crank_errors(2.5e-4)
    assert np.all(fine[:3] < 3e-5), fine
    assert np.all(np.log2(coarse[:3] / fine[:3]) > 1.9), coarse / fine
    assert fine[3] < 1e-12


def test_slider_driven_along_a_turning_arm_reaches_its_prescribed_place():
    """A polar robot: a rigid arm pinned at the origin and driven through 90°, carrying a
    slider driven 0.2 m outwards along it. The slider sits at R(θ)(r₀ + s) e exactly, the
    arm's carried axis needing the constraint Hessian for Newton to converge in few
    iterations."""
    scene = Scene("polar")
    scene.rigid_body("arm", mass=2.0, inertia=0.1, position=(0.5, 0.0), points={"pivot": (-0.5, 0.0)})
    scene.rigid_body("slider", mass=1.0, inertia=0.01, position=(0.3, 0.0))
    scene.pin("base", "arm.pivot", drive=trapezoidal(0.0, math.pi / 2, acceleration=10.0, speed=3.0))
    scene.prismatic("radial", "slider", carrier="arm", axis=(1.0, 0.0),
                    drive=trapezoidal(0.0, 0.2, acceleration=2.0, speed=0.5))
    scene.simulation(t_end=1.0, h=2e-3, rho_inf=0.8, tol=1e-11)
    sim = flextop.Simulation(scene.to_dict())
    res = sim.run()
    theta = res.q[:, 3 * sim.node("arm") + 2]
    assert theta[-1] == pytest.approx(math.pi / 2, abs=1e-9)
    slider = 3 * sim.node("slider")
    radius = 0.3 + 0.2
    np.testing.assert_allclose(res.q[-1, slider:slider + 2] + [0.3, 0.0], [0.0, radius], atol=1e-9)
    assert res.q[-1, slider + 2] == pytest.approx(math.pi / 2, abs=1e-9)  # rotation locked to the arm
    assert res.newton["max"] <= 4


def test_a_beam_welded_to_a_clamped_body_is_a_cantilever():
    """A static cantilever clamped directly and one welded to a rigid body clamped at
    another of its points deflect alike."""
    def cantilever(welded: bool) -> float:
        scene = Scene("cantilever", analysis="static")
        scene.section("steel", E=200e9, nu=0.3, rho=7800.0, diameter=0.01)
        scene.node("root", 0.0, 0.0)
        scene.node("tip", 1.0, 0.0)
        scene.beam("root", "tip", section="steel", split=8, fixed=True)
        scene.load("tip", force=(0.0, -10.0))
        if welded:
            scene.rigid_body("wall", mass=1.0, position=(-0.2, 0.1), points={"face": (0.2, -0.1), "bolt": (0.0, 0.3)})
            scene.weld("weld", "wall.face", "root")
            scene.clamp("bolt", "wall.bolt")
        else:
            scene.clamp("root", "root")
        sim = flextop.Simulation(scene.to_dict())
        return float(sim.equilibrium().displacement("tip")[1])

    direct, welded = cantilever(False), cantilever(True)
    assert welded == pytest.approx(direct, rel=1e-10)
    assert direct == pytest.approx(-10.0 / (3 * 200e9 * math.pi * 0.01**4 / 64), rel=1e-2)


@pytest.mark.parametrize("response", ["tip_deflection", "torque_rms:crank", "torque_squared:crank",
                                      "drive_work:crank", "joint_position:slide", "joint_position:A"])
def test_gradients_through_bodies_sliders_and_arms_are_exact(response):
    """The flexible slider-crank: rigid crank and slider, a hinge on the crank's arm, a
    slider on the ground; direct and adjoint agree to round-off and match fourth-order
    central differences."""
    sim = flextop.Simulation(scenes.slider_crank(t_end=0.03, h=5e-4))
    x = np.array([0.9, 0.5, 0.7, 0.4])
    direct = sim.run_with_sensitivities(x, [response], method="direct")
    adjoint = sim.run_with_sensitivities(x, [response], method="adjoint")
    g = direct.gradients[0]
    np.testing.assert_allclose(adjoint.gradients[0], g, rtol=1e-9, atol=1e-9 * np.abs(g).max())
    value = lambda y: sim.run_with_sensitivities(y, [response], method="direct").values[0]  # noqa: E731
    step = 1e-3
    for i in range(len(x)):
        unit = np.eye(len(x))[i]
        fd = fourth_order(lambda t: value(x + t * unit), step)
        assert g[i] == pytest.approx(fd, rel=1e-6, abs=1e-6 * np.abs(g).max())


def test_a_link_declared_rigid_moves_as_a_very_stiff_flexible_link_with_fewer_unknowns():
    """The robot arm with link 1 declared rigid (one body: the frame's mass, centre and
    inertia) against link 1 of the same frame at full density and 10⁶ times the modulus:
    link 2 moves alike to 1e-6 of its motion (the difference falls like 1/E), with 48
    unknowns instead of 90."""
    base = scenes.robot_arm().to_dict()
    rigid = {**base, "ground_structures": [{**base["ground_structures"][0], "rigid": True}, base["ground_structures"][1]]}
    stiff_section = {**base["sections"]["aluminium"], "E": 70e15}
    stiff = {**base, "sections": {**base["sections"], "stiff": stiff_section},
             "ground_structures": [{**base["ground_structures"][0], "section": "stiff"}, base["ground_structures"][1]]}
    sim_rigid, sim_stiff = flextop.Simulation(rigid), flextop.Simulation(stiff)
    x2 = np.linspace(0.2, 1.0, sim_rigid.n_design)
    run_rigid = sim_rigid.run(x2)
    run_stiff = sim_stiff.run(np.concatenate([np.ones(sim_stiff.n_design - sim_rigid.n_design), x2]))
    link2 = [n for n in sim_rigid.node_names if n.startswith("link2")]
    motion = lambda sim, res: np.array([res.q[:, 3 * sim.node(n):3 * sim.node(n) + 2] for n in link2])  # noqa: E731
    a, b = motion(sim_rigid, run_rigid), motion(sim_stiff, run_stiff)
    assert np.abs(a - b).max() < 1e-6 * np.abs(b).max()
    assert (run_rigid.q.shape[1], run_stiff.q.shape[1]) == (48, 90)
    assert sim_rigid.mechanism["frames"] == 2


def test_motor_sizing_and_joint_positions_read_the_run():
    """∫τ² dt is the trapezoidal integral of the motor torque squared; the drive's work
    ∫τ ġ dt agrees with the energy book's; a joint's position is its coordinate at the end:
    the slider's travel, the crank's turn, the relative rotation of the rod on the crank."""
    sim = flextop.Simulation(scenes.slider_crank(t_end=0.03, h=5e-4))
    res = sim.run(0.6)
    torque = res.motor_torques["crank"]
    assert res.response("torque_squared:crank") == pytest.approx(np.trapezoid(torque**2, res.time), rel=1e-12)
    # ∫ τ θ̇ dt against the energy book's Σ τ̄ Δθ: two second-order quadratures of one work.
    rate = np.gradient(res.q[:, 3 * sim.node("crank") + 2], res.time)
    work = res.response("drive_work:crank")
    assert work == pytest.approx(np.trapezoid(torque * rate, res.time), rel=1e-3)
    assert work == pytest.approx(res.energies["drive_work"][-1], rel=5e-4)
    slider, crank, rod = (3 * sim.node(n) for n in ("slider", "crank", "rod0"))
    assert res.response("joint_position:slide") == pytest.approx(res.q[-1, slider], rel=1e-12)
    assert res.response("joint_position:crank") == pytest.approx(res.q[-1, crank + 2], rel=1e-12)
    assert res.response("joint_position:A") == pytest.approx(res.q[-1, rod + 2] - res.q[-1, crank + 2], rel=1e-12)
    weld = {"name": "w", "rigid_bodies": [BODY, {**BODY, "name": "c", "position": [1.5, 0.0], "points": {}}],
            "joints": [{"kind": "pin", "name": "pin", "node": "b.p"}, {"kind": "weld", "name": "w", "nodes": ["b.p", "c"]}]}
    with pytest.raises(flextop.errors.SettingsError, match="joint 'w' is a weld: it holds every coordinate"):
        flextop.Simulation(weld).run(t_end=0.01, h=1e-3).response("joint_position:w")


BODY = {"name": "b", "mass": 1.0, "position": [1.0, 0.0], "points": {"p": [0.5, 0.0]}}


def body_scene(**changes) -> dict:
    spec = {"name": "bad", "rigid_bodies": [dict(BODY)], "joints": [{"kind": "pin", "name": "pin", "node": "b.p"}]}
    for key, value in changes.items():
        spec[key] = value
    return spec


@pytest.mark.parametrize("spec, message", [
    (body_scene(loads=[{"node": "b.p", "force": [1.0, 0.0]}]),
     "loads[0].node: 'b.p' is a point of the rigid body 'b': only joints attach"),
    (body_scene(rigid_bodies=[{**BODY, "inertia": 0.0}], joints=[{"kind": "pin", "name": "pin", "node": "b"}]),
     "rigid body 'b': has no rotary inertia and no joint holds its rotation"),
    (body_scene(joints=[{"kind": "prismatic", "name": "s", "node": "b", "axis": [1.0, 0.0],
                         "drive": {"kind": "trapezoidal", "start": 0, "end_deg": 10, "acceleration": 1, "speed": 1}}]),
     "the drive of a prismatic joint or a roller is a travel in m: it takes no `_deg` keys"),
    (body_scene(rigid_bodies=[{**BODY, "mass": -1.0}]), "rigid_bodies[0] (b).mass: must be positive"),
    (body_scene(rigid_bodies=[{**BODY, "inertia": float("nan")}]), "rigid_bodies[0] (b).inertia: must be non-negative"),
    (body_scene(rigid_bodies=[{**BODY, "angle": 0.1, "angle_deg": 5.0}]), "rigid_bodies[0] (b).angle_deg: give `angle`"),
    (body_scene(rigid_bodies=[{**BODY, "points": {"p": [math.inf, 0.0]}}]), "rigid_bodies[0] (b).points.p[0]: must be finite"),
    (body_scene(rigid_bodies=[BODY, {**BODY, "name": "b.p", "points": {}}]), "duplicate node name 'b.p'"),
    (body_scene(joints=[{"kind": "pin", "name": "pin", "node": "b.q"}]), "joints[0].node: unknown node or rigid-body point 'b.q'"),
    (body_scene(joints=[{"kind": "prismatic", "name": "s", "node": "b", "axis": [0.0, 0.0]}]),
     "joints[0].axis: an axis of zero length"),
    (body_scene(joints=[{"kind": "prismatic", "name": "s", "node": "b"}]), "a prismatic joint or a roller needs its `axis`"),
    (body_scene(joints=[{"kind": "hinge", "name": "h", "nodes": ["b", "b.p"]}]), "needs two distinct nodes or bodies"),
    (body_scene(joints=[{"kind": "pin", "name": "p", "node": "b", "axis": [1.0, 0.0]}]), "only a prismatic joint or a roller takes"),
    (body_scene(joints=[{"kind": "weld", "name": "w", "nodes": ["b", "b.p"], "drive": trapezoidal(0, 1, acceleration=1, speed=1)}]),
     "a weld has no drive"),
    (body_scene(rigid_bodies=[BODY, {**BODY, "name": "c", "position": [3.0, 0.0]}],
                joints=[{"kind": "pin", "name": "pin", "node": "b.p"}, {"kind": "weld", "name": "w", "nodes": ["b", "c"]}]),
     "joints[1] (w): 'b' and 'c' are 2.000e0 m apart; they must coincide"),
])
def test_bad_bodies_and_joints_raise_scene_error_naming_the_entry(spec, message):
    with pytest.raises(SceneError) as err:
        flextop.Simulation(spec)
    assert message in str(err.value)


def test_mechanisms_of_bodies_alone_export_and_refuse_modes(tmp_path):
    """A scene without beams writes its ParaView files (vertices only) and says it has no
    elastic modes."""
    import meshio

    sim = flextop.Simulation(scenes.pendulum(periods=0.1))
    res = sim.run()
    res.to_vtk(tmp_path / "pendulum.pvd")
    frame = meshio.read(sorted(tmp_path.glob("*.vtu"))[-1])
    assert [c.type for c in frame.cells] == ["vertex"]
    assert sorted(frame.cell_data["vertex"][0]) == [1.0, 3.0]  # the pin, the bob
    with pytest.raises(flextop.errors.SettingsError, match="no elastic modes"):
        sim.natural_frequencies(1)


@pytest.mark.parametrize("motor, message", [
    ({"joint": "w", "torque": 1.0}, "motors[0] (m).joint: 'w' is a weld: it holds every coordinate"),
    ({"joint": "driven", "torque": 1.0}, "motors[0] (m).joint: 'driven' is driven"),
    ({"joint": "nope", "torque": 1.0}, "motors[0] (m).joint: unknown joint 'nope'"),
    ({"joint": "pin", "torque": 1.0, "servo": {"kp": 1.0, "motion": trapezoidal(0, 1, acceleration=1, speed=1)}},
     "a motor takes a `torque`"),
    ({"joint": "pin", "table": {"t": [0, 1], "scale": [0, 1]}}, "a motor takes a `torque`"),
    ({"joint": "pin", "servo": {"kp": -1.0, "motion": trapezoidal(0, 1, acceleration=1, speed=1)}},
     "motors[0] (m).servo.kp: must be non-negative"),
    ({"joint": "pin", "torque": float("inf")}, "motors[0] (m).torque: must be finite"),
    ({"joint": "slide", "servo": {"kp": 1.0, "motion": {"kind": "trapezoidal", "start": 0, "end_deg": 10,
                                                        "acceleration": 1, "speed": 1}}},
     "motors[0] (m).servo.motion: a slider's servo follows a travel in m"),
])
def test_bad_motors_raise_scene_error_naming_the_entry(motor, message):
    spec = body_scene(rigid_bodies=[BODY, {**BODY, "name": "c", "position": [1.5, 0.0], "points": {}},
                                    {**BODY, "name": "d", "position": [5.0, 0.0], "points": {}}],
                      joints=[{"kind": "pin", "name": "pin", "node": "b.p"},
                              {"kind": "weld", "name": "w", "nodes": ["b.p", "c"]},
                              {"kind": "pin", "name": "driven", "node": "d",
                               "drive": trapezoidal(0, 1, acceleration=1, speed=1)}])
    spec["rigid_bodies"].append({**BODY, "name": "e", "position": [9.0, 0.0], "points": {}})
    spec["joints"].append({"kind": "prismatic", "name": "slide", "node": "e", "axis": [1.0, 0.0]})
    spec["motors"] = [{"name": "m", **motor}]
    with pytest.raises(SceneError) as err:
        flextop.Simulation(spec)
    assert message in str(err.value)


def test_starts_that_cannot_be_are_scene_errors():
    """An equilibrium start needs every rigid-body mode held (a free pendulum has none to
    rest in); a damper alone holds nothing at rest; a static scene has no start."""
    with pytest.raises(SceneError, match="free rigid-body mode"):
        flextop.Simulation({**scenes.pendulum().to_dict(), "initial": "equilibrium"})
    damped = {**rigid_chain({}), "analysis": "static", "initial_rates": {},
              "springs": [{"name": "d", "joint": "O", "c": 1.0}, {"name": "e", "joint": "H", "c": 1.0}]}
    with pytest.raises(SceneError, match="free rigid-body mode"):
        flextop.Simulation(damped)
    with pytest.raises(SceneError, match="a static scene has no start"):
        flextop.Simulation({**rigid_chain({"O": 1.0, "H": 0.0}), "analysis": "static"})


def test_a_scene_of_bodies_only_needs_one():
    with pytest.raises(SceneError, match="has no beams, continuum members or rigid bodies"):
        flextop.Simulation({"name": "empty", "joints": []})


def mid_span_deflection(split: int, h: float, rho_inf: float = 0.8):
    """The flexible slider-crank over its first 0.15 s: the rod's middle node from the
    chord between its ends (m), and the run."""
    sim = flextop.Simulation(scenes.slider_crank(split=split, h=h, t_end=0.15, rho_inf=rho_inf))
    res = sim.run()
    p = res.positions
    a, b, m = (p[:, sim.node(n)] for n in ("rod0", "rod4", "rod2"))
    chord = b - a
    normal = np.stack([-chord[:, 1], chord[:, 0]], 1) / np.linalg.norm(chord, axis=1)[:, None]
    return res.time, ((m - (a + b) / 2) * normal).sum(1), res


def test_flexible_slider_crank_mid_span_deflection_converges_in_elements_and_step():
    """Against 32 elements at h = 31 µs: the history's largest error relative to the peak
    deflection falls at second order in the elements (16 → 32 per rod) and in the step."""
    t_ref, w_ref, _ = mid_span_deflection(8, 3.125e-5)
    assert 1e-3 < np.abs(w_ref).max() < 2e-3  # about 1.3 mm

    def error(split: int, h: float) -> float:
        t, w, _ = mid_span_deflection(split, h)
        return float(np.abs(np.interp(t_ref, t, w) - w_ref).max() / np.abs(w_ref).max())

    in_elements = [error(s, 3.125e-5) for s in (1, 2, 4)]
    in_step = [error(8, h) for h in (2.5e-4, 1.25e-4, 6.25e-5)]
    for errors in (in_elements, in_step):
        assert errors[0] > errors[1] > errors[2]
        assert errors[1] / errors[2] > 3.5, errors
    assert in_step[2] < 5e-3


def test_flexible_slider_crank_balances_drive_work_and_energy():
    """Drive work = kinetic + strain energy + what the integrator dissipates: without
    numerical dissipation (ρ∞ = 1) the balance closes at second order in the step."""
    imbalance = []
    for h in (5e-4, 2.5e-4):
        energy = mid_span_deflection(2, h, rho_inf=1.0)[2].energies
        work = energy["drive_work"]
        imbalance.append(np.abs(energy["kinetic"] + energy["strain"] - work).max() / np.abs(work).max())
    assert imbalance[1] < 2.5e-4
    assert imbalance[0] / imbalance[1] > 3.5


def oscillator(kind: str, h: float):
    """A 2 kg slider on a ground axis held by an 800 N/m spring (on the joint's travel, or
    between the slider and a clamped wall), pushed by a constant 10 N from rest: x(t) =
    (F/k)(1 − cos ωt), ω = √(k/m). Returns the run's largest error relative to F/k, its
    energy imbalance |T + U − W| relative to the work done, and the motion."""
    m, k, force = 2.0, 800.0, 10.0
    scene = Scene("oscillator")
    scene.rigid_body("mass", mass=m, position=(1.0, 0.0))
    scene.prismatic("slide", "mass", axis=(1.0, 0.0))
    if kind == "joint":
        scene.joint_spring("spring", "slide", k=k)
    else:
        scene.rigid_body("wall", mass=1.0, inertia=0.1, position=(0.0, 0.0))
        scene.clamp("wall", "wall")
        scene.spring("spring", "wall", "mass", k=k)
    scene.load("mass", force=(force, 0.0))
    scene.simulation(t_end=1.0, h=h, rho_inf=0.9)
    sim = flextop.Simulation(scene)
    res = sim.run()
    x = res.q[:, 3 * sim.node("mass")]
    exact = force / k * (1 - np.cos(math.sqrt(k / m) * res.time))
    energy = res.energies
    imbalance = np.abs(energy["kinetic"] + energy["strain"] - energy["external_work"]).max()
    return np.abs(x - exact).max() / (force / k), imbalance / energy["external_work"].max(), x


def test_a_mass_on_a_spring_oscillates_at_the_root_of_k_over_m():
    """Over three periods the motion matches (F/k)(1 − cos ωt) at second order in the step,
    to 4e-5 of the amplitude at h = 0.25 ms (a frequency error below 1e-5 ω); a spring
    on the slider's travel and one between two bodies give the same motion; the springs'
    energy closes the balance."""
    errors = [oscillator("joint", h)[0] for h in (1e-3, 5e-4, 2.5e-4)]
    assert 3.8 < errors[0] / errors[1] < 4.2 and 3.8 < errors[1] / errors[2] < 4.2
    assert errors[2] < 4e-5
    joint, points = oscillator("joint", 5e-4), oscillator("points", 5e-4)
    np.testing.assert_allclose(points[2], joint[2], rtol=0, atol=1e-12)
    assert joint[1] < 1e-6 and points[1] < 1e-6


def damped_oscillator(h: float):
    """The oscillator of :func:`oscillator` with a damper of ratio ζ = 0.05 on the slider's
    travel: x(t) = (F/k)(1 − e^(−ζωt)(cos ω_d t + ζ/√(1 − ζ²) sin ω_d t)), ω_d = ω√(1 − ζ²).
    Returns the largest error relative to F/k, the imbalance |T + U − W_e − W_c| relative to
    the work of the load, and the dampers' work."""
    m, k, force, zeta = 2.0, 800.0, 10.0, 0.05
    omega = math.sqrt(k / m)
    scene = Scene("damped oscillator")
    scene.rigid_body("mass", mass=m, position=(1.0, 0.0))
    scene.prismatic("slide", "mass", axis=(1.0, 0.0))
    scene.joint_spring("spring", "slide", k=k, c=2 * zeta * m * omega)
    scene.load("mass", force=(force, 0.0))
    scene.simulation(t_end=1.0, h=h, rho_inf=0.9)
    sim = flextop.Simulation(scene)
    res = sim.run()
    x, t = res.q[:, 3 * sim.node("mass")], res.time
    damped = omega * math.sqrt(1 - zeta**2)
    exact = force / k * (1 - np.exp(-zeta * omega * t) * (np.cos(damped * t) + zeta / math.sqrt(1 - zeta**2)
                                                           * np.sin(damped * t)))
    e = res.energies
    imbalance = np.abs(e["kinetic"] + e["strain"] - e["external_work"] - e["damping_work"]).max()
    return np.abs(x - exact).max() / (force / k), imbalance / e["external_work"].max(), e["damping_work"]


def test_a_damped_oscillator_decays_and_rings_as_theory():
    """Decay rate ζω and damped frequency ω_d: the motion matches the closed form at second
    order, to 2e-5 of the amplitude at h = 0.25 ms; what the damper dissipates closes the
    energy balance."""
    errors = [damped_oscillator(h)[0] for h in (1e-3, 5e-4, 2.5e-4)]
    assert 3.8 < errors[0] / errors[1] < 4.2 and 3.8 < errors[1] / errors[2] < 4.2
    assert errors[2] < 2e-5
    _, imbalance, work = damped_oscillator(2.5e-4)
    assert imbalance < 2e-6
    assert np.all(np.diff(work) <= 0) and work[-1] < -0.05


def test_gradients_through_springs_dampers_and_motors_are_exact():
    """The flexible slider-crank with a torsion spring and damper at the crank pin, a damper
    on the slider's travel, a spring from a clamped wall to the slider, a ramped force on
    the slider and a PD servo at the rod's end: direct = adjoint (also on variable steps,
    stored or checkpointed), and fourth-order central differences."""
    spec = slider_crank_with_force_elements()
    sim = flextop.Simulation(spec)
    x = np.array([0.9, 0.5, 0.7, 0.4])
    direct = sim.run_with_sensitivities(x, ["tip_deflection"], method="direct")
    adjoint = sim.run_with_sensitivities(x, ["tip_deflection"], method="adjoint")
    g = direct.gradients[0]
    np.testing.assert_allclose(adjoint.gradients[0], g, rtol=1e-9, atol=1e-9 * np.abs(g).max())
    value = lambda y: sim.run_with_sensitivities(y, ["tip_deflection"], method="direct").values[0]  # noqa: E731
    step = 1e-3
    for i in range(len(x)):
        unit = np.eye(len(x))[i]
        fd = fourth_order(lambda t: value(x + t * unit), step)
        assert g[i] == pytest.approx(fd, rel=1e-6, abs=1e-6 * np.abs(g).max())
    plain = flextop.Simulation(scenes.slider_crank(t_end=0.03, h=5e-4)).run(x).response("tip_deflection")
    assert abs(direct.values[0] - plain) > 1e-3 * plain  # the springs act
    varied = sim.run_with_sensitivities(x, ["tip_deflection"], method="direct", local_tol=1e-5).gradients[0]
    for memory in ("store", "checkpoints"):
        other = sim.run_with_sensitivities(x, ["tip_deflection"], method="adjoint", local_tol=1e-5, memory=memory)
        np.testing.assert_allclose(other.gradients[0], varied, rtol=1e-9, atol=1e-9 * np.abs(varied).max())


@pytest.mark.parametrize("spring, message", [
    ({"nodes": ["b", "b.p"], "k": 1.0}, "coincide or lie on one body"),
    ({"nodes": ["b.p", "c"], "k": 1.0}, "coincide or lie on one body"),
    ({"nodes": ["b", "c"], "k": -1.0}, "springs[0] (s).k: must be non-negative"),
    ({"nodes": ["b", "c"], "k": 1.0, "length": -0.1}, "springs[0] (s).length: must be non-negative"),
    ({"nodes": ["b", "c"], "joint": "pin", "k": 1.0}, "a spring takes two `nodes` or one `joint`"),
    ({"joint": "pin", "k": 1.0, "length": 0.2}, "takes a `rest` value, not `length`"),
    ({"joint": "nope", "k": 1.0}, "springs[0] (s).joint: unknown joint 'nope'"),
    ({"joint": "w", "k": 1.0}, "'w' is a weld: it holds every coordinate"),
    ({"joint": "pin", "c": -0.5}, "springs[0] (s).c: must be non-negative"),
    ({"joint": "pin"}, "has neither stiffness `k` nor damping `c`"),
])
def test_bad_springs_and_dampers_raise_scene_error_naming_the_entry(spring, message):
    spec = body_scene(rigid_bodies=[BODY, {**BODY, "name": "c", "position": [1.5, 0.0], "points": {}}],
                      joints=[{"kind": "pin", "name": "pin", "node": "b.p"},
                              {"kind": "weld", "name": "w", "nodes": ["b.p", "c"]}])
    spec["springs"] = [{"name": "s", **spring}]
    with pytest.raises(SceneError) as err:
        flextop.Simulation(spec)
    assert message in str(err.value)


INERTIA = 0.02


def wheel(h: float, add_motor) -> tuple[np.ndarray, np.ndarray]:
    """A wheel of rotary inertia 0.02 kg m² on a free axle, turned by the motor
    ``add_motor(scene)`` adds: times and its angle."""
    scene = Scene("wheel")
    scene.rigid_body("wheel", mass=1.0, inertia=INERTIA, position=(0.0, 0.0), points={"rim": (0.1, 0.0)})
    scene.pin("axle", "wheel")
    add_motor(scene)
    scene.simulation(t_end=1.0, h=h, rho_inf=0.9)
    sim = flextop.Simulation(scene)
    res = sim.run()
    return res.time, res.q[:, 3 * sim.node("wheel") + 2]


def test_a_motor_turns_a_wheel_by_its_torque():
    """A constant torque gives θ = τt²/2J, exact for generalized-α; a torque ramped by a
    table gives τt³/6J to 1e-6 of it."""
    t, angle = wheel(1e-2, lambda s: s.motor("motor", "axle", torque=0.5))
    np.testing.assert_allclose(angle, 0.5 * t**2 / (2 * INERTIA), rtol=0, atol=1e-12)
    t, angle = wheel(1e-3, lambda s: s.motor("motor", "axle", torque=0.5, table=([0.0, 1.0], [0.0, 1.0])))
    np.testing.assert_allclose(angle, 0.5 * t**3 / (6 * INERTIA), rtol=0, atol=1e-6 * 0.5 / (6 * INERTIA))


def test_a_pd_servo_follows_its_differential_equation():
    """A servo (kp = 50 N m/rad, kd = 2 N m s/rad) following a trapezoidal law on the wheel:
    J θ̈ = kp (θ_r − θ) + kd (θ̇_r − θ̇), solved by scipy to 1e-11; flextop's angle agrees at
    second order in the step, to 1e-7 rad at h = 0.25 ms."""
    from scipy.integrate import solve_ivp

    kp, kd = 50.0, 2.0
    motion = trapezoidal(0.0, 2.0, acceleration=20.0, speed=4.0)

    def reference(t: float) -> tuple[float, float]:
        t_acc, t_end = 0.2, 0.7
        if t < t_acc:
            return 10 * t * t, 20 * t
        if t < t_end - t_acc:
            return 0.4 + 4 * (t - t_acc), 4.0
        if t < t_end:
            return 2.0 - 10 * (t_end - t) ** 2, 20 * (t_end - t)
        return 2.0, 0.0

    def rate(t, y):
        angle, speed = reference(t)
        return [y[1], (kp * (angle - y[0]) + kd * (speed - y[1])) / INERTIA]

    errors = []
    for h in (5e-4, 2.5e-4):
        t, angle = wheel(h, lambda s: s.servo("servo", "axle", kp=kp, kd=kd, motion=motion))
        exact = solve_ivp(rate, (0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-11, atol=1e-13, max_step=1e-3).y[0]
        errors.append(np.abs(angle - exact).max())
    assert errors[0] / errors[1] > 3.5
    assert errors[1] < 1e-7


def test_a_structure_started_from_equilibrium_stays_still():
    """The arm under gravity with its drives held (their laws start after the run): from
    `initial = "equilibrium"` it stays at the static deflection to 1e-9 of it, and that is
    the static scene's equilibrium; from rest it swings by about twice as much."""
    spec = scenes.robot_arm(t_end=0.5).to_dict()
    spec["gravity"] = [0.0, -9.81]
    for joint in spec["joints"]:
        joint["drive"]["t_start"] = 5.0
    moved = {}
    for initial in ("rest", "equilibrium"):
        res = flextop.Simulation({**spec, "initial": initial}).run(0.5)
        moved[initial] = np.abs(res.q - res.q[0]).max()
    static = flextop.Simulation({**spec, "analysis": "static"}).equilibrium(0.5)
    deflection = np.abs(static.q).max()
    np.testing.assert_allclose(res.q[0], static.q, rtol=0, atol=1e-12 * deflection)
    assert moved["equilibrium"] < 1e-9 * deflection
    assert moved["rest"] > deflection


@pytest.mark.parametrize("case", ["slider_crank", "robot_arm"])
def test_gradients_from_an_equilibrium_start_are_exact(case):
    """q₀(x) is the static equilibrium: its sensitivity starts the direct method and the
    adjoint carries q̄₀ back through it; both agree to round-off and with fourth-order
    differences (the slider-crank's hinge on the crank's arm brings the joints' curvature
    into the initial accelerations)."""
    if case == "slider_crank":
        spec, x = scenes.slider_crank(t_end=0.03, h=5e-4).to_dict(), np.array([0.9, 0.5, 0.7, 0.4])
        picked = range(4)
    else:
        spec = scenes.robot_arm(t_end=0.2).to_dict()
        x, picked = np.linspace(0.2, 1.0, 148), [0, 33, 100]
    spec.update(gravity=[0.0, -9.81], initial="equilibrium")
    sim = flextop.Simulation(spec)
    responses = ["tip_deflection", "compliance"]
    direct = sim.run_with_sensitivities(x, responses, method="direct")
    adjoint = sim.run_with_sensitivities(x, responses, method="adjoint")
    for k in range(2):
        g = direct.gradients[k]
        np.testing.assert_allclose(adjoint.gradients[k], g, rtol=1e-9, atol=1e-9 * np.abs(g).max())
    value = lambda y: sim.run_with_sensitivities(y, responses, method="direct").values  # noqa: E731
    step = 1e-4
    for i in picked:
        unit = np.eye(len(x))[i]
        fd = fourth_order(lambda t: value(x + t * unit), step)
        for k in range(2):
            g = direct.gradients[k]
            assert g[i] == pytest.approx(fd[k], rel=1e-6, abs=1e-6 * np.abs(g).max())


@pytest.mark.parametrize("h", [1e-3, 1.3e-3, 3.1e-3])
def test_a_spring_that_collapses_stops_the_run_by_name(h):
    """A slider driven onto and through the wall point its spring hangs from: at zero
    length the spring's force has no direction, and the run stops naming the spring and
    the time, whether a step lands on the crossing or steps over it."""
    scene = Scene("collapse")
    scene.rigid_body("wall", mass=1.0, inertia=0.1, position=(0.0, 0.0))
    scene.clamp("wall", "wall")
    scene.rigid_body("mass", mass=1.0, position=(0.1, 0.0))
    scene.prismatic("slide", "mass", axis=(1.0, 0.0), drive=trapezoidal(0.0, -0.2, acceleration=10.0, speed=1.0))
    scene.spring("tether", "wall", "mass", k=100.0)
    scene.simulation(t_end=0.5, h=h)
    with pytest.raises(flextop.errors.SimulationError, match=r"at t = 0\.1[0-9]* s spring 'tether' has collapsed"):
        flextop.Simulation(scene).run()


def test_a_slider_at_a_body_point_takes_a_motor_and_a_damper():
    """On a ground axis the slider's rotation is held, so its point travels as its centre:
    a force and a damper act on it linearly, and a constant force F against damping c
    reaches the speed F/c."""
    scene = Scene("cart")
    scene.rigid_body("cart", mass=2.0, inertia=0.1, position=(0.0, 0.0), points={"hitch": (0.3, 0.1)})
    scene.prismatic("rail", "cart.hitch", axis=(1.0, 0.0))
    scene.joint_spring("drag", "rail", c=20.0)
    scene.motor("push", "rail", torque=10.0)
    scene.simulation(t_end=2.0, h=1e-3)
    sim = flextop.Simulation(scene)
    res = sim.run()
    speed = res.qdot[-1, 3 * sim.node("cart")]
    assert speed == pytest.approx(10.0 / 20.0 * (1 - math.exp(-20.0 / 2.0 * 2.0)), rel=1e-5)


def test_a_static_servo_holds_its_reference_without_its_rate():
    """In a static scene a servo acts as a spring to its reference: its derivative gain,
    which would balance only a velocity, does not shift the equilibrium."""
    def rotation(kd: float) -> float:
        scene = Scene("servo", analysis="static")
        scene.section("steel", E=200e9, nu=0.3, rho=7800.0, diameter=0.01)
        scene.node("o", 0.0, 0.0)
        scene.node("tip", 0.5, 0.0)
        scene.beam("o", "tip", section="steel", fixed=True)
        scene.rigid_body("hub", mass=1.0, inertia=0.01, position=(0.0, 0.0))
        scene.clamp("base", "hub")
        scene.hinge("h", "hub", "o")
        scene.servo("servo", "h", kp=100.0, kd=kd, motion=trapezoidal(0.0, 0.3, acceleration=1.0, speed=1.0))
        scene.load("tip", force=(0.0, -5.0))
        scene.simulation(t_end=0.5)
        sim = flextop.Simulation(scene)
        return float(sim.equilibrium().q[3 * sim.node("o") + 2])

    assert rotation(5.0) == pytest.approx(rotation(0.0), rel=1e-12)
    # The law's angle at t = 0.5 s (still accelerating) less the load's moment over kp, the
    # moment's arm shortened by the turn (and the beam's small bending).
    reference = 0.5 * 1.0 * 0.5**2
    assert rotation(0.0) == pytest.approx(reference - 5.0 * 0.5 * math.cos(0.1) / 100.0, rel=2e-4)


def test_a_pendulum_launched_from_the_bottom_follows_the_elliptic_solution():
    """Started at the bottom with the rate √(2g/L) that carries it to 90°: θ(t) =
    2 asin(k sn(ωt, k)), k = sin 45°, over a period, at second order in the step."""
    length, g = 1.0, 9.81

    def error(h: float) -> float:
        scene = scenes.pendulum(angle=0.0, h=h)
        scene.initial_rate("pivot", math.sqrt(2 * g / length))
        sim = flextop.Simulation(scene)
        res = sim.run(t_end=scenes.pendulum_period(length, g, math.pi / 2))
        bob = sim.node("bob")
        theta = np.arctan2(res.q[:, 3 * bob], length - res.q[:, 3 * bob + 1])
        k = math.sin(math.pi / 4)
        exact = 2 * np.arcsin(k * ellipj(math.sqrt(g / length) * res.time, k * k)[0])
        assert res.energies["kinetic"][0] == pytest.approx(g * length, rel=1e-12)
        return float(np.abs(theta - exact).max())

    coarse, fine = error(4e-3), error(2e-3)
    assert 1.9 < math.log2(coarse / fine) < 2.1
    assert error(2e-4) < 2e-6


def rigid_chain(rates: dict) -> dict:
    """Two rigid links pinned in a chain (two free modes), with initial ``rates``."""
    bodies = [{"name": "a", "mass": 1.0, "inertia": 0.1, "position": [0.5, 0.0], "points": {"o": [-0.5, 0.0], "e": [0.5, 0.0]}},
              {"name": "b", "mass": 1.0, "inertia": 0.1, "position": [1.5, 0.0], "points": {"o": [-0.5, 0.0]}}]
    joints = [{"kind": "pin", "name": "O", "node": "a.o"}, {"kind": "hinge", "name": "H", "nodes": ["a.e", "b.o"]}]
    return {"name": "chain", "rigid_bodies": bodies, "joints": joints, "initial_rates": rates}


def test_initial_rates_set_a_rigid_motion_consistent_with_the_joints():
    """Rates on both joints of a chain: the links turn at them, the hinge's points move
    together (the rows' rates vanish), and the bodies' centres move as rigid links do."""
    sim = flextop.Simulation(rigid_chain({"O": 2.0, "H": -1.0}))
    v = sim.run(t_end=0.01, h=1e-3).qdot[0]
    a, b = 3 * sim.node("a"), 3 * sim.node("b")
    assert (v[a + 2], v[b + 2]) == pytest.approx((2.0, 1.0), abs=1e-12)
    np.testing.assert_allclose(v[a:a + 2], [0.0, 1.0], atol=1e-12)  # 2 rad/s at 0.5 m
    np.testing.assert_allclose(v[b:b + 2], [0.0, 2.0 + 0.5], atol=1e-12)  # the hinge's 2 m/s plus 1 rad/s at 0.5 m


@pytest.mark.parametrize("rates, message", [
    ({"O": 1.0}, "the rates leave 1 rigid-body mode(s) of the mechanism undetermined"),
    ({"nope": 1.0}, "initial_rates.nope: unknown joint 'nope'"),
    ({"O": float("nan"), "H": 0.0}, "initial_rates.O: must be finite"),
])
def test_bad_initial_rates_are_scene_errors(rates, message):
    with pytest.raises(SceneError) as err:
        flextop.Simulation(rigid_chain(rates))
    assert message in str(err.value)


def test_initial_rates_the_joints_forbid_are_refused():
    """A slider on a ground axis driven by a turning crank through a rod: one free mode,
    and rates on the crank and on the slider that disagree."""
    spec = {"name": "crank-slider",
            "rigid_bodies": [{"name": "crank", "mass": 1.0, "inertia": 0.01, "position": [0.0, 0.05],
                              "points": {"o": [0.0, -0.05], "p": [0.0, 0.05]}},
                             {"name": "rod", "mass": 1.0, "inertia": 0.01, "position": [0.15, 0.05],
                              "points": {"a": [-0.15, 0.05], "b": [0.15, -0.05]}},
                             {"name": "slider", "mass": 1.0, "position": [0.3, 0.0]}],
            "joints": [{"kind": "pin", "name": "O", "node": "crank.o"},
                       {"kind": "hinge", "name": "A", "nodes": ["crank.p", "rod.a"]},
                       {"kind": "hinge", "name": "B", "nodes": ["rod.b", "slider"]},
                       {"kind": "prismatic", "name": "S", "node": "slider", "axis": [1.0, 0.0]}],
            "initial_rates": {"O": 1.0, "S": 5.0}}
    with pytest.raises(SceneError, match="ask for a motion the joints forbid"):
        flextop.Simulation(spec)
    spec["initial_rates"] = {"O": 1.0}
    v = flextop.Simulation(spec).run(t_end=0.01, h=1e-3).qdot[0]
    assert v[3 * 2] == pytest.approx(-0.1, rel=1e-9)  # the crank tip's 0.1 m/s, carried to the slider


def test_gradients_of_a_launched_flexible_pendulum_are_exact():
    """A flexible beam welded to a bob, pinned with a torsion spring-damper and launched at
    3 rad/s under gravity: direct = adjoint and fourth-order differences."""
    scene = Scene("flexible pendulum", gravity=(0.0, -9.81))
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.01)
    for k in range(5):
        scene.node(f"n{k}", 0.2 * k, 0.0)
    for k in range(4):
        scene.beam(f"n{k}", f"n{k + 1}", section="al", split=2, name=f"bar{k}")
    scene.rigid_body("bob", mass=0.5, inertia=1e-3, position=(0.8, 0.0))
    scene.weld("w", "n4", "bob")
    scene.pin("root", "n0")
    scene.joint_spring("spring", "root", k=2.0, c=0.05)
    scene.initial_rate("root", 3.0)
    scene.simulation(t_end=0.3, h=1e-3, rho_inf=0.9)
    sim = flextop.Simulation(scene)
    x = np.array([0.9, 0.6, 0.5, 0.8])
    responses = ["compliance", "joint_position:root"]
    direct = sim.run_with_sensitivities(x, responses, method="direct")
    adjoint = sim.run_with_sensitivities(x, responses, method="adjoint")
    value = lambda y: sim.run_with_sensitivities(y, responses, method="direct").values  # noqa: E731
    step = 1e-4
    fd = np.array([fourth_order(lambda t, u=unit: value(x + t * u), step) for unit in np.eye(4)]).T
    for k in range(2):
        g = direct.gradients[k]
        np.testing.assert_allclose(adjoint.gradients[k], g, rtol=1e-9, atol=1e-9 * np.abs(g).max())
        np.testing.assert_allclose(fd[k], g, rtol=1e-6, atol=1e-6 * np.abs(g).max())


def test_local_error_control_runs_a_mechanism_of_rigid_bodies_alone():
    """The pendulum's error scale is the size of its nodes and points (its one node alone
    has none; the step fell to nothing at t = 0 before): the error against the elliptic
    solution falls more than threefold per decade of the tolerance, to 3e-4 rad at 1e-6."""
    sim = flextop.Simulation(scenes.pendulum())
    bob, k, w0 = sim.node("bob"), math.sin(math.pi / 4), math.sqrt(9.81)
    errors = []
    for tol in (1e-4, 1e-5, 1e-6):
        res = sim.run(local_tol=tol)
        theta = np.arctan2(res.q[:, 3 * bob] + 1.0, -res.q[:, 3 * bob + 1])
        exact = 2 * np.arcsin(k * ellipj(ellipk(k * k) - w0 * res.time, k * k)[0])
        errors.append(np.abs(theta - exact).max())
    assert errors[0] / errors[1] > 3 and errors[1] / errors[2] > 3 and errors[2] < 3e-4


def damped_slider(between_points: bool, h: float = 5e-4) -> flextop.Simulation:
    """A 2 kg body on a ground slider pulled by a 5 N force, held by a spring-damper (k, c)
    along its axis: on the slider's travel, or between the body and a wall point 0.3 m
    behind it (the distance is then the travel plus 0.3 m)."""
    scene = Scene("damped slider")
    scene.rigid_body("mass", mass=2.0, position=(0.3, 0.0))
    scene.rigid_body("wall", mass=1.0, inertia=1.0, position=(0.0, 0.0))
    scene.clamp("wall", "wall")
    scene.prismatic("slide", "mass", axis=(1.0, 0.0))
    if between_points:
        scene.spring("spring", "wall", "mass", k=400.0, c=6.0)
    else:
        scene.joint_spring("spring", "slide", k=400.0, c=6.0)
    scene.load("mass", force=(5.0, 0.0))
    scene.simulation(t_end=0.5, h=h, rho_inf=0.9)
    return flextop.Simulation(scene)


def test_a_damper_between_points_damps_as_one_on_the_joint():
    """Along the axis the distance's rate is the travel's: the two dampers give the same
    motion to 1e-10 of it, and the same dissipated work."""
    sims = [damped_slider(p) for p in (False, True)]
    runs = [s.run() for s in sims]
    travel = [r.q[:, 3 * s.node("mass")] for s, r in zip(sims, runs)]
    assert np.abs(travel[1] - travel[0]).max() < 1e-10 * np.abs(travel[0]).max()
    work = [r.energies["damping_work"][-1] for r in runs]
    assert work[1] == pytest.approx(work[0], rel=1e-8) and work[0] < 0


def test_gradients_through_a_damper_between_points_are_exact():
    """The flexible slider-crank with a spring-damper from a wall point to the slider that
    swings across it: its C follows the state and its derivative is not symmetric; the
    gradients' exact solves give direct = adjoint and fourth-order differences, also to
    the damper's c."""
    spec = scenes.slider_crank(t_end=0.03, h=5e-4).to_dict()
    spec["rigid_bodies"].append({"name": "wall", "mass": 1.0, "inertia": 0.1, "position": [0.3, 0.1]})
    spec["joints"].append({"kind": "clamp", "name": "wall", "node": "wall"})
    spec["springs"] = [{"name": "damper", "nodes": ["wall", "slider"], "k": 50.0, "c": 8.0}]
    sim = flextop.Simulation(spec)
    x = np.array([0.9, 0.5, 0.7, 0.4])
    responses = ["tip_deflection", "torque_squared:crank"]
    direct = sim.run_with_sensitivities(x, responses, parameters=["c:damper"], method="direct")
    adjoint = sim.run_with_sensitivities(x, responses, parameters=["c:damper"], method="adjoint", memory="checkpoints")
    # Without a parameter that reads them, the damper alone makes the adjoint keep velocities.
    alone = sim.run_with_sensitivities(x, responses, method="adjoint")
    np.testing.assert_allclose(alone.gradients, direct.gradients, rtol=0, atol=1e-9 * np.abs(direct.gradients).max())
    np.testing.assert_allclose(adjoint.gradients, direct.gradients, rtol=0, atol=1e-9 * np.abs(direct.gradients).max())
    np.testing.assert_allclose(adjoint.parameter_gradients, direct.parameter_gradients, rtol=1e-9)
    value = lambda y, s=spec: flextop.Simulation(s).run_with_sensitivities(y, responses, method="direct").values  # noqa: E731
    step = 1e-4
    for i in range(4):
        unit = np.eye(4)[i]
        fd = fourth_order(lambda t: value(x + t * unit), step)
        np.testing.assert_allclose(direct.gradients[:, i], fd, rtol=0, atol=1e-6 * np.abs(fd).max())
    fd = fourth_order(lambda t: value(x, {**spec, "springs": [{**spec["springs"][0], "c": 8.0 + t}]}), 8e-3)
    np.testing.assert_allclose(direct.parameter_gradients[:, 0], fd, rtol=1e-6)


def test_local_error_control_runs_a_single_body_without_points():
    """A body on a slider held by a spring, launched at 0.5 m/s: one point, no extent to
    measure by (its error scale is then 1 m); x = (v₀/ω) sin ωt, the error falling more than
    tenfold over two decades of the tolerance, to 1e-3 of the amplitude."""
    scene = Scene("launched mass")
    scene.rigid_body("mass", mass=2.0, position=(0.0, 0.0))
    scene.prismatic("slide", "mass", axis=(1.0, 0.0))
    scene.joint_spring("spring", "slide", k=400.0)
    scene.initial_rate("slide", 0.5)
    scene.simulation(t_end=0.5, h=1e-3, rho_inf=0.9)
    sim = flextop.Simulation(scene)
    mass, omega = 3 * sim.node("mass"), math.sqrt(400.0 / 2.0)
    errors = []
    for tol in (1e-6, 1e-8):
        res = sim.run(local_tol=tol)
        v0 = res.qdot[0, mass]
        assert abs(v0) == pytest.approx(0.5, rel=1e-12)
        errors.append(np.abs(res.q[:, mass] - v0 / omega * np.sin(omega * res.time)).max() / (0.5 / omega))
    assert errors[0] / errors[1] > 10 and errors[1] < 1e-3
