"""Spatial scenes from Python and TOML: a compound pendulum against its elliptic period at
order 2, a cantilever's static deflection and first frequency against closed forms, exact
gradients at the seam against differences of rebuilt scenes and against ``δ ∝ 1/E``, the
builder's TOML read back bit for bit, and bad input named."""

import math

import numpy as np
import pytest
from scipy.special import ellipk

import flextop
from conftest import EXAMPLES, lattice_cantilever, trapezoid
from flextop import SceneError, SettingsError, SimulationError, SpatialScene, SpatialSimulation, axis_angle
from flextop.quaternion import rotations

G = 9.81


def pendulum(mass: float = 1.0, length: float = 1.0, tilt: float = 0.0) -> SpatialScene:
    """A uniform bar hinged at one end about an axis tilted by ``tilt`` (rad) from y in the
    horizontal plane, released horizontally from rest under gravity along −z."""
    scene = SpatialScene("compound pendulum", gravity=(0.0, 0.0, -G))
    axis = (-math.sin(tilt), math.cos(tilt), 0.0)
    along = np.array([math.cos(tilt), math.sin(tilt), 0.0])
    inertia = mass * length**2 / 12.0
    scene.rigid_body("bar", mass=mass, inertia=(1e-4 * inertia, inertia, inertia), position=tuple(along * length / 2),
                     orientation=axis_angle((0.0, 0.0, 1.0), tilt), points={"pivot": (-length / 2, 0.0, 0.0)})
    scene.revolute("hinge", "bar.pivot", axis=axis)
    scene.tip = "bar"
    return scene


def quarter_period(length: float = 1.0) -> float:
    """A quarter of the period of a uniform bar released horizontally: ``K(sin² 45°)/ω₀``,
    ``ω₀² = m g (L/2) / (m L²/3)``: when it hangs straight down, at its fastest."""
    omega0 = math.sqrt(1.5 * G / length)
    return ellipk(0.5) / omega0


@pytest.mark.parametrize("tilt", [0.0, 0.7])
def test_a_compound_pendulum_hangs_down_at_its_elliptic_quarter_period_at_order_2(tilt):
    scene = pendulum(tilt=tilt)
    sim = SpatialSimulation(scene)
    t_quarter = quarter_period()
    down = np.array([0.0, 0.0, -0.5])
    errors = []
    for n in (100, 200, 400):
        run = sim.simulate(t_end=t_quarter, h=t_quarter / n, rho_inf=1.0)
        errors.append(np.linalg.norm(run.position("bar")[-1] - down))
        energy = run.kinetic + run.potential
        assert np.ptp(energy) < 1e-3 * run.kinetic.max()
    assert errors[-1] < 1e-3
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all((orders > 1.8) & (orders < 2.2)), (errors, orders)


def test_gradients_match_differences_of_rebuilt_scenes_and_direct_equals_adjoint():
    t_end = 0.3
    responses = ["x:bar", "z:bar", "torque_squared:hinge"]
    scene = pendulum(tilt=0.3)
    spec = scene.to_dict()
    spec["joints"][0]["drive"] = flextop.trapezoidal(0.0, 0.4, acceleration=20.0, speed=3.0)
    spec["springs"] = [{"name": "s", "a": "bar", "b": [0.5, 0.5, 0.5], "k": 30.0, "c": 0.5}]
    settings = {"t_end": t_end, "h": 0.01}

    def run(mass=1.0, k=30.0, method="direct"):
        changed = {**spec, "rigid_bodies": [{**spec["rigid_bodies"][0], "mass": mass}],
                   "springs": [{**spec["springs"][0], "k": k}]}
        return SpatialSimulation(changed).run_with_sensitivities(None, responses, ["mass:bar", "k:s"], method=method, **settings)

    direct, adjoint = run(), run(method="adjoint")
    assert np.allclose(direct.gradient, adjoint.gradient, rtol=1e-9, atol=1e-12 * np.abs(direct.gradient).max())
    for j, (name, value) in enumerate([("mass", 1.0), ("k", 30.0)]):
        step = 1e-3 * value
        at = [run(**{name: value + s * step}).values for s in (-2, -1, 1, 2)]
        fd = (at[0] - 8 * at[1] + 8 * at[2] - at[3]) / (12 * step)
        assert np.allclose(direct.gradient[:, j], fd, rtol=1e-6, atol=1e-9 * np.abs(fd).max()), (name, direct.gradient[:, j], fd)
    assert direct["torque_squared:hinge"] > 0.0


def cantilever(split: int = 4, load: float = -1.0, length: float = 1.0) -> SpatialScene:
    """A steel rod of 1 cm diameter clamped at one end, a dead load along z at the other."""
    scene = SpatialScene("cantilever", analysis="static")
    scene.section("steel", E=2.1e11, rho=7850.0, nu=0.3, diameter=0.01)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (length, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="steel", split=split)
    scene.weld("clamp", "root")
    scene.load("push", "end", force=(0.0, 0.0, load))
    scene.tip = "end"
    return scene


def test_a_cantilever_deflects_as_timoshenko_says_and_its_gradient_to_E_is_minus_delta_over_E():
    E, nu, d, L, P = 2.1e11, 0.3, 0.01, 1.0, -1e-3
    area, inertia = math.pi * d**2 / 4, math.pi * d**4 / 64
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    expected = P * L**3 / (3 * E * inertia) + P * L / (kappa * E / (2 * (1 + nu)) * area)
    sim = SpatialSimulation(cantilever(split=1, load=P))
    eq = sim.equilibrium()
    assert eq.position("end")[2] == pytest.approx(expected, rel=1e-6)
    g = sim.run_with_sensitivities(None, ["z:end", "strain_energy"], ["E:rod"])
    assert g["z:end"] == pytest.approx(eq.position("end")[2], rel=1e-12)
    assert g.d("z:end", "E:rod") == pytest.approx(-expected / E, rel=1e-5)
    assert g.d("strain_energy", "E:rod") == pytest.approx(-g["strain_energy"] / E, rel=1e-5)
    # the equilibrium's strain energy is the work of the load, halved (Clapeyron)
    assert eq.strain == pytest.approx(0.5 * P * eq.position("end")[2], rel=1e-5)


