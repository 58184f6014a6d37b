"""Spatial runs to a tolerance (``rtol``): every frame beam's elements and the steps chosen by
step doubling. Against references on far finer grids: the values within ``rtol``, the
gradients within ``5·rtol``, the estimates never below the true error by more than 2×; over
a motion and at an equilibrium. A node inside a beam is the same point on every grid. Bad
tolerances named; a tolerance past the limits a ToleranceError."""

import functools
from dataclasses import replace

import numpy as np
import pytest

import flextop
from flextop import SettingsError, SpatialScene, SpatialSimulation, ToleranceError
from flextop.problems import SpatialProblem
from flextop.discretization.spatial import refined_spec, renamed
from flextop.scenes.spatial_catalogue import spatial_robot_arm
from test_spatial import flexible_pendulum


def bent_cantilever(split: int = 1) -> SpatialScene:
    """A 1 m aluminium tube clamped at its root, its end pushed sideways and down far into
    the nonlinear range (about a quarter of its length), a load at its middle too."""
    scene = SpatialScene("bent cantilever", analysis="static")
    scene.section("alu", E=7e10, rho=2700.0, nu=0.33, shape="tube", outer=0.02, inner=0.016)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (1.0, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="alu", split=2 * split)
    scene.weld("clamp", "root")
    scene.load("push", "end", force=(0.0, 150.0, -100.0))
    scene.load("middle", f"rod[{split}]", force=(0.0, 0.0, -100.0))
    return scene


def relative(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b))


def assert_honest(run, reference, rtol: float) -> None:
    """Each value within ``rtol`` of the reference and its gradient within ``5·rtol`` (the
    2-norm over parameters and densities), each estimate at least half the true error."""
    full = np.hstack([run.gradient, run.dfdx])
    truth = np.hstack([reference.gradient, reference.dfdx])
    for k, name in enumerate(run.responses):
        value_error = abs(run.values[k] - reference.values[k]) / abs(reference.values[k])
        gradient_error = relative(full[k], truth[k])
        assert value_error <= rtol and gradient_error <= 5 * rtol, (name, value_error, gradient_error, run.discretization)
        assert run.errors[name] >= value_error / 2 and run.gradient_errors[name] >= gradient_error / 2, \
            (name, run.errors[name], value_error, run.gradient_errors[name], gradient_error)


def test_an_equilibrium_to_a_tolerance_is_within_it():
    """The bent tube from two elements: refined until the end's and the middle's positions
    and their gradients to E and the density meet rtol 1e-3, against 64 elements. The middle
    node, ``rod[1]`` on the scene's two elements, is ``rod[r]`` on ``2r``."""
    rtol, responses, parameters = 1e-3, ["y:end", "z:end", "z:rod[1]"], ["E:rod"]
    sim = SpatialSimulation(bent_cantilever())
    x = np.array([0.6])
    run = sim.run_with_sensitivities(x, responses, parameters, rtol=rtol)
    assert run.responses == tuple(responses) and run.discretization.refinement > 1
    reference = SpatialSimulation(bent_cantilever(32)).run_with_sensitivities(
        x, ["y:end", "z:end", "z:rod[32]"], parameters)
    assert abs(reference.values[1]) > 0.1  # far into the nonlinear range
    assert_honest(run, reference, rtol)


@pytest.mark.parametrize("x", [[1.0, 1.0], [0.3, 0.5], [0.05, 0.02]], ids=["full", "light", "nearly void"])
def test_a_motion_to_a_tolerance_is_within_it(x):
    """The flexible pendulum's ∫U dt and the end's position at full, light and nearly void
    designs, rtol 1e-2, against 8× its elements on 32× its steps with the time error removed
    by Richardson's extrapolation. The full design needs more than the scene's grid."""
    rtol, responses, x = 1e-2, ["strain_energy", "z:end", "x:end"], np.array(x)
    sim = SpatialSimulation(flexible_pendulum(), rtol=rtol)
    run = sim.run_with_sensitivities(x, responses)
    assert run.discretization is not None and run.discretization.steps >= 20
    if x[0] == 1.0:
        assert run.discretization.refinement > 1 and run.discretization.steps > 20
    fine = SpatialSimulation(refined_spec(flexible_pendulum().to_dict(), 8))
    at = [fine.run_with_sensitivities(x, responses, h=0.005 / k) for k in (32, 16)]
    reference = replace(at[0], **{key: (4 * getattr(at[0], key) - getattr(at[1], key)) / 3
                                  for key in ("values", "gradient", "dfdx")})
    assert relative(at[0].values, reference.values) < 0.1 * rtol  # the reference's own error is small
    assert_honest(run, reference, rtol)


