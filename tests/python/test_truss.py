"""The truss bar, the second element kind behind the elements' one interface
(``src/mechanism/element/``): a frame and a truss built from one ground structure, the
linear truss in the small-load limit, the rotation a pin does not have, exact gradients
in statics and in a motion, and the refinement leaving truss bars whole."""

import numpy as np
import pytest

import flextop
from flextop import SceneError
from flextop.discretization.accuracy import split_by

from conftest import assert_exact_gradients

E, D = flextop.scenes.ALUMINIUM["E"], flextop.scenes.DIAMETER


def linear_truss_compliance(model, force, node: str) -> float:
    """``Fᵀu`` of the linear truss ``Σ (EA/L) n nᵀ u = F`` at full density, assembled here
    from the model's nodes and bars, the nodes whose coordinates a joint holds left out
    (the base column, each node pinned)."""
    positions = np.asarray(model.reference_positions).reshape(-1, 2)
    names = model.node_names
    area = np.pi * D**2 / 4
    k = np.zeros((2 * len(names), 2 * len(names)))
    for a, b in np.asarray(model.bars()["nodes"], dtype=int):
        chord = positions[b] - positions[a]
        n = chord / np.linalg.norm(chord)
        block = E * area / np.linalg.norm(chord) * np.outer(n, n)
        for i, j, sign in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
            k[2 * i:2 * i + 2, 2 * j:2 * j + 2] += sign * block
    held = {2 * i + c for i, name in enumerate(names) if name.startswith("truss[0,") for c in (0, 1)}
    free = [d for d in range(2 * len(names)) if d not in held]
    f = np.zeros(2 * len(names))
    f[2 * names.index(node):2 * names.index(node) + 2] = force
    u = np.linalg.solve(k[np.ix_(free, free)], f[free])
    return float(f[free] @ u)


def test_a_frame_and_a_truss_build_from_one_ground_structure():
    frame, truss = (flextop.Simulation(flextop.scenes.static_truss(kind=kind)) for kind in ("frame", "truss"))
    fb, tb = frame.model.bars(), truss.model.bars()
    assert fb["name"] == tb["name"] and np.array_equal(fb["nodes"], tb["nodes"])
    assert set(fb["kind"]) == {"frame"} and set(tb["kind"]) == {"truss"}
    assert tb["elements"] == [1] * len(tb["name"])
    x = np.full(truss.n_design, 0.6)
    # The pin-jointed truss is stiffer here only through its supports: three pins against
    # one clamp; both stand.
    assert 0 < truss.run_with_sensitivities(x, ["compliance"])[0][0] < frame.run_with_sensitivities(x, ["compliance"])[0][0]


def test_small_loads_give_the_linear_truss_compliance():
    force = np.array([30.0, -100.0]) * 1e-6
    scene = flextop.scenes.static_truss(kind="truss", force=tuple(force), x_min=1e-3)
    sim = flextop.Simulation(scene)
    f, _ = sim.run_with_sensitivities(np.ones(sim.n_design), ["compliance"], tol=1e-14)
    expected = linear_truss_compliance(sim.model, force, "truss[4,1]")
    assert f[0] == pytest.approx(expected, rel=1e-6)
    # Scaled back: the nonlinear truss departs from the linear one at the real load.
    assert expected / 1e-12 == pytest.approx(
        linear_truss_compliance(sim.model, force / 1e-6, "truss[4,1]"), rel=1e-12)


def test_a_node_only_truss_bars_meet_has_no_rotation():
    sim = flextop.Simulation(flextop.scenes.static_truss(kind="truss"))
    q = sim.run(np.full(sim.n_design, 0.5)).q.reshape(-1, 3)
    assert np.all(q[:, 2] == 0.0) and np.abs(q[:, :2]).max() > 0