def flexible_pendulum() -> SpatialScene:
    """Two tube beams in an L, hinged at the root about a tilted axis and swinging under
    gravity with a payload at the end: the upper beam of three elements, the lower of two."""
    scene = SpatialScene("flexible pendulum", gravity=(0.0, 0.0, -G))
    scene.section("alu", E=7e10, rho=2700.0, nu=0.33, shape="tube", outer=0.02, inner=0.016)
    for name, at in [("root", (0.0, 0.0, 0.0)), ("elbow", (0.5, 0.0, 0.0)), ("end", (0.5, 0.4, -0.1))]:
        scene.node(name, at)
    scene.beam("upper", "root", "elbow", section="alu", split=3)
    scene.beam("lower", "elbow", "end", section="alu", split=2)
    scene.point_mass("payload", "end", 0.5)
    scene.revolute("hinge", "root", axis=(0.0, 1.0, 0.3))
    scene.simulation(t_end=0.1, h=0.005, tol=1e-11)
    scene.tip = "end"
    return scene


def test_density_gradients_match_differences_and_direct_equals_adjoint():
    """∂f/∂x of a flexible spatial mechanism's final position and ∫U dt, through SIMP's
    stiffness and Du–Olhoff's mass, against fourth-order differences of runs at shifted
    designs (1e-6), and direct against adjoint (1e-9)."""
    sim = SpatialSimulation(flexible_pendulum())
    assert sim.variables == ("upper", "lower") and sim.x_min == 0.01
    x, responses = np.array([0.7, 0.08]), ["z:end", "x:end", "strain_energy"]
    direct = sim.run_with_sensitivities(x, responses, method="direct")
    f, adjoint = sim.run_with_sensitivities(x, responses, method="adjoint")
    scale = np.abs(direct.dfdx).max(axis=1, keepdims=True)
    assert np.all(scale > 0) and np.allclose(direct.values, f, rtol=0, atol=0)
    assert np.all(np.abs(direct.dfdx - adjoint) <= 1e-9 * scale)
    h = 1e-4
    for i in range(2):
        def at(k: float) -> np.ndarray:
            return sim.run_with_sensitivities(x + k * h * np.eye(2)[i], responses).values
        fd = (at(-2) - 8 * at(-1) + 8 * at(1) - at(2)) / (12 * h)
        assert np.all(np.abs(direct.dfdx[:, i] - fd) <= 1e-6 * scale[:, 0]), (i, direct.dfdx[:, i], fd)


def test_a_design_groups_fixes_and_reads_back_and_bad_designs_are_named(tmp_path):
    scene = flexible_pendulum()
    scene.design(p=2.0, mass="linear", x_min=0.05)
    scene.beam("brace", "root", "end", section="alu", kind="truss", fixed=True)
    spec = scene.to_dict()
    spec["beams"][0]["group"] = spec["beams"][1]["group"] = "arm"
    path = tmp_path / "pendulum.toml"
    path.write_text(SpatialScene.from_dict(spec).to_toml())
    sim = SpatialSimulation(path)
    assert sim.variables == ("arm",) and sim.x_min == 0.05
    # SIMP p = 3 (the default) at x = 0.5 on a static cantilever, linear at this load: an eighth
    # of the stiffness, eight times the energy, and dU/dx = −3U at full density
    rod = SpatialSimulation(cantilever(split=2, load=-1e-3))
    full, half = rod.run_with_sensitivities(1.0, "strain_energy"), rod.run_with_sensitivities(0.5, "strain_energy")
    assert half.values[0] == pytest.approx(8 * full.values[0], rel=1e-6)
    assert full.dfdx[0, 0] == pytest.approx(-3 * full.values[0], rel=1e-6)
    for x, words in [([0.5, 0.5], "2 entries; the scene has 1"), ("half", "real numbers"), ([[0.5]], "shape"),
                     (0.001, r"x\[0\] \(arm\) = 0.001 is outside \[0.05, 1\]"), (float("nan"), "outside")]:
        with pytest.raises(flextop.DesignError, match=words):
            sim.simulate(x)
        with pytest.raises(flextop.DesignError, match=words):
            sim.run_with_sensitivities(x, "z:end")


def test_a_cantilevers_lowest_frequencies_are_euler_bernoullis_in_both_planes_and_its_torsion():
    E, nu, rho, d, L = 2.1e11, 0.3, 7850.0, 0.01, 1.0
    sim = SpatialSimulation(cantilever(split=16, load=0.0))
    modes = sim.modes()
    f = modes.frequencies
    area, inertia = math.pi * d**2 / 4, math.pi * d**4 / 64
    bending = 1.875104**2 * math.sqrt(E * inertia / (rho * area * L**4)) / (2 * math.pi)
    assert f[0] == pytest.approx(bending, rel=2e-3) and f[1] == pytest.approx(bending, rel=2e-3)
    torsion = math.sqrt(E / (2 * (1 + nu)) / rho) / (4 * L)
    assert np.min(np.abs(f / torsion - 1.0)) < 2e-3
    assert modes.shapes.shape == (len(f), 6 * 17)


def test_the_lowest_modes_by_count_are_the_dense_ones_and_pass_the_dense_limit():
    sim = SpatialSimulation(cantilever(split=16, load=0.0))
    every, lowest = sim.modes(), sim.modes(count=6)
    assert every.bound is None and every.below is None
    # to 1e-10 of the largest: the dense solve splits the round rod's equal pair by 3e-10
    assert lowest.frequencies == pytest.approx(every.frequencies[:6], abs=1e-10 * every.frequencies[5])
    assert lowest.shapes.shape == (6, 6 * 17)
    assert lowest.below == 6 and every.omega_squared[5] < lowest.bound < every.omega_squared[6]
    # 300 elements, 1806 unknowns: every mode is refused, naming the way out; the lowest are
    # the closed form's pairs of equal bending frequencies (a round rod)
    E, rho, d, L = 2.1e11, 7850.0, 0.01, 1.0
    long = SpatialSimulation(cantilever(split=300, load=0.0))
    with pytest.raises(SettingsError, match="pass a count"):
        long.modes()
    f = long.modes(count=4).frequencies
    bending = 1.875104**2 * math.sqrt(E * math.pi * d**4 / 64 / (rho * math.pi * d**2 / 4 * L**4)) / (2 * math.pi)
    assert f[:2] == pytest.approx([bending, bending], rel=1e-3)
    assert f[0] == pytest.approx(f[1], rel=1e-8) and f[2] == pytest.approx(f[3], rel=1e-8)