def test_a_motion_to_a_tolerance_extrapolates_in_the_step_where_that_is_the_more_accurate():
    """The heavy top's final position at rtol 1e-3 over half a second: its time error alone
    counts, and Richardson's extrapolation from half the steps passes where the grid's own
    values would need more steps; the values and the gradient to its mass are the
    extrapolation of the two runs on that grid, within rtol of 32× the steps (extrapolated),
    and without ``extrapolate`` the grid passes only with more steps."""
    top = SpatialSimulation(flextop.scenes.heavy_top())
    names, mass = ["x:top", "z:top"], ["mass:top"]
    out = top.run_with_sensitivities(None, names, mass, rtol=1e-3, t_end=0.5)
    d = out.discretization
    assert d.extrapolated and "extrapolated from half the steps" in str(d)
    fine, half = (top.run_with_sensitivities(None, names, mass, h=0.5 / n, t_end=0.5) for n in (d.steps, d.steps // 2))
    assert np.allclose(out.values, (4 * fine.values - half.values) / 3, rtol=1e-12, atol=0)
    assert np.allclose(out.gradient, (4 * fine.gradient - half.gradient) / 3, rtol=1e-12, atol=0)
    limit = [top.run_with_sensitivities(None, names, h=0.5 / n, t_end=0.5).values for n in (32 * d.steps, 16 * d.steps)]
    truth = (4 * limit[0] - limit[1]) / 3
    assert np.all(np.abs(out.values - truth) <= 1e-3 * np.abs(truth))
    plain = top.run_with_sensitivities(None, names, mass, rtol=1e-3, t_end=0.5, extrapolate=False).discretization
    assert not plain.extrapolated and plain.steps > d.steps


def test_the_scenes_grid_is_kept_where_no_tolerance_is_asked_for_or_h_is_given():
    sim = SpatialSimulation(flexible_pendulum(), rtol=1e-2)
    plain = SpatialSimulation(flexible_pendulum())
    fixed = sim.run_with_sensitivities(0.5, "strain_energy", h=0.005)
    assert fixed.discretization is None and fixed.values[0] == plain.run_with_sensitivities(0.5, "strain_energy").values[0]


def test_a_node_inside_a_beam_is_the_same_point_on_every_grid():
    scene = bent_cantilever().to_dict()
    assert renamed("rod[1]", 4, {"rod"}) == "rod[4]" and renamed("box[1,0,0]", 4, {"box/bar"}) == "box[1,0,0]"
    assert renamed("box/bar7[1]", 2, {"box/bar"}) == "box/bar7[2]" and renamed("other[1]", 2, {"rod"}) == "other[1]"
    refined = refined_spec(scene, 4)
    assert refined["beams"][0]["split"] == 8 and refined["loads"][1]["at"] == "rod[4]"
    coarse, fine = (SpatialSimulation(s).simulate(t_end=1e-3, h=1e-3) for s in (scene, refined))
    assert np.array_equal(coarse.position("rod[1]")[0], [0.5, 0.0, 0.0])
    assert np.allclose(fine.position("rod[4]")[0], [0.5, 0.0, 0.0], rtol=0, atol=1e-15)


@pytest.mark.parametrize("options, culprit", [
    ({"rtol": 0.0}, "rtol"),
    ({"rtol": 1.5}, "rtol"),
    ({"rtol": float("nan")}, "rtol"),
    ({"rtol": 1e-2, "atol": -1.0}, "atol"),
    ({"accuracy": "best"}, "accuracy"),
    ({"accuracy": "fast", "rtol": 1e-2}, "accuracy"),
])
def test_bad_tolerances_are_named(options, culprit):
    with pytest.raises(SettingsError, match=culprit):
        SpatialSimulation(flexible_pendulum(), **options)


def test_a_tolerance_and_a_step_together_are_refused():
    with pytest.raises(SettingsError, match="h .* or rtol"):
        SpatialSimulation(flexible_pendulum()).run_with_sensitivities(0.5, "strain_energy", rtol=1e-2, h=0.01)


def test_a_tolerance_past_the_limits_is_a_tolerance_error():
    """rtol 1e-6 on the bent tube needs more than 16× the scene's elements: a ToleranceError
    naming the response and the error reached, not a run without end."""
    with pytest.raises(ToleranceError, match="z:end"):
        SpatialSimulation(bent_cantilever()).run_with_sensitivities(0.6, "z:end", rtol=1e-6)


@pytest.mark.parametrize("tol", [1e-4, 1e-5])
def test_a_loose_newton_tolerance_leaves_the_rigid_trajectory_determined(tol):
    """The tip deflection's rigid companion runs at Newton's default tolerance whatever the
    run's: at a looser one (a run to a tolerance's companions stop at 1e-6) its two runs had
    moved apart by 7.4e-7 m on the robot arm, read as a freedom no drive holds."""
    sim = SpatialSimulation(spatial_robot_arm())
    loose, tight = (sim.run_with_sensitivities(1.0, "tip_deflection", tol=t).values[0] for t in (tol, 1e-10))
    assert loose == pytest.approx(tight, rel=10 * tol)


def test_a_simulation_held_to_a_tolerance_runs_its_refined_grids_without_it():
    """A static scene's simulation with its own rtol: its candidates run on grids of their
    own (no run to a tolerance within a run to a tolerance), the same as a call's rtol."""
    x = np.array([0.6])
    held = SpatialSimulation(bent_cantilever(), rtol=1e-3).run_with_sensitivities(x, "z:end")
    asked = SpatialSimulation(bent_cantilever()).run_with_sensitivities(x, "z:end", rtol=1e-3)
    assert held.discretization == asked.discretization and held.values[0] == asked.values[0]


def test_an_optimization_held_to_a_tolerance_meets_it_where_it_ends():
    """The flexible pendulum's ∫U dt under a volume bound of 0.8 by MMA at rtol 5e-3: accepted
    designs that moved by more than ``readapt`` are measured, the others run on the grid held,
    the grid only grows, and the design returned is measured as the run ends, its value
    within rtol of 8× its elements on 32× its steps. (Its status may be UNCONFIRMED: a KKT
    point of the grid held that the finer grid measured at the end moves.) At rtol 1e-2 the
    scene's own grid passes where the adjoint's time error agrees with the half steps
    (estimated 0.81 %, 0.60 % off): the contract has nothing to refine."""
    sim = SpatialSimulation(flexible_pendulum())
    problem = SpatialProblem(sim, "strain_energy", volume=0.8, rtol=5e-3, readapt=0.5)
    grids, on_held, measure = [], [], problem._run

    def counted(x, measured):
        (grids if measured else on_held).append(problem.held)
        return measure(x, measured)

    problem._run = counted
    result = flextop.optimize(problem, 0.8, method="mma", max_iter=30, kkt_tol=1e-4)
    assert result.status.name in ("KKT", "UNCONFIRMED") and result.kkt < 1e-2, result.message
    assert grids and on_held and None not in on_held and np.array_equal(problem.rule.at, result.x)
    held = [g for g in grids if g is not None] + [problem.held]
    assert all(b.refinement >= a.refinement and b.steps >= a.steps for a, b in zip(held, held[1:]))
    assert held[-1].refinement > 1  # the contract refined the scene's grid
    restored = SpatialProblem.from_dict(sim, problem.to_dict())  # a checkpoint keeps the grid held and the rule
    assert restored.held == problem.held and np.array_equal(restored.rule.at, problem.rule.at) and restored.rtol == 5e-3
    fine = SpatialSimulation(refined_spec(flexible_pendulum().to_dict(), 8))
    reference = fine.run_with_sensitivities(result.x, "strain_energy", h=0.005 / 32).values[0]
    assert abs(result.fun * problem.reference - reference) <= 5e-3 * reference


def clamped_bar(split: int = 1) -> SpatialScene:
    """A 1.2 m aluminium bar of a 20 × 8 mm rectangle, welded to the ground at both ends: its
    lowest mode bends it about its weaker axis."""
    scene = SpatialScene("clamped bar", gravity=(0.0, 0.0, 0.0))
    scene.section("flat", E=7e10, rho=2700.0, nu=0.33, shape="rectangle", width=0.02, height=0.008)
    scene.node("a", (0.0, 0.0, 0.0))
    scene.node("b", (1.2, 0.0, 0.0))
    scene.beam("bar", "a", "b", section="flat", split=split)
    scene.weld("left", "a")
    scene.weld("right", "b")
    return scene


@pytest.mark.parametrize("x", [1.0, 0.3])
def test_a_beams_own_frequency_is_its_lowest_mode_clamped_at_both_ends(x):
    """The indicator that grades beams: a beam's own lowest clamped–clamped frequency, over
    both bending planes the softer one's, against the lowest mode of the same beam welded at
    both ends in 32 elements, at full density and at 0.3 (SIMP's stiffness over Du–Olhoff's
    mass), within 0.1 %; its mass, ρAL times the mass law's factor."""
    own = SpatialSimulation(clamped_bar(1)).model
    lowest = SpatialSimulation(clamped_bar(32)).modes([x], at="rest", count=1).frequencies[0]
    assert own.beam_frequencies([x])[0] == pytest.approx(lowest, rel=1e-3)
    full_mass = 2700.0 * 0.02 * 0.008 * 1.2
    assert own.beam_masses()[0] == pytest.approx(full_mass, rel=1e-12)
    assert own.beam_masses([x])[0] < full_mass if x < 1 else own.beam_masses([x])[0] == pytest.approx(full_mass)


def test_the_beams_are_graded_by_their_need():
    """On the spatial robot arm at refinement 8 (``refine="bars"``, the default): the beams of
    the largest need ``M/f²`` get 8× their elements, each factor 8 of need below halves that,
    down to the floor; ``refine="uniform"`` refines every frame beam alike."""
    from flextop.discretization.spatial import EveryBeam, beam_factors

    sim = SpatialSimulation(spatial_robot_arm())
    x = np.random.default_rng(0).uniform(0.05, 1.0, sim.n_design)
    factors = beam_factors(sim, EveryBeam(8, 100, graded=True), list(x))
    need = np.array(sim.model.beam_masses(list(x))) / np.array(sim.model.beam_frequencies(list(x))) ** 2
    expected = np.maximum(1, 8 >> np.floor(np.log2(need.max() / need) / 3).astype(int))
    assert list(factors.values()) == list(expected) and len(set(expected)) > 2
    floored = beam_factors(sim, EveryBeam(8, 100, floor=4, uniform=2, graded=True), list(x))
    assert list(floored.values()) == list(2 * np.maximum(4, expected))
    uniform = SpatialSimulation(spatial_robot_arm(), refine="uniform")
    assert set(beam_factors(uniform, EveryBeam(8, 100), list(x)).values()) == {8}


def test_a_graded_scene_splits_each_beam_and_keeps_its_named_nodes():
    """The scene's ``splits`` table gives each beam its own elements; a node named inside a
    beam is renamed by that beam's own factor and stays the same point."""
    from flextop.discretization.spatial import graded_name, graded_spec

    scene = bent_cantilever().to_dict()
    assert graded_name("rod[1]", {"rod": 4}) == "rod[4]" and graded_name("box[1,0,0]", {"rod": 4}) == "box[1,0,0]"
    assert graded_name("other[1]", {"rod": 4}) == "other[1]"
    refined = graded_spec(scene, {"rod": 2}, {"rod": 4})
    assert refined["splits"] == {"rod": 8} and refined["loads"][1]["at"] == "rod[4]" and refined["beams"][0]["split"] == 2
    sim = SpatialSimulation(refined)
    assert len(dict(sim.model.beams)["rod"]) == 8
    assert np.allclose(sim.simulate(t_end=1e-3, h=1e-3).position("rod[4]")[0], [0.5, 0.0, 0.0], rtol=0, atol=1e-15)


@pytest.mark.parametrize("splits, culprit", [
    ({"nothing": 2}, "splits.nothing: no beam is called so"),
    ({"rod": 0}, "splits.rod: 0: between 1 and"),
])
def test_bad_splits_are_named(splits, culprit):
    scene = bent_cantilever().to_dict()
    with pytest.raises(flextop.SceneError, match=culprit):
        SpatialSimulation({**scene, "splits": splits})


def test_a_truss_bar_cannot_be_split():
    scene = SpatialScene("truss", analysis="static")
    scene.section("rod", E=2e11, rho=7800.0, nu=0.3, diameter=0.01)
    scene.node("a", (0.0, 0.0, 0.0))
    scene.node("b", (1.0, 0.0, 0.0))
    scene.beam("tie", "a", "b", section="rod", kind="truss")
    with pytest.raises(flextop.SceneError, match="splits.tie: a truss bar is one element"):
        SpatialSimulation({**scene.to_dict(), "splits": {"tie": 2}})


def test_a_refinement_spatial_scenes_lack_is_named():
    with pytest.raises(SettingsError, match="refine: 'every' is not one of uniform, bars, shares"):
        SpatialSimulation(flexible_pendulum(), refine="every")


def test_a_motion_to_a_tolerance_by_graded_beams_is_within_it():
    """The flexible pendulum with a light upper beam (x = 0.1: its own frequency a third of
    the solid one's), its beams graded (the default): the grid accepted splits the upper beam
    and leaves the lower one; rtol 1e-2 on ∫U dt and the end's position against 8× the
    elements on 32× the steps, extrapolated."""
    from flextop.discretization.spatial import beam_factors

    sim = SpatialSimulation(flexible_pendulum(), rtol=1e-2)
    run = sim.run_with_sensitivities(LIGHT_UPPER, PENDULUM_RESPONSES)
    d = run.discretization
    assert d.graded and not d.factors and beam_factors(sim, d, list(LIGHT_UPPER)) == {"lower": 1, "upper": 2}
    assert_honest(run, light_upper_reference(), 1e-2)


def test_a_motion_to_a_tolerance_by_measured_shares_is_within_it():
    """The same pendulum with ``refine="shares"``: the strain energy's space error is over
    half its budget on the scene's grid, the measured shares put it on the light upper beam,
    which alone doubles its elements; within rtol 1e-2 of the same reference."""
    from flextop.discretization.spatial import beam_factors

    sim = SpatialSimulation(flexible_pendulum(), rtol=1e-2, refine="shares")
    run = sim.run_with_sensitivities(LIGHT_UPPER, PENDULUM_RESPONSES)
    d = run.discretization
    assert d.factors == (1, 2) and beam_factors(sim, d, list(LIGHT_UPPER)) == {"lower": 1, "upper": 2}
    assert "the 1 of 2 beams that measured shares of the error refined" in str(d)
    assert_honest(run, light_upper_reference(), 1e-2)


LIGHT_UPPER = np.array([0.1, 1.0])
"""The flexible pendulum with a light upper beam."""

PENDULUM_RESPONSES = ["strain_energy", "z:end", "x:end"]


@functools.cache
def light_upper_reference():
    """The pendulum at :data:`LIGHT_UPPER` on 8× the elements on 32× the steps, extrapolated
    from 16×."""
    fine = SpatialSimulation(refined_spec(flexible_pendulum().to_dict(), 8))
    at = [fine.run_with_sensitivities(LIGHT_UPPER, PENDULUM_RESPONSES, h=0.005 / k) for k in (32, 16)]
    return replace(at[0], **{key: (4 * getattr(at[0], key) - getattr(at[1], key)) / 3
                             for key in ("values", "gradient", "dfdx")})


def test_beam_shares_add_up_to_the_change_of_splitting():
    """On the light-upper pendulum: the shares of the node positions and of the strain
    energy's mean (with its own reading of the split beams) add up to the change that
    splitting both beams makes within 1e-3 of it, and the light upper beam carries over 99 %
    of each."""
    sim = SpatialSimulation(flexible_pendulum())
    shares = sim.beam_shares(LIGHT_UPPER, PENDULUM_RESPONSES)
    assert shares.bars == ("lower", "upper")
    for name in PENDULUM_RESPONSES:
        share = shares.shares[name]
        assert abs(shares.unattributed[name]) <= 1e-3 * abs(shares.change[name]), (name, shares.change, share)
        assert abs(share[1]) >= 0.99 * np.abs(share).sum(), (name, share)


@pytest.mark.parametrize("scene, responses, culprit", [
    ("pendulum", ["volume"], "'volume' is explicit in the design"),
    ("pendulum", [], "give at least one response"),
    ("pendulum", ["z:nowhere"], "nowhere"),
    ("static", ["y:end"], "measured on a dynamic run"),
])
def test_bad_beam_shares_are_named(scene, responses, culprit):
    sim = SpatialSimulation(flexible_pendulum() if scene == "pendulum" else bent_cantilever())
    with pytest.raises(SettingsError, match=culprit):
        sim.beam_shares(None, responses)
