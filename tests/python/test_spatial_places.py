"""Gradients of spatial mechanisms to their joints' places (``position_x:JOINT`` …): the
joint moved along an axis of space where the scene builds it, both its anchors' points with
it. Against fourth-order differences of scenes rebuilt with the points moved, and direct
against adjoint: over the spatial slider-crank's motion, its trapezoidal drive's kinks on
the grid (the run restarts there), and at a hinged bar's equilibrium. Names the scene lacks,
and the deflection whose rigid trajectory would move, are refused."""

import numpy as np
import pytest

from flextop import SettingsError, SpatialScene, SpatialSimulation
from flextop.scenes import spatial_slider_crank
from flextop.scenes.spatial import axis_angle


def assert_exact(spec: dict, responses: list[str], places: list[tuple[str, int]], *, step: float = 1e-4,
                 x: np.ndarray | None = None, **options) -> np.ndarray:
    """Direct = adjoint to 1e-9 and fourth-order differences (steps of ``step`` m) to 1e-6,
    beside the differences' noise (values reproducible to 1e-10, Newton's tolerance, over the
    step); the differences run scenes rebuilt with the joints' points moved
    (:meth:`SizingProblem.spec_at`, apart from the engine's parameters)."""
    from flextop.problems import SizingProblem

    names = [f"position_{'xyz'[axis]}:{joint}" for joint, axis in places]
    layout = SizingProblem(spec, responses[0], places={f"{joint}.{'xyz'[axis]}": (-10.0, 10.0) for joint, axis in places})
    sim = SpatialSimulation(spec)
    direct = sim.run_with_sensitivities(x, responses, names, method="direct", **options)
    adjoint = sim.run_with_sensitivities(x, responses, names, method="adjoint", **options)
    g, values = direct.gradient, np.abs(direct.values)
    noise = 1e-10 * values / step
    for j, (joint, axis) in enumerate(places):
        assert np.all(np.abs(adjoint.gradient[:, j] - g[:, j]) <= 1e-9 * np.abs(g[:, j]) + 1e-6 * noise), names[j]

        def value(k: float, j=j) -> np.ndarray:
            z = layout.z0.copy()
            z[j] += k * step
            return SpatialSimulation(layout.spec_at(z)).run_with_sensitivities(x, responses, [], **options).values

        fd = (value(-2) - 8 * value(-1) + 8 * value(1) - value(2)) / (12 * step)
        assert np.all(np.abs(g[:, j] - fd) <= 1e-6 * np.abs(fd) + noise), (names[j], g[:, j], fd, noise)
    return g


def test_gradients_to_every_joint_s_place_in_the_slider_crank_s_motion_are_exact():
    """The crank's pivot (on the ground), the pin (crank to rod), the wrist (rod to the
    slider's centre) and the slide (a point of the ground to the slider), each along one
    axis: the slider's travel, the rod's height, the drive's effort, the pin's force and the
    kinetic energy. The drive's law reaches its speed at 0.1 s and its end at 0.2 s, steps
    25 and 50 of 4 ms: the run restarts at both, and the gradients go through the restarts."""
    spec = spatial_slider_crank(turn=2.0, t_end=0.3, h=0.004).to_dict()
    law = spec["joints"][0]["drive"]
    assert (law["end"], law["acceleration"], law["speed"]) == (2.0, 200.0, 20.0)  # kinks at 0.1 and 0.2 s
    responses = ["x:slider", "z:rod", "torque_squared:crank", "reaction:pin", "kinetic_energy"]
    places = [("crank", 2), ("pin", 0), ("pin", 1), ("wrist", 2), ("slide", 1)]
    g = assert_exact(spec, responses, places)
    # The slide's place moves nothing: the slider slides without turning, so its point and
    # the ground's moving together relabel the same motion. Every other place moves the
    # effort and the pin's force.
    assert np.abs(g[:, 4]).max() < 1e-15 * np.abs(g).max()
    assert np.all(np.abs(g[2:4, :4]) > 1e-3)


def test_gradients_to_the_spatial_arm_s_hinges_places_through_its_flexible_links_are_exact():
    """The spatial robot arm (lattice links of 3 × 2 × 2 nodes, a graded design): the
    shoulder's lift hinge along z, the elbow's fold along x and the base's turn along y,
    their places moving how the links' beams are loaded: the strain energy's mean and the
    lift's effort, direct = adjoint and against differences of rebuilt scenes."""
    from flextop.scenes import spatial_robot_arm

    spec = spatial_robot_arm(nx=3, t_end=0.36, h=0.012).to_dict()
    x = np.linspace(0.4, 1.0, SpatialSimulation(spec).n_design)
    g = assert_exact(spec, ["strain_energy", "torque_squared:lift"], [("lift", 2), ("fold", 0), ("turn", 1)], x=x)
    assert np.all(np.abs(g) > 1e-3 * np.abs(g).max(axis=1, keepdims=True))