@pytest.mark.parametrize("kind", ["truss", "frame"])
def test_a_lattices_lowest_modes_by_count_are_the_dense_ones(kind):
    # a 6 × 3 × 3 lattice of diagonals pinned at one face: as truss bars its nodes have no
    # rotation (not unknowns of either path), as beams they do
    scene = SpatialScene("lattice", analysis="static")
    scene.section("steel", E=2.1e11, rho=7850.0, nu=0.3, diameter=0.01)
    scene.ground_structure("g", nx=6, ny=3, nz=3, length=1.0, height=0.4, width=0.4, section="steel",
                           connectivity="diagonals", kind=kind)
    for j in range(3):
        for k in range(3):
            scene.spherical(f"pin{j}{k}", f"g[0,{j},{k}]")
    sim = SpatialSimulation(scene)
    eq = sim.equilibrium()
    every, lowest = sim.modes(at=eq), sim.modes(at=eq, count=8)
    assert lowest.frequencies == pytest.approx(every.frequencies[:8], rel=1e-10)
    assert lowest.below >= 8 and every.omega_squared[lowest.below - 1] < lowest.bound < every.omega_squared[lowest.below]
    # Its square section bends alike in y and z: equal pairs (the first and second, the
    # fifth and sixth, the eighth and ninth), each counted twice by the Sturm count, the eighth's twin
    # among the lowest eight's below the bound.
    f = np.asarray(every.frequencies)
    for a in (0, 4, 7):
        assert f[a + 1] == pytest.approx(f[a], rel=1e-8) and f[a + 2] > 1.001 * f[a + 1], (a, f[:10])
    assert lowest.below == 9


@pytest.mark.parametrize("offset", [0.0, 0.1])
def test_a_body_welded_to_a_beam_turns_with_it_in_every_mode(offset):
    """A 2 kg body welded to a cantilever's tip, its centre at the tip or 0.1 m off it, has
    the lowest frequencies of the same mass there (a point mass, or its inertia about the
    tip), every mode densely as by Lanczos, its equal pair in both planes where the body sits
    on the axis; and they are its motion's (a free swing's period under gravity at 6.96 Hz
    with the body at the tip). The dense null space of the joints once lost free directions
    to round-off (an eigen-decomposition of BᵀB at a squared tolerance): the tip was held
    from turning, at 12.2 and 13.5 Hz."""
    def rod(body: bool) -> SpatialScene:
        scene = SpatialScene("tip", analysis="static")
        scene.section("s", E=2.1e11, rho=7850.0, nu=0.3, diameter=0.02)
        scene.node("root", (0.0, 0.0, 0.0))
        scene.node("end", (1.0, 0.0, 0.0))
        scene.beam("rod", "root", "end", section="s", split=8)
        scene.weld("clamp", "ground", "root")
        if body:
            scene.rigid_body("w", mass=2.0, inertia=(1e-6, 1e-6, 1e-6), position=(1.0, 0.0, offset),
                             points={"hub": (0.0, 0.0, -offset)})
            scene.weld("mount", "end", "w.hub")
        else:
            scene.point_mass("m", "end", 2.0)
        return scene

    welded = SpatialSimulation(rod(True))
    every, lowest = welded.modes(), welded.modes(count=4)
    assert lowest.frequencies == pytest.approx(every.frequencies[:4], rel=1e-9)
    if offset == 0.0:
        point = SpatialSimulation(rod(False)).modes().frequencies[:4]
        assert every.frequencies[:4] == pytest.approx(point, rel=1e-5)  # the body's 1e-6 kg m² aside
        assert every.frequencies[0] == pytest.approx(6.9596, rel=1e-4)
    else:
        assert every.frequencies[0] < 6.9596  # the mass's inertia about the tip lowers it


@pytest.mark.parametrize("count, words", [(0, "count must be a whole number ≥ 1, got 0"), (2.5, "count must be"),
                                          (True, "count must be"), ("3", "count must be"),
                                          (97, "count: is 97: the mechanism has 96 free directions")])
def test_a_bad_count_is_named(count, words):
    with pytest.raises(SettingsError, match=words):
        SpatialSimulation(cantilever(split=16, load=0.0)).modes(count=count)


def test_an_unstable_equilibrium_has_no_frequencies():
    scene = pendulum()
    spec = scene.to_dict()
    spec["rigid_bodies"][0]["position"] = [0.0, 0.0, 0.5]
    spec["rigid_bodies"][0]["orientation"] = axis_angle((0.0, 1.0, 0.0), -math.pi / 2)
    sim = SpatialSimulation(spec)
    for modes in (sim.modes(), sim.modes(count=1)):
        assert modes.omega_squared[0] == pytest.approx(-1.5 * G, rel=1e-9)
        with pytest.raises(SimulationError, match="unstable"):
            modes.frequencies


def test_a_scene_written_as_toml_reads_back_and_runs_bit_for_bit(tmp_path):
    scene = pendulum(tilt=0.4)
    scene.simulation(t_end=0.2, h=0.01)
    path = tmp_path / "pendulum.toml"
    path.write_text(scene.to_toml(header="a compound pendulum"))
    assert SpatialScene.from_toml(path).to_dict() == scene.to_dict()
    a, b = SpatialSimulation(scene).simulate(), SpatialSimulation(path).simulate()
    assert np.array_equal(a.q, b.q) and np.array_equal(a.lam, b.lam)
    rotation = a.rotation("bar")
    assert np.allclose(rotation @ rotation.transpose(0, 2, 1), np.eye(3), atol=1e-12)


