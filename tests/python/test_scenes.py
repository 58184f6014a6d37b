"""Scene building: reference scenes, builder/TOML equivalence, and every kind of bad input
raising its documented exception with the culprit named."""

import math

import numpy as np
import pytest

import flextop
from flextop import DesignError, SceneError, SettingsError, SimulationError
from flextop.scenes.builder import tomllib

from conftest import EXAMPLES, cantilever


def summary(sim: flextop.Simulation) -> dict:
    bars = sim.bars
    return {
        "positions": np.asarray(sim.model.reference_positions),
        "bar_nodes": np.asarray(bars.nodes),
        "bar_variable": list(bars.variable),
        "bar_component": list(bars.component),
        "bar_volume": np.asarray(bars.volume),
        "joints": sim.model.joints(),
        "names": sim.node_names,
        "analysis": sim.analysis,
        "tip": sim.tip,
    }


@pytest.mark.parametrize("name", ["robot_arm", "static_truss"])
def test_builders_and_example_files_give_the_same_model(name):
    built = summary(flextop.Simulation(getattr(flextop.scenes, name)()))
    loaded = summary(flextop.Simulation(EXAMPLES / f"{name}.toml"))
    for key, value in built.items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(value, loaded[key], err_msg=key)
        else:
            assert value == loaded[key], key


@pytest.mark.parametrize("name", sorted(flextop.scenes.EXAMPLES))
def test_example_files_are_the_builders_output(name):
    committed = (EXAMPLES / name).read_text(encoding="utf-8")
    assert committed == flextop.scenes.example_toml(name), f"examples/{name} is stale: run python scripts/write_examples.py"


def test_to_toml_reads_back_as_the_same_dict():
    scene = flextop.Scene("every kind of entry", gravity=(0.0, -9.81))
    scene.section("steel", E=210e9, G=81e9, rho=7850.0, A=1e-4, I=8.3e-10, kappa=5 / 6)
    scene.section("odd name.with \"quotes\"", E=1.5e15, nu=0.3, rho=2.5e20, diameter=1e-3)
    scene.node("o", 0.0, 0.0)
    scene.node("tip\tnode", 1.0, -2.5e-7)
    scene.beam("o", "tip\tnode", section="steel", split=3, name="b", component="c", group="g", fixed=True)
    gs = scene.ground_structure("g1", nx=3, ny=2, length=1.0, height=0.2, section="steel", origin="o", angle=0.5)
    scene.point_mass(gs.node(2, 1), 1.0, inertia=0.01)
    scene.load(gs.node(2, 0), force=np.array([1.0, -2.0]), moment=np.float64(0.5), table=([0.0, 1.0], [0.0, 1.0]))
    scene.clamp("root", "o")
    scene.hinge("h", gs.node(0, 0), gs.node(0, 1), drive=flextop.motion_table([0.0, 1.0], [0.0, 0.2]))
    scene.pin("p", gs.node(1, 1), drive=flextop.trapezoidal(0.0, 1.0, acceleration=2.0, speed=0.5, t_start=0.1))
    scene.design(interpolation="ramp", q=5.0, x_min=1e-3)
    scene.simulation(t_end=1.0, h=0.01, mass="lumped", max_iter=30)
    scene.tip = "tip\tnode"
    scene.split("g1/bar2", 4)
    text = scene.to_toml(header="a header\n\nover lines", comments={"sections.steel": "a comment", "joints[2]": "pin"})
    assert text.startswith("# a header\n#\n# over lines\n")
    assert "[sections.steel]          # a comment\n" in text and "[[joints]]                # pin\n" in text
    assert "E = 210e9\n" in text and "E = 1500e12\n" in text and "rho = 2.5e+20\n" in text
    assert tomllib.loads(text) == json_like(scene.to_dict())


def test_a_bar_split_on_its_own_refines_that_bar_alone():
    """``Scene.split`` gives one bar its own elements; a split given to every bar builds and
    runs as the uniform one, and refining a scene refines each bar's own split."""
    from flextop.discretization.accuracy import split_by
    scene = flextop.scenes.robot_arm()
    scene.split("link1/bar12", 4)
    sim = flextop.Simulation(scene)
    elements = np.bincount(np.asarray(sim.model.elements()["bar"]))
    assert elements.sum() == 148 + 3 and elements[list(sim.bars.name).index("link1/bar12")] == 4
    refined = flextop.Simulation(split_by(scene.to_dict(), 2))
    assert len(refined.model.elements()["bar"]) == 2 * (148 + 3)
    each = flextop.scenes.robot_arm()
    for name in sim.bars.name:
        each.split(name, 2)
    x = np.random.default_rng(4).uniform(0.1, 1.0, sim.n_design)
    uniform = flextop.Simulation(flextop.scenes.robot_arm(split=2)).run(x, t_end=0.2).tip_deflection()
    assert flextop.Simulation(each).run(x, t_end=0.2).tip_deflection() == uniform
    with pytest.raises(SceneError, match="splits.link1/bar999"):
        bad = flextop.scenes.robot_arm()
        bad.split("link1/bar999", 2)
        flextop.Simulation(bad)