def bar() -> dict:
    """A 1 kg bar of 0.6 m, its centre at the origin, hinged about y at a point 0.2 m from its
    centre, held near level by a torsion spring of 30 N m/rad under gravity."""
    scene = SpatialScene("hinged bar", analysis="static", gravity=(0.0, 0.0, -9.81))
    scene.rigid_body("bar", mass=1.0, inertia=(1e-4, 0.03, 0.03), position=(0.0, 0.0, 0.0),
                     points={"pivot": (-0.2, 0.0, 0.0)})
    scene.revolute("hinge", "bar.pivot", axis=(0.0, 1.0, 0.0))
    scene.torsion("spring", "hinge", k=30.0)
    return scene.to_dict()


def test_gradients_to_a_hinge_s_place_at_an_equilibrium_are_exact_and_as_the_closed_form_says():
    """Moving the hinge along the bar moves its lever: the bar's weight turns it by
    θ = m g l cos θ / k about the hinge, l the centre's distance from it, so that
    dθ/dl = m g cos θ / (k + m g l sin θ); the centre's height z = −l sin θ then moves by
    −sin θ − l cos θ dθ/dl per metre of the hinge along x (the pivot's point, and the ground's
    with it, moved by dl = −dx: the centre ends further from the hinge as the hinge moves
    towards −x, l = 0.2 − x)."""
    spec = bar()
    g = assert_exact(spec, ["z:bar", "x:bar"], [("hinge", 0), ("hinge", 2)])
    out = SpatialSimulation(spec).run_with_sensitivities(None, ["z:bar"], [])
    z = float(out.values[0])
    mg, k, lever = 9.81, 30.0, 0.2
    theta = np.arcsin(-z / lever)
    # The hinge moved by x: l = 0.2 − x and the centre at hinge + l (cos θ, −sin θ).
    dtheta = mg * np.cos(theta) / (k + mg * lever * np.sin(theta))
    assert g[0, 0] == pytest.approx(np.sin(theta) + lever * np.cos(theta) * dtheta, rel=1e-8)


def test_places_that_are_not_in_the_scene_or_move_a_rigid_trajectory_are_refused():
    """A joint whose bodies turn relative to each other at the start (the heavy top spins
    on its pivot) is refused too: moving its place would break their initial rates, whose
    rate to it is not built."""
    from flextop.scenes import heavy_top

    with pytest.raises(SettingsError, match="joint 'pivot': its bodies turn relative to each other at the start"):
        SpatialSimulation(heavy_top()).run_with_sensitivities(None, ["x:top"], ["position_x:pivot"])
    sim = SpatialSimulation(spatial_slider_crank(turn=2.0, t_end=0.3, h=0.004))
    with pytest.raises(SettingsError, match="'position_x:elbow': 'elbow' is no joint of the scene"):
        sim.run_with_sensitivities(None, ["x:slider"], ["position_x:elbow"])
    with pytest.raises(SettingsError, match="'position_w:pin': 'position_w' is not a parameter kind"):
        sim.run_with_sensitivities(None, ["x:slider"], ["position_w:pin"])
    with pytest.raises(SettingsError, match="a joint's place moves responses\\[0\\]'s rigid trajectory"):
        sim.run_with_sensitivities(None, ["tip_deflection"], ["position_x:pin"])


# Places as an optimization's design (flextop.problems.SizingProblem).

PLACES = {"pin.x": (0.1, 0.2), "pin.y": (-0.05, 0.05), "wrist.z": (-0.05, 0.05)}


def crank() -> dict:
    return spatial_slider_crank(turn=2.0, t_end=0.3, h=0.004).to_dict()


def test_a_sizing_problem_over_places_has_the_gradients_of_its_differences():
    """The drive's effort over the pin's place in x and y (the crank's length and the pin's
    offset across it) and the wrist's in z: the problem's gradient, the engine's, against
    fourth-order differences of the problem itself (each evaluation a scene rebuilt with
    the points moved); the start is where the scene builds the joints."""
    from flextop.problems import SizingProblem

    problem = SizingProblem(crank(), "torque_squared:crank", places=PLACES)
    np.testing.assert_allclose(problem.z0, [0.15, 0.0, 0.0], atol=1e-15)
    z, e = problem.z0, problem.evaluate(problem.z0)
    for k in range(problem.n):
        delta = 1e-4

        def at(by: float, k=k) -> float:
            moved_z = z.copy()
            moved_z[k] += by * delta
            return problem.evaluate(moved_z).f0

        fd = (at(-2) - 8 * at(-1) + 8 * at(1) - at(2)) / (12 * delta)
        assert e.df0[k] == pytest.approx(fd, rel=1e-6), k