@pytest.mark.parametrize("change, culprit", [
    (lambda s: s["joints"][0].update(axis=[0.0, 0.0, 0.0]), "joints.hinge"),
    (lambda s: s["joints"][0].update(a="bar.tip"), "joints[0] (hinge).a: body 'bar' has no point 'tip'"),
    (lambda s: s["rigid_bodies"][0].update(orientation={"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 2]]}),
     "rigid_bodies[0] (bar).orientation.matrix: is not a rotation"),
    (lambda s: s["rigid_bodies"][0].update(mass="heavy"), "rigid_bodies[0].mass"),
    (lambda s: s.update(colour="red"), "unknown field `colour`"),
])
def test_bad_scenes_are_refused_naming_the_entry(change, culprit):
    spec = pendulum().to_dict()
    change(spec)
    with pytest.raises(SceneError, match=culprit.replace("[", r"\[").replace("(", r"\(").replace(")", r"\)")):
        SpatialSimulation(spec)


def test_bad_requests_are_named():
    sim = SpatialSimulation(pendulum())
    with pytest.raises(SettingsError, match="'w:bar': 'w' is not a spatial scene's response kind"):
        sim.run_with_sensitivities(None, ["w:bar"], t_end=0.1, h=0.01)
    with pytest.raises(SettingsError, match="'E:bar': 'bar' is no beam"):
        sim.run_with_sensitivities(None, None, ["E:bar"], t_end=0.1, h=0.01)
    with pytest.raises(SettingsError, match="t_end"):
        sim.simulate()
    # The pendulum swings freely: its rigid mechanism has a freedom no drive holds.
    with pytest.raises(SettingsError, match="tip_deflection: the drives leave the rigid mechanism a freedom"):
        sim.run_with_sensitivities(None, ["tip_deflection:bar"], t_end=0.1, h=0.01)
    # So does the flexible pendulum, hinged at the node where its link's nominal mass sits: no
    # weight turns it in either of the companion's runs, and only the rank of its joints sees it.
    with pytest.raises(SettingsError, match="tip_deflection: the drives leave the rigid mechanism a freedom"):
        SpatialSimulation(flexible_pendulum()).run_with_sensitivities(0.5, "tip_deflection")
    with pytest.raises(SettingsError, match="'tip_deflection:nowhere': 'nowhere' is no body or node"):
        sim.run_with_sensitivities(None, ["tip_deflection:nowhere"], t_end=0.1, h=0.01)
    with pytest.raises(SettingsError, match="an equilibrium has none"):
        sim.run_with_sensitivities(None, ["tip_deflection:bar"], equilibrium=True)
    with pytest.raises(SettingsError, match="'tip' is no body or node"):
        sim.simulate(t_end=0.01, h=0.01).position("tip")
    with pytest.raises(SceneError, match="SpatialSimulation"):
        flextop.Simulation(pendulum().to_dict())
    scene = SpatialScene()
    scene.section("s", E=1.0, rho=1.0, nu=0.3, diameter=1.0)
    with pytest.raises(SceneError, match="given twice"):
        scene.section("s", E=1.0, rho=1.0, nu=0.3, diameter=1.0)


def test_the_papers_arm_built_as_a_spatial_mechanism_gives_the_planar_tip_deflection():
    """The arm's Eq. 40 from the spatial engine's tip against the planar rigid trajectory:
    within 0.1 % of the planar engine's at one and two elements per bar (measured 3.5e-4
    and 9.6e-5: the elements differ, the Simo–Reissner beam's rotary inertia lumped), the
    difference falling as both refine, the motion in its plane to round-off. The spatial
    engine's own ``tip_deflection`` (its rigid companion: each link one body on the joints
    and drives) is that number to 1e-9: its rigid trajectory is the planar one."""
    differences = []
    for split, h in [(1, 0.02), (2, 0.01)]:
        sim = flextop.Simulation(flextop.scenes.robot_arm(split=split, h=h))
        planar = sim.run(None).tip_deflection()
        scene = flextop.spatial.from_planar(sim)
        assert sum(len(b.get("nodes", [])) > 0 for b in scene.to_dict()["beams"]) == len(sim.bars.name)
        run = SpatialSimulation(scene).simulate()
        tip = run.position(scene.tip)
        assert np.abs(tip[:, 2]).max() < 1e-12
        error = tip[:, :2] - sim.rigid_trajectory(sim.tip, run.time)
        spatial = np.trapezoid(np.sum(error**2, axis=1), run.time) / run.time[-1]
        differences.append(abs(spatial / planar - 1.0))
        if split == 1:
            own = SpatialSimulation(scene).run_with_sensitivities(None, "tip_deflection").values[0]
            assert abs(own / spatial - 1.0) < 1e-9, (own, spatial)
    assert differences[0] < 1e-3 and differences[1] < differences[0] / 2, differences


def test_the_papers_arm_built_as_a_spatial_mechanism_gives_the_planar_density_gradients():
    """The arm's mean strain energy and its gradient to the 148 bars' densities at a random
    design, from both engines (the spatial one's variables the planar one's, in order): the
    values within 0.3 %, the gradients' relative 2-norm difference 2.5e-2 and 1.0e-2 at one
    and two elements per bar (3.1e-3 at four, ``benches/spatial_arm.py``), falling as both
    refine; the spatial adjoint equal to its direct sweep through the drive's restarts."""
    x = np.random.default_rng(1).uniform(0.3, 1.0, 148)
    differences = []
    for split, h in [(1, 0.02), (2, 0.01)]:
        sim = flextop.Simulation(flextop.scenes.robot_arm(split=split, h=h))
        spatial = SpatialSimulation(flextop.spatial.from_planar(sim))
        assert spatial.variables == tuple(sim.variable_names)
        f, dfdx = sim.run_with_sensitivities(x, ["strain_energy"])
        g = spatial.run_with_sensitivities(x, "strain_energy", method="adjoint")
        # The same name means the same mean (1/t_f) ∫U dt in both engines.
        assert g.values[0] == pytest.approx(f[0], rel=3e-3)
        differences.append(np.linalg.norm(g.dfdx - dfdx) / np.linalg.norm(dfdx))
        if split == 1:
            direct = spatial.run_with_sensitivities(x, "strain_energy", method="direct").dfdx
            assert np.abs(direct - g.dfdx).max() <= 1e-9 * np.abs(direct).max()
    assert differences[0] < 3e-2 and differences[1] < differences[0] / 2, differences



def test_each_engines_optimum_of_the_papers_arm_is_an_optimum_of_the_other():
    """The paper's arm, its tip deflection minimized at 40 % of each link's volume by MMA
    from x = 0.4 to a KKT residual of 1e-4, in the planar engine and in the spatial one (the
    scene ``from_planar``: the nz = 1 lattice, moving in its plane): each optimum, started
    from in the other engine's problem, is a KKT point there at once (no iteration), the two
    engines' objectives there within 0.3 % on the scene's grid (8e-4 and 2.4e-3 measured;
    converged, to rtol 1e-3, 3e-5 and 4e-4: BENCHMARKS.md). From the same start the two runs
    end at different KKT points (d 1.3 % apart, max |Δx| 0.39): the problem has many, and the
    engines' small differences on the scene's grid steer MMA to different ones."""
    from flextop.problems import SpatialProblem, robot_arm_problem

    planar = robot_arm_problem("tip_deflection")
    sim = SpatialSimulation(flextop.spatial.from_planar(planar.simulation))
    problems = {"planar": planar, "spatial": SpatialProblem(sim, "tip_deflection", volume=0.4, per_structure=True)}
    d = {"planar": lambda x: planar.simulation.run_with_sensitivities(x, ["tip_deflection"]).values[0],
         "spatial": lambda x: sim.run_with_sensitivities(x, "tip_deflection").values[0]}
    optima = {}
    for name, problem in problems.items():
        result = flextop.optimize(problem, 0.4, method="mma", max_iter=100, kkt_tol=1e-4)
        assert result.status.name == "KKT", result.message
        optima[name] = result.x
    for name, other in (("planar", "spatial"), ("spatial", "planar")):
        there = flextop.optimize(problems[other], optima[name], method="mma", max_iter=100, kkt_tol=1e-4)
        assert there.status.name == "KKT" and there.nit == 0 and np.array_equal(there.x, optima[name])
        assert d[other](optima[name]) == pytest.approx(d[name](optima[name]), rel=3e-3)
    assert abs(d["planar"](optima["spatial"]) / d["planar"](optima["planar"]) - 1) > 5e-3

def test_a_torsion_spring_from_the_builder_swings_at_its_closed_form_period_with_exact_gradients():
    """A bar hinged at one end about a vertical axis and held by a torsion spring, no
    gravity, released 0.3 rad from rest: a quarter period ``(π/2) √(I/k)`` later it passes
    its rest angle (the error, at its fastest, falling at order 2 in h, below 1e-3 rad at 200
    steps); the gradient of its centre's final y to ``k:coil`` direct = adjoint."""
    scene = SpatialScene("torsion pendulum")
    scene.rigid_body("bar", mass=1.0, inertia=(1e-3, 1.0 / 12.0, 1.0 / 12.0), position=(0.5, 0.0, 0.0),
                     points={"pivot": (-0.5, 0.0, 0.0)})
    scene.revolute("hinge", "bar.pivot", axis=(0.0, 0.0, 1.0))
    scene.torsion("coil", "hinge", k=2.0, c=0.0, rest=-0.3)
    scene.tip = "bar"
    spec = SpatialScene.from_dict(scene.to_dict())
    assert spec.to_dict()["springs"] == [{"name": "coil", "joint": "hinge", "k": 2.0, "c": 0.0, "rest": -0.3}]
    sim = SpatialSimulation(scene)
    period = 2 * math.pi * math.sqrt((1.0 / 12.0 + 0.25) / 2.0)
    errors = []
    for steps in (100, 200):
        run = sim.simulate(t_end=period / 4, h=period / 4 / steps, rho_inf=0.9)
        turned = run.rotation("bar")[-1]
        # the joint's angle is its b's (the ground's) from its a's (the bar's): the bar rests at +0.3
        errors.append(abs(math.atan2(turned[1, 0], turned[0, 0]) - 0.3))
    assert errors[1] < 1e-3 and math.log2(errors[0] / errors[1]) == pytest.approx(2.0, abs=0.15), errors
    g = {m: sim.run_with_sensitivities(None, "y:bar", ["k:coil"], method=m, t_end=0.2, h=0.005) for m in ("direct", "adjoint")}
    assert abs(g["direct"].gradient[0, 0]) > 1e-3
    assert g["direct"].gradient[0, 0] == pytest.approx(g["adjoint"].gradient[0, 0], rel=1e-9)


def test_a_lattice_from_the_builder_reads_back_and_its_single_layer_is_the_planar_ground_structure(tmp_path):
    """``SpatialScene.ground_structure``: a 5 × 3 single layer has the planar ground
    structure's bars (every pair of grid nodes with ``gcd(Δi, Δj) = 1``), a 4 × 2 × 2 lattice
    with face diagonals its closed-form count; written as TOML and read back, clamped
    lattices under tip loads give the same equilibrium, with direct = adjoint density
    gradients."""
    grid = [(i, j) for i in range(5) for j in range(3)]
    planar = sum(math.gcd(abs(a[0] - b[0]), abs(a[1] - b[1])) == 1 for n, a in enumerate(grid) for b in grid[n + 1:])
    scene = SpatialScene("lattice", analysis="static")
    scene.section("s", E=7e10, rho=2700.0, nu=0.33, diameter=0.01)
    scene.ground_structure("g", nx=5, ny=3, length=0.5, height=0.2, section="s")
    scene.ground_structure("box", nx=4, ny=2, nz=2, length=0.3, height=0.05, width=0.05, section="s",
                           connectivity="faces", origin=(0.0, 0.0, 1.0))
    for k in range(2):
        for j in range(2):
            scene.weld(f"clamp{j}{k}", f"box[0,{j},{k}]")
    scene.weld("clamp", "g[0,0,0]")
    scene.weld("clamp2", "g[0,2,0]")
    scene.load("push", "box[3,1,1]", force=(0.0, -5.0, -20.0))
    scene.load("pull", "g[4,1,0]", force=(0.0, -10.0, 0.0))
    path = tmp_path / "lattice.toml"
    path.write_text(scene.to_toml())
    sim = SpatialSimulation(path)
    edges, faces = 3 * 2 * 2 + 4 * 1 * 2 + 4 * 2 * 1, 2 * (3 * 1 * 2 + 3 * 2 * 1 + 4 * 1 * 1)
    assert sim.n_design == planar + edges + faces
    x = np.linspace(0.3, 1.0, sim.n_design)
    a, b = sim.equilibrium(x), SpatialSimulation(scene).equilibrium(x)
    assert np.array_equal(a.q, b.q) and a.position("box[3,1,1]")[2] < 1.025  # built at z = 1 + width/2
    direct = sim.run_with_sensitivities(x, ["strain_energy", "z:box[3,1,1]"], method="direct").dfdx
    adjoint = sim.run_with_sensitivities(x, ["strain_energy", "z:box[3,1,1]"], method="adjoint").dfdx
    assert np.all(np.abs(direct - adjoint) <= 1e-9 * np.abs(direct).max(axis=1, keepdims=True))


def test_a_spatial_lattice_is_designed_by_mma_to_a_kkt_point():
    """A 4 × 2 × 2 lattice cantilever of 72 steel tubes (edges, face and body diagonals),
    clamped at one face, pushed down and sideways at the other: its static strain energy
    minimized by MMA at 30 % of the full volume from the uniform design, on the exact
    density gradients. Measured: a KKT point (residual 9.1e-5 < 1e-4) in 18 iterations,
    the energy 0.045 of the uniform design's, the volume bound active. A problem's bad
    bounds are named."""
    scene = lattice_cantilever()
    sim = SpatialSimulation(scene)
    assert sim.n_design == 72
    budget = 0.3 * sim.volume(1.0)
    volumes = np.asarray(sim.model.volumes[0])
    x0 = np.full(sim.n_design, 0.3)
    start = sim.run_with_sensitivities(x0, ["strain_energy", "volume"], method="adjoint")
    assert start.values[1] == pytest.approx(budget, rel=1e-12) and np.array_equal(start.dfdx[1], volumes)

    problem = flextop.problems.SpatialProblem(sim, "strain_energy", volume=0.3)
    result = flextop.optimize(problem, x0, method="mma", max_iter=100, kkt_tol=1e-4)
    assert result.success and result.kkt < 1e-4, result.message
    assert result.fun < 0.1 and sim.volume(result.x) == pytest.approx(budget, rel=1e-3)
    assert problem.reference == pytest.approx(start.values[0], rel=1e-12)
    per = flextop.problems.SpatialProblem(sim, "strain_energy", volume=0.3, per_structure=True)
    assert per.names == [f"volume:box ≤ {budget:.4g}"]
    assert sim.volume(x0, "box") == pytest.approx(budget, rel=1e-12)
    with pytest.raises(SettingsError, match="'volume:nowhere': 'nowhere' is no ground structure"):
        sim.run_with_sensitivities(x0, "volume:nowhere")
    for bad, culprit in [({"volume": 1.5}, "volume: 1.5"), ({"constraints": [("z:box[3,0,0]", -1.0)]}, "the bound -1.0"),
                         ({"reference": float("nan")}, "reference: nan")]:
        with pytest.raises(SettingsError, match=culprit):
            flextop.problems.SpatialProblem(sim, "strain_energy", **bad)


def test_the_spatial_robot_arm_moves_its_payload_out_of_every_plane_with_exact_density_gradients():
    """The spatial robot arm (188 lattice bars): the payload's path spans all three
    directions (its positions' third singular value 0.1 m over the run, of 3.8 and 0.63), the
    links stay whole; over its first 0.2 s the payload's height, the strain energy and its
    deflection from the rigid trajectory (Eq. 40) have direct = adjoint gradients to the 188
    densities through three drives' restarts."""
    sim = SpatialSimulation(flextop.scenes.spatial_robot_arm())
    assert sim.n_design == 188
    path = sim.simulate().position("payload")
    spread = np.linalg.svd(path - path.mean(axis=0), compute_uv=False)
    assert spread[2] > 0.05, spread
    x = np.random.default_rng(3).uniform(0.2, 1.0, sim.n_design)
    responses = ["z:payload", "strain_energy", "tip_deflection"]
    direct = sim.run_with_sensitivities(x, responses, method="direct", t_end=0.2).dfdx
    adjoint = sim.run_with_sensitivities(x, responses, method="adjoint", t_end=0.2).dfdx
    scale = np.abs(direct).max(axis=1, keepdims=True)
    assert np.all(scale > 0) and np.all(np.abs(direct - adjoint) <= 1e-9 * scale)


def test_planar_entries_without_a_spatial_counterpart_are_named():
    scene = flextop.scenes.slider_crank()
    with pytest.raises(SceneError, match="joints.slide: a planar prismatic has no spatial counterpart"):
        flextop.spatial.from_planar(scene)


def test_the_spatial_slider_crank_follows_its_closed_form_through_space():
    """The example's crank turns about an axis tilted 30° from z: its pin leaves the plane,
    the rod moves through space, and the slider is where ``x = p_x + √(l² − p_y² − p_z²)``
    puts it at every step (index-3 constraints: to round-off, whatever the step)."""
    scene = flextop.scenes.spatial_slider_crank()
    run = SpatialSimulation(scene).simulate()
    theta, T = trapezoid(0.0, 2 * math.pi, 200.0, 20.0)
    angle = theta(run.time)
    r, l, alpha = 0.15, 0.3, math.radians(30.0)
    pin = r * np.stack([np.cos(angle), np.sin(angle) * math.cos(alpha), -np.sin(angle) * math.sin(alpha)], axis=1)
    slider = pin[:, 0] + np.sqrt(l**2 - pin[:, 1] ** 2 - pin[:, 2] ** 2)
    assert np.abs(run.position("slider")[:, 0] - slider).max() < 1e-9
    assert np.abs(run.position("slider")[:, 1:]).max() < 1e-12
    assert np.abs(pin[:, 2]).max() > 0.07  # out of the slider's plane
    assert T < run.time[-1]


@pytest.mark.parametrize("name", ["heavy_top.toml", "spatial_slider_crank.toml", "spatial_robot_arm.toml",
                                  "spatial_paper_arm.toml"])
def test_the_spatial_examples_run_as_their_builders_say(name):
    path = EXAMPLES / name
    run = SpatialSimulation(path).simulate()
    builder = {"heavy_top.toml": flextop.scenes.heavy_top, "spatial_slider_crank.toml": flextop.scenes.spatial_slider_crank,
               "spatial_robot_arm.toml": flextop.scenes.spatial_robot_arm,
               "spatial_paper_arm.toml": flextop.scenes.spatial_paper_arm}
    again = SpatialSimulation(builder[name]()).simulate()
    assert np.array_equal(run.q, again.q)
    if name == "heavy_top.toml":  # its centre of mass stays 1 m from the pivot; its energy, with ρ∞ = 0.9, barely falls
        assert np.abs(np.linalg.norm(run.position("top"), axis=1) - 1.0).max() < 1e-9
        energy = run.kinetic + run.potential
        assert 0.0 <= energy[0] - energy[-1] < 1e-3 * energy[0]


def test_implausible_units_are_warned_about():
    spec = cantilever(split=1).to_dict()
    spec["sections"]["steel"]["E"] = 210.0  # GPa typed as Pa
    with pytest.warns(flextop.PlausibilityWarning, match=r"sections.steel.E = 210 Pa"):
        SpatialSimulation(spec)


def test_a_spatial_motion_for_paraview_reads_back_with_meshio(tmp_path):
    """The rod's frames: points where the nodes are at each frame's time, then its weld's
    place, one line per beam element, the body's vertex and the weld's, the nodes' axes
    orthonormal and turning with them."""
    import xml.etree.ElementTree as ET

    import meshio

    scene = cantilever(split=4, load=-50.0)
    spec = scene.to_dict()
    spec["analysis"] = "dynamic"
    spec["point_masses"] = [{"name": "bob", "node": "end", "mass": 0.2}]
    spec["simulation"] = {"t_end": 0.02, "h": 0.001}
    run = SpatialSimulation(spec).simulate()
    index = run.to_vtk(tmp_path / "motion.pvd", every=5)
    frames = ET.parse(index).getroot().find("Collection")
    times = [float(d.get("timestep")) for d in frames]
    assert times == pytest.approx(list(run.time[::5]))
    for k, dataset in zip(range(0, len(run.time), 5), frames):
        mesh = meshio.read(tmp_path / dataset.get("file"))
        nodes = run.q[k].reshape(-1, 7)[:, :3]
        assert np.allclose(mesh.points[:len(nodes)], nodes, atol=1e-12)
        assert np.allclose(mesh.points[len(nodes):], [[0.0, 0.0, 0.0]], atol=1e-12)  # the weld at the root
        lines = mesh.cells_dict["line"]
        assert len(lines) == 4 and mesh.cells_dict["vertex"].ravel().tolist() == [1, len(nodes)]
        axes = np.stack([mesh.point_data[f"axis_{i}"] for i in (1, 2, 3)], axis=2)[:len(nodes)]
        assert np.allclose(axes @ axes.transpose(0, 2, 1), np.eye(3), atol=1e-12)
    assert np.abs(mesh.point_data["axis_1"][1, 2]) > 1e-6  # the tip has turned by the end
    assert np.all(np.isnan(mesh.point_data["velocity"][len(nodes):]))  # a joint's place carries no node's motion
    assert np.all(mesh.cell_data["density"][0] == 1.0)  # at full density
    with pytest.raises(SettingsError, match=r"\.pvd"):
        run.to_vtk(tmp_path / "motion.vtu")
    with pytest.raises(SettingsError, match=r"\.vtu"):
        SpatialSimulation(cantilever()).equilibrium().to_vtk(tmp_path / "state.pvd")


def test_a_spatial_motions_joints_and_bars_reach_paraview_where_and_as_thick_as_they_are(tmp_path):
    """The spatial robot arm in motion: each joint a vertex at its first anchor, where its
    second anchor is too (the revolute hinges and the welds hold their points together, to
    Newton's tolerance), with its index; each line's ``radius`` its tube's outer radius."""
    import meshio

    sim = SpatialSimulation(flextop.scenes.spatial_robot_arm())
    run = sim.simulate(0.5, t_end=0.05)
    index = run.to_vtk(tmp_path / "arm.pvd", every=2)
    mesh = meshio.read(index.parent / f"arm_{len(run.time) - 1:05d}.vtu")
    n, anchors = len(sim.layout.nodes_in_order), sim.model.joint_anchors
    nodes = run.q[-1].reshape(-1, 7)
    second = np.array([nodes[b, :3] + rotations(nodes[b, 3:][None])[0] @ np.asarray(arm)
                       for _, _, (_, b), (_, arm) in anchors])
    assert np.allclose(mesh.points[n:], second, atol=1e-9)
    joint, vertex = (np.concatenate(mesh.cell_data[k]) for k in ("joint", "vertex"))
    assert np.array_equal(joint[vertex == 1], np.arange(len(anchors))) and np.all(joint[vertex != 1] == -1)
    radius = mesh.cell_data["radius"][0]
    assert len(radius) == len(sim.layout.lines) and np.all(radius == 0.006)  # the tubes' 12 mm
    assert np.all(np.isnan(np.concatenate(mesh.cell_data["radius"][1:])))


def test_a_spatial_design_is_seen_in_paraview_and_in_a_3d_figure(tmp_path):
    """The spatial robot arm at a random design: each line of the ParaView frames carries its
    bar's density; the 3D figure draws one line per bar, each as wide as its density says
    (widths linear in the density) and the faint ones below 1.5 x_min; bad designs and
    configurations are named."""
    import meshio
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    from flextop.errors import DesignError
    from flextop.plots import WIDTHS, plot_spatial_design

    sim = SpatialSimulation(flextop.scenes.spatial_robot_arm())
    x = np.random.default_rng(5).uniform(sim.x_min, 1.0, sim.n_design)
    x[:10] = sim.x_min
    run = sim.simulate(x, t_end=0.01)
    index = run.to_vtk(tmp_path / "arm.pvd")
    mesh = meshio.read(index.parent / "arm_00000.vtu")
    variable = np.asarray(sim.layout.line_variable)
    density = mesh.cell_data["density"][0]
    assert len(density) == sim.n_design and np.array_equal(density, x[variable])
    fig = plot_spatial_design(sim, x, q=run.q[-1], view=(10, 30), path=tmp_path / "arm.png")
    (lines,) = [c for c in fig.axes[0].collections if isinstance(c, Line3DCollection)]
    widths = np.asarray(lines.get_linewidths())
    expected = WIDTHS[0] + (WIDTHS[1] - WIDTHS[0]) * (x[variable] - sim.x_min) / (1 - sim.x_min)
    assert np.allclose(widths, expected)
    alpha, void = lines.get_colors()[:, 3], x[variable] < 1.5 * sim.x_min
    assert void.sum() >= 10 and np.all(alpha[void] < 0.5) and np.all(alpha[~void] == 1.0)
    assert (tmp_path / "arm.png").stat().st_size > 10_000
    with pytest.raises(DesignError):
        plot_spatial_design(sim, np.full(sim.n_design, 2.0))
    with pytest.raises(SettingsError, match="q: expected"):
        plot_spatial_design(sim, x, q=run.q[-1][:-1])


def test_the_spatial_robot_arm_at_rest_where_its_drives_end():
    """The arm's equilibrium at the end of its motion (t = 1 s, the scene's t_end): the drives
    move with the load steps from the start, so that the base's radian is reached; the arm
    stays in its vertical plane, turned by the base drive's end (1 rad, to 1e-9), its payload
    where the motion leaves it within 5 mm (the motion's own vibration); its lowest modes
    about that state, by count, with the Sturm count."""
    sim = SpatialSimulation(flextop.scenes.spatial_robot_arm())
    eq = sim.equilibrium()
    assert eq.time == 1.0 and eq.load_steps > 1
    payload = eq.position("payload")
    assert abs(math.atan2(payload[1], payload[0]) - 1.0) < 1e-9
    moved = sim.simulate(t_end=1.0).position("payload")[-1]
    assert np.linalg.norm(payload - moved) < 5e-3, (payload, moved)
    modes = sim.modes(count=4)
    assert modes.below == 4 and np.all(np.diff(modes.frequencies) > 0) and 10.0 < modes.frequencies[0] < 50.0


def test_the_rigid_trajectory_from_python_makes_the_engines_tip_deflection(tmp_path):
    """The spatial robot arm at x = 0.4: the payload's rigid trajectory on the run's grid,
    integrated against its path by the trapezoidal rule over t_f, is the engine's
    tip_deflection to 1e-12; the figure of the two paths is drawn; wrong shapes, unknown names
    and an undriven pendulum are named."""
    from flextop.plots import plot_spatial_paths

    sim = SpatialSimulation(flextop.scenes.spatial_robot_arm())
    run = sim.simulate(0.4, t_end=0.5)
    rigid = sim.rigid_trajectory(t_end=0.5)
    assert rigid.shape == (len(run.time), 3) and np.array_equal(rigid[0], run.position("payload")[0])
    gap = np.sum((run.position("payload") - rigid) ** 2, axis=1)
    d = sim.run_with_sensitivities(0.4, "tip_deflection", t_end=0.5).values[0]
    assert np.trapezoid(gap, run.time) / run.time[-1] == pytest.approx(d, rel=1e-12)
    plot_spatial_paths(run, rigid, "payload", path=tmp_path / "paths.png")
    assert (tmp_path / "paths.png").stat().st_size > 10_000
    with pytest.raises(SettingsError, match="rigid: expected"):
        plot_spatial_paths(run, rigid[1:], "payload")
    with pytest.raises(SettingsError, match="'nowhere' is no body or node"):
        sim.rigid_trajectory("nowhere", t_end=0.1)
    with pytest.raises(SettingsError, match="freedom"):
        SpatialSimulation(pendulum()).rigid_trajectory(t_end=0.1, h=0.01)


def test_the_papers_arm_as_a_3d_lattice_needs_depth_only_with_its_payload_off_its_plane():
    """The paper's arm as lattices of 5 × 3 × 2 nodes (746 bars): with the payload in the
    links' mid-plane it moves in its plane to round-off; 5 cm out of it, the payload leaves
    its plane (by more than 0.1 mm). Its rigid trajectory ends where the reference scenes'
    closed form puts the tip, L(cos θ₁, sin θ₁) + L(cos(θ₁+θ₂), sin(θ₁+θ₂)) at θ = π/2,
    plus the offset; its tip deflection's adjoint gradient to two densities matches central
    differences (1e-5)."""
    flat = SpatialSimulation(flextop.scenes.spatial_paper_arm(offset=0.0))
    assert flat.n_design == 746
    z = flat.simulate(0.4, t_end=0.4).position("payload")[:, 2]
    assert np.abs(z).max() < 1e-12
    sim = SpatialSimulation(flextop.scenes.spatial_paper_arm())
    run = sim.simulate(0.4, t_end=0.4)
    assert np.abs(run.position("payload")[:, 2] - 0.05).max() > 1e-4
    rigid = sim.rigid_trajectory()
    assert np.abs(rigid[-1] - [-1.0, 1.0, 0.05]).max() < 1e-9
    x = np.full(sim.n_design, 0.4)
    g = sim.run_with_sensitivities(x, "tip_deflection", method="adjoint", t_end=0.4)
    for i in (0, 400):
        e = 1e-4
        moved = [sim.run_with_sensitivities(x + s * e * np.eye(sim.n_design)[i], "tip_deflection", t_end=0.4).values[0]
                 for s in (1.0, -1.0)]
        assert (moved[0] - moved[1]) / (2 * e) == pytest.approx(g.dfdx[0, i], rel=1e-5)