def test_unknown_nodes_and_a_missing_tip_are_settings_errors():
    pendulum = flextop.Simulation(flextop.scenes.pendulum(periods=0.05))
    with pytest.raises(SettingsError, match="node 'nope': the scene has no node of that name"):
        pendulum.node("nope")
    res = pendulum.run()
    assert pendulum.tip is None
    with pytest.raises(SettingsError, match="the scene has no `tip`"):
        res.tip_error()


def json_like(value):
    """``value`` with tuples and numpy values as the lists and floats that TOML reads back."""
    if isinstance(value, dict):
        return {k: json_like(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [json_like(v) for v in value]
    return value.item() if isinstance(value, np.generic) else value


def test_reference_robot_arm_dimensions():
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    assert sim.n_design == 148 and sim.components == ["link1", "link2"]
    pos = np.asarray(sim.model.reference_positions)
    tip = pos[sim.tip]
    # Link 2's node (L, 0): L(cos θ1, sin θ1) + L(cos 2θ1, sin 2θ1) at θ1 = π/3.
    np.testing.assert_allclose(tip, [math.cos(math.pi / 3) + math.cos(2 * math.pi / 3), math.sin(math.pi / 3) + math.sin(2 * math.pi / 3)], atol=1e-15)
    volume = np.asarray(sim.bars.volume)
    assert volume.sum() / 2 == pytest.approx(math.pi * 0.01**2 * sum_of_bar_lengths(5, 3, 1.0, 0.1))


def sum_of_bar_lengths(nx, ny, length, height):
    pts = [(length * i / (nx - 1), height * (j / (ny - 1) - 0.5)) for i in range(nx) for j in range(ny)]
    total = 0.0
    for a in range(len(pts)):
        for b in range(a + 1, len(pts)):
            di, dj = abs(a // ny - b // ny), abs(a % ny - b % ny)
            if math.gcd(di, dj) == 1:
                total += math.dist(pts[a], pts[b])
    return total


def bad(mutate):
    spec = flextop.scenes.robot_arm().to_dict()
    mutate(spec)
    return spec


@pytest.mark.parametrize(
    "mutate, culprit",
    [
        (lambda s: s["sections"]["aluminium"].update(modulus=1.0), "modulus"),
        (lambda s: s["joints"][0]["drive"].update(sped=0.5), "sped"),
        (lambda s: s["sections"]["aluminium"].update(E=-70e9), "sections.aluminium.E"),
        (lambda s: s["sections"]["aluminium"].update(E=0.0), "sections.aluminium.E"),
        (lambda s: s["sections"]["aluminium"].update(rho=float("nan")), "sections.aluminium.rho"),
        (lambda s: s["point_masses"][0].update(mass=float("inf")), "point_masses[0].mass"),
        (lambda s: s["joints"][0]["drive"].update(speed=-1.0), "joints[0].drive.speed"),
        (lambda s: s["ground_structures"][0].update(height=0.0), "height"),
        (lambda s: s["ground_structures"][1].update(name="link1"), "duplicate node name 'link1[0,0]'"),
        (lambda s: s["joints"][1].update(name="shoulder"), "joints[1] (shoulder): duplicate name: joints[0] is called 'shoulder' too"),
        (lambda s: s["point_masses"][0].update(node="link3[4,1]"), "unknown node 'link3[4,1]'"),
        (lambda s: s["ground_structures"][1].update(origin=[0.5, 0.9]), "must coincide"),
        (lambda s: s["joints"].append({"kind": "pin", "name": "again", "node": "link1[0,1]"}), "over-constrained"),
        (lambda s: s["joints"].pop(1), "unconstrained"),
        (lambda s: s["design"].update(x_min=0.0), "design.x_min"),
        (lambda s: s["design"].update(p=float("nan")), "design.p"),
        (lambda s: s["simulation"].update(rho_inf=1.5), "simulation.rho_inf"),
        (lambda s: s["joints"][0]["drive"].pop("acceleration"), "joints[0].drive: a trapezoidal law needs `acceleration`"),
        (lambda s: s["joints"][0]["drive"].update(acceleration="x"), "joints[0].drive.acceleration: expected a number, got the text \"x\""),
        # A law from 1e15 rad turned 0.125 rad instead of 0.15, from 1e17 rad not at all.
        (lambda s: s["joints"][0]["drive"].update(start=1e15, end=1e15 + 0.15), "joints[0].drive: moves 1.250e-1 from 1.000000e15, where numbers are held only to 2.220e-1"),
        (lambda s: s["joints"][0]["drive"].update(start=1e17, end=1e17 + 0.15), "joints[0].drive: moves 0.000e0 from 1.000000e17"),
        (lambda s: s["joints"].__setitem__(0, {**s["joints"][0], "drive": flextop.motion_table([0.0, 0.5, 1.0], [1e12, 1e12 + 0.1, 1e12 + 0.2])}), "joints[0].drive: moves 2.000e-1 from 1.000000e12"),
        # Types are kept, not taken by truthiness: "false" fixed a bar, True was 1 kg.
        (lambda s: s["ground_structures"][0].update(rigid="false"), 'ground_structures[0].rigid: expected true or false, got the text "false"'),
        (lambda s: s["ground_structures"][0].update(rigid=1), "ground_structures[0].rigid: expected true or false, got the whole number `1`"),
        (lambda s: s["point_masses"][0].update(mass=True), "point_masses[0].mass: expected a number, got `true`"),
        (lambda s: s["ground_structures"][0].update(length=True), "ground_structures[0].length: expected a number, got `true`"),
        (lambda s: s["ground_structures"][0].update(split=2.0), "ground_structures[0].split: expected a whole number ≥ 0, got the number `2.0`"),
        (lambda s: s["ground_structures"][0].update(nx=10**30), "ground_structures[0].nx: the whole number 10" + "0" * 29 + " is too large"),
        (lambda s: s["point_masses"][0].update(mass=object()), "point_masses[0].mass: expected a number, text, list or table, got object"),
        (lambda s: s["joints"][0].update(kind=3), "joints[0].kind: expected a name (text)"),
        (lambda s: s["joints"][0]["drive"].update(kind="bogus"), "joints[0].drive.kind: unknown value `bogus`"),
        (lambda s: s["joints"][0]["drive"].update(t=[0.0, 1.0]), "joints[0].drive: a trapezoidal law does not take `t`"),
        (lambda s: s["joints"][1].update(node="link1[4,1]"), "joints[1]: a hinge takes two `nodes` [a, b], not `node`"),
        (lambda s: s["joints"][0].update(kind="clamp"), "joints[0]: a clamp has no drive"),
        (lambda s: s["ground_structures"][1].update(origin=[1, 2, 3]), "origin: invalid length 3, expected a node's name or coordinates"),
        (lambda s: s["ground_structures"][0].update(nx=-1), "ground_structures[0].nx: expected a whole number ≥ 0"),
    ],
)
def test_bad_scenes_raise_scene_error_naming_the_culprit(mutate, culprit):
    with pytest.raises(SceneError, match=None) as info:
        flextop.Simulation(bad(mutate))
    assert culprit in str(info.value)
    assert isinstance(info.value, ValueError)


def test_numpy_values_keep_their_types():
    """numpy's booleans, integers and floats are read as Python's: an optimizer's output fed
    back into a scene works."""
    spec = flextop.scenes.spun_beam().to_dict()
    spec["beams"][0].update(fixed=np.True_, split=np.int64(2))
    spec["point_masses"][0].update(mass=np.float32(0.25))
    spec["nodes"][1].update(x=np.float64(0.125))
    spec["joints"][0]["drive"] = {"kind": "table", "t": np.linspace(0.0, 0.6, 4), "theta": np.array([0.0, 0.1, 0.5, 0.6])}
    sim = flextop.Simulation(spec)
    assert sim.n_design == 7 and "bar0" not in sim.variable_names


def test_a_string_boolean_in_a_toml_file_is_a_scene_error(tmp_path):
    text = flextop.scenes.spun_beam().to_toml().replace("fixed = false", 'fixed = "false"', 1)
    assert 'fixed = "false"' in text
    (tmp_path / "spun.toml").write_text(text)
    with pytest.raises(SceneError, match=r'beams\[0\]\.fixed: expected true or false, got the text "false"'):
        flextop.Simulation(tmp_path / "spun.toml")


def test_drives_must_start_at_rest():
    spec = flextop.scenes.robot_arm().to_dict()
    spec["joints"][0]["drive"] = flextop.motion_table([0.0, 1.0], [1.0, 1.5], start_velocity=0.3)
    with pytest.raises(SceneError, match=r"joints\[0\]\.drive: moves at t = 0 .* drives start at rest"):
        flextop.Simulation(spec)


def test_zero_length_bar_is_rejected():
    scene = flextop.Scene()
    scene.section("s", E=1e9, nu=0.3, rho=1000.0, diameter=0.01)
    scene.node("a", 1.0, 2.0)
    scene.node("b", 1.0, 2.0)
    scene.beam("a", "b", section="s")
    scene.clamp("c", "a")
    with pytest.raises(SceneError, match="zero-length bar: nodes 'a' and 'b' coincide"):
        flextop.Simulation(scene)


def test_static_mechanism_is_unconstrained():
    spec = flextop.scenes.static_truss().to_dict()
    spec["joints"][0]["kind"] = "pin"
    with pytest.raises(SceneError, match="mechanism with 1 free rigid-body mode"):
        flextop.Simulation(spec)


def test_toml_syntax_and_unknown_table_errors(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text((EXAMPLES / "robot_arm.toml").read_text().replace("[design]", "[desing]"))
    with pytest.raises(SceneError, match="desing"):
        flextop.Simulation(path)


@pytest.mark.parametrize(
    "x, match",
    [
        (np.full(147, 0.4), "147 entries"),
        (np.r_[np.full(147, 0.4), 1.5], r"x\[147\] \(link2/bar73\) = 1.5 is outside \[0.01, 1\]"),
        (np.r_[0.005, np.full(147, 0.4)], r"x\[0\] \(link1/bar0\)"),
        (np.r_[np.nan, np.full(147, 0.4)], r"x\[0\]"),
        (np.r_[5e-324, np.full(147, 0.4)], r"x\[0\] \(link1/bar0\) = 5e-324 is outside"),
        (np.full((2, 74), 0.4), r"one number or a vector of 148, got an array of shape \(2, 74\)"),
        ("0.4", "real numbers, got str"),
        (np.full(148, "0.4"), "real numbers, got ndarray of <U3"),
        (0.4 + 0j, "real numbers, got complex"),
    ],
)
def test_designs_outside_bounds_raise_design_error(arm, x, match):
    with pytest.raises(DesignError, match=match):
        arm.run(x)


@pytest.mark.parametrize(
    "kwargs, match",
    [({"h": 0.0}, "h: step size must be positive"), ({"h": float("nan")}, "h:"), ({"rho_inf": -0.1}, "rho_inf"),
     ({"t_end": -1.0}, "t_end"), ({"tol": 2.0}, "tol"), ({"mass": "diagonal"}, "mass")],
)
def test_bad_settings_raise_settings_error(arm, kwargs, match):
    with pytest.raises(SettingsError, match=match):
        arm.run(0.4, **kwargs)


def test_missing_step_size_is_named():
    sim = flextop.Simulation(cantilever())
    with pytest.raises(SettingsError, match="t_end: not given"):
        sim.run()


def test_failed_newton_reports_time_residual_and_iterations(arm):
    with pytest.raises(SimulationError, match=r"Newton did not converge at t = 0\.020000 s: residual .* after 1 iterations"):
        arm.run(0.4, max_iter=1)


def test_a_scene_written_in_degrees_runs_as_the_one_in_radians(tmp_path):
    """``start_deg``/``end_deg``/``speed_deg``/``acceleration_deg`` of a drive and
    ``angle_deg`` of a ground structure are the radians' keys in degrees."""
    text = (EXAMPLES / "robot_arm.toml").read_text()
    rad = "start = 1.0471975511965976, end = 1.5707963267948966, acceleration = 2.0, speed = 0.5 }"
    deg = "start_deg = 60.0, end_deg = 90.0, acceleration_deg = 114.59155902616465, speed_deg = 28.64788975654116 }"
    assert rad in text
    path = tmp_path / "degrees.toml"
    path.write_text(text.replace(rad, deg))
    x = 0.4
    d = flextop.Simulation(EXAMPLES / "robot_arm.toml").run(x).response("tip_deflection")
    assert flextop.Simulation(path).run(x).response("tip_deflection") == pytest.approx(d, rel=1e-12)
    path.write_text(text.replace(rad, rad.replace("start =", "start_deg = 60.0, start =")))
    with pytest.raises(flextop.SceneError, match="`start` .rad. or `start_deg`, not both"):
        flextop.Simulation(path)


def test_the_builder_refuses_a_second_entry_of_one_name():
    """A second section (or split, or initial rate) of one name replaced the first without
    a word; TOML refuses a key given twice, and so does the builder now."""
    scene = flextop.scenes.spun_beam()
    with pytest.raises(SceneError, match="section 'aluminium': given twice"):
        scene.section("aluminium", E=1e9, rho=1000.0, nu=0.3, diameter=0.01)
    scene.split("bar0", 2)
    with pytest.raises(SceneError, match="split 'bar0': given twice"):
        scene.split("bar0", 3)
    pendulum = flextop.scenes.pendulum()
    pendulum.initial_rate("pivot", 1.0)
    with pytest.raises(SceneError, match="initial_rate 'pivot': given twice"):
        pendulum.initial_rate("pivot", 2.0)
    assert scene.to_dict()["sections"]["aluminium"]["E"] == 70e9 and scene.to_dict()["splits"] == {"bar0": 2}