def test_a_moment_on_a_pin_and_a_split_truss_bar_are_named():
    scene = flextop.scenes.static_truss(kind="truss")
    scene.load("truss[2,1]", moment=1.0)
    with pytest.raises(SceneError, match="only truss bars or continuum cells meet: a pin carries no moment"):
        flextop.Simulation(scene)
    with pytest.raises(SceneError, match="a truss bar is one element"):
        flextop.Simulation(flextop.scenes.static_truss(kind="truss", split=2))
    with pytest.raises(SceneError, match="kind"):
        flextop.scenes.static_truss(kind="cable")


def test_a_joint_on_a_rotation_truss_bars_do_not_turn_is_named():
    """The arm with truss links: its elbow drive would turn a node the pinned bars do not
    turn with (at solve, a singular matrix); a clamp at a truss support likewise locks
    nothing. Both are refused at the build, naming the joint."""
    arm = flextop.scenes.robot_arm().to_dict()
    for g in arm["ground_structures"]:
        g["kind"] = "truss"
    with pytest.raises(SceneError, match=r"joints\[0\] \(shoulder\): acts on the rotation of node 'link1\[0,1\]'"):
        flextop.Simulation(arm)
    truss = flextop.scenes.static_truss(kind="truss").to_dict()
    truss["joints"][1] = {"kind": "clamp", "name": "held", "node": "truss[0,1]"}
    with pytest.raises(SceneError, match=r"joints\[1\] \(held\).*pin the node instead of clamping it"):
        flextop.Simulation(truss)


def test_refinement_leaves_truss_bars_whole():
    spec = flextop.scenes.static_truss(kind="truss").to_dict()
    spec["splits"] = {"truss/bar3": 1}
    refined = split_by(spec, 4)
    assert refined["ground_structures"][0]["split"] == 1 and refined["splits"] == {"truss/bar3": 1}
    sim = flextop.Simulation(flextop.scenes.static_truss(kind="truss"))
    x = np.full(sim.n_design, 0.5)
    run = sim.run(x, rtol=1e-3)
    # Truss bars are exact in space: the companion with "twice the elements" is the same model.
    assert run.response("compliance") == pytest.approx(sim.run(x).response("compliance"), rel=1e-12)
    # In motion, the space companion guided by the prolongation: a truss bar maps end to end.
    moving = flextop.Simulation(dynamic_truss())
    run = moving.run(np.full(moving.n_design, 0.5), rtol=1e-2)
    assert run.error_estimate("strain_energy") <= 1e-2


def dynamic_truss() -> flextop.Scene:
    """The truss ground structure in motion: its base column pinned, a load ramped on and
    off at the tip, under gravity, with stiffness-proportional damping."""
    scene = flextop.Scene("moving_truss", analysis="dynamic", gravity=(0.0, -9.81))
    scene.section("al", E=E, nu=0.32, rho=2700.0, diameter=D, rayleigh=(0.0, 2e-5))
    g = scene.ground_structure("truss", nx=4, ny=2, length=0.6, height=0.1, section="al", kind="truss")
    for j in range(2):
        scene.pin(f"base{j}", g.node(0, j))
    scene.load(g.node(3, 1), force=(0.0, -200.0), table=([0.0, 0.01, 0.02], [0.0, 1.0, 0.0]))
    scene.design(interpolation="simp", p=3.0, x_min=0.01)
    scene.simulation(t_end=0.03, h=5e-4)
    return scene


@pytest.mark.parametrize("scene, responses", [
    (flextop.scenes.static_truss(kind="truss"), ["compliance", "stress:p=8", "buckling:p=8"]),
    (dynamic_truss(), ["strain_energy", "compliance", "displacement:truss[3,1]:0,1"]),
])
def test_truss_gradients_match_differences_and_direct_equals_adjoint(scene, responses):
    sim = flextop.Simulation(scene)
    assert_exact_gradients(sim, np.random.default_rng(7).uniform(0.2, 0.95, sim.n_design), responses,
                           (1, sim.n_design - 2))