def test_mma_over_places_shortens_the_crank_to_a_kkt_point():
    """The effort falls with the crank's length (the same turn sweeps the rod less): MMA
    takes the pin to its lower bound in x, finds its offset across the crank inside its
    bounds and ends at a KKT point, the effort a fifth of the start's (measured 0.196)."""
    from flextop import optimize
    from flextop.problems import SizingProblem

    problem = SizingProblem(crank(), "torque_squared:crank", places=PLACES)
    result = optimize(problem, problem.z0, "mma", max_iter=100, kkt_tol=1e-5)
    assert result.success, result.message
    assert result.x[0] == pytest.approx(0.1, abs=1e-9)
    assert -0.05 < result.x[1] < 0.05
    assert problem.evaluate(result.x).f0 < 0.25


def test_places_on_turned_bodies_and_a_shared_point_have_the_gradients_of_their_differences():
    """The hinged bar built turned (its axes 0.7 rad about y from space's), its hinge on a
    body point that a spring to the ground shares, and its place along x and z as the design:
    each place moves the hinge's point by R₀ᵀe in the bar's axes and leaves the spring's
    where it was. The problem's gradient against fourth-order differences of the problem."""
    from flextop.problems import SizingProblem

    scene = SpatialScene("turned bar", analysis="static", gravity=(0.0, 0.0, -9.81))
    scene.rigid_body("bar", mass=1.0, inertia=(1e-4, 0.03, 0.03), position=(0.0, 0.0, 0.0),
                     orientation=axis_angle((0.0, 1.0, 0.0), 0.7), points={"pivot": (-0.2, 0.0, 0.0)})
    scene.revolute("hinge", "bar.pivot", axis=(0.0, 1.0, 0.0))
    scene.torsion("coil", "hinge", k=30.0)
    scene.spring("tether", "bar.pivot", [0.0, 0.0, 0.3], k=50.0)
    # Newton to 1e-13: at its 1e-10 the equilibria differenced are reproducible to 1e-10 of the
    # forces, which read 2e-6 of the smaller gradient over the step.
    problem = SizingProblem(scene, "z:bar", places={"hinge.x": (-0.5, 0.5), "hinge.z": (-0.5, 0.5)},
                            reference=1.0, tol=1e-13)
    start = np.array([-0.2 * np.cos(0.7), 0.2 * np.sin(0.7)])
    np.testing.assert_allclose(problem.z0, start, atol=1e-15)
    moved_spec = problem.spec_at(problem.z0 + [0.01, 0.0])
    assert next(b for b in moved_spec["rigid_bodies"])["points"]["pivot"] == [-0.2, 0.0, 0.0]
    e = problem.evaluate(problem.z0)
    assert np.all(np.abs(e.df0) > 1e-3)
    for k in range(problem.n):
        delta = 1e-4

        def at(by: float, k=k) -> float:
            z = problem.z0.copy()
            z[k] += by * delta
            return problem.evaluate(z).f0

        fd = (at(-2) - 8 * at(-1) + 8 * at(1) - at(2)) / (12 * delta)
        assert e.df0[k] == pytest.approx(fd, rel=1e-8), k


@pytest.mark.parametrize(("places", "culprit"), [
    ({"elbow.x": (0.0, 1.0)}, "no joint called 'elbow'"),
    ({"pin.w": (0.0, 1.0)}, "the axis is x, y or z"),
    ({"pin.x": (0.2, 0.1)}, "must be finite with lower < upper"),
    ({"pin.x": (0.0, float("inf"))}, "must be finite with lower < upper"),
    ({"pin.x": (0.16, 0.2)}, "the joint's 0.15 m lies outside"),
    ({"pin.x": "wide"}, "bounds as \\(lower, upper\\)"),
])
def test_bad_places_are_named(places, culprit):
    from flextop.problems import SizingProblem

    with pytest.raises(SettingsError, match=culprit):
        SizingProblem(crank(), "torque_squared:crank", places=places)


def test_a_joint_that_holds_a_node_cannot_be_placed_and_a_problem_needs_a_variable():
    from flextop.problems import SizingProblem
    from flextop.scenes import spatial_robot_arm

    with pytest.raises(SettingsError, match="holds node 'link1\\[0,0,0\\]'"):
        SizingProblem(spatial_robot_arm(nx=3), "strain_energy", places={"shoulder_link100.x": (-1.0, 1.0)})
    with pytest.raises(SettingsError, match="sizes or places: name at least one"):
        SizingProblem(crank(), "torque_squared:crank")
