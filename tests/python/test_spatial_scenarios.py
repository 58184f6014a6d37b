"""Scenario problems and batches of spatial scenes: sums exact to round-off, the worst case
against finite differences, the same bits on every executor, held to a tolerance as a
single spatial problem is, checkpoints, failures named."""

import pickle
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from multiprocessing import get_context

import numpy as np
import pytest

import flextop
from conftest import assert_worst_case_differences
from flextop.discretization import spatial as spatial_tolerance
from flextop.problems import Scenario, ScenarioProblem, evaluate
from flextop.scenes.spatial_catalogue import spatial_robot_arm
from flextop.spatial import SpatialSimulation


def arm(**changes):
    """The spatial robot arm, short (three nodes along each link, 0.3 s): its physics, quickly."""
    return spatial_robot_arm(nx=3, t_end=0.3, **changes).to_dict()


def two_payloads():
    return [Scenario("light", arm(payload=0.5)), Scenario("heavy", arm(payload=3.0), 0.5)]


def design(n, seed=0):
    return np.random.default_rng(seed).uniform(0.3, 1.0, n)


def test_a_weighted_sum_of_spatial_scenarios_is_the_sum_of_their_runs():
    cases = two_payloads()
    sim = SpatialSimulation(cases[0].scene)
    volume = 0.5 * sim.volume(1.0)
    problem = ScenarioProblem(cases, "tip_deflection", [("volume", volume), ("strain_energy", 0.02), ("mass", 100.0)])
    x = design(problem.n)
    e = problem.evaluate(x)
    alone = [SpatialSimulation(c.scene).run_with_sensitivities(x, ["tip_deflection", "strain_energy"]) for c in cases]
    f = sum(c.weight * a.values[0] for c, a in zip(cases, alone))
    df = sum(c.weight * a.dfdx[0] for c, a in zip(cases, alone))
    assert alone[1].values[0] > 2.0 * alone[0].values[0]  # the payloads make two different motions
    assert abs(e.f0 * problem.objective_scale - f) <= 1e-14 * abs(f)
    assert np.max(np.abs(e.df0 * problem.objective_scale - df)) <= 1e-14 * np.max(np.abs(df))
    # the volume and the mass once, the strain energy once per scenario, named after it
    assert problem.names == ["volume", "light: strain_energy", "heavy: strain_energy", "mass"]
    assert (e.g[3] + 1.0) * 100.0 == pytest.approx(sim.mass(x), rel=1e-14)
    assert (e.g[0] + 1.0) * volume == pytest.approx(sim.volume(x), rel=1e-14)
    for k, a in enumerate(alone):
        assert abs((e.g[1 + k] + 1.0) * 0.02 - a.values[1]) <= 1e-14 * a.values[1]
        assert np.max(np.abs(e.dg[1 + k] * 0.02 - a.dfdx[1])) <= 1e-14 * np.max(np.abs(a.dfdx[1]))
    assert problem.timings["runs"] > 0.0


def test_the_worst_case_of_spatial_scenarios_passes_finite_differences():
    problem = ScenarioProblem(two_payloads(), "tip_deflection", aggregate="worst")
    x = problem.start(design(problem.n - 1, seed=3))
    base = problem.evaluate(x)
    assert base.f0 == 0.0 and base.g.shape == (2,) and np.max(base.g) == pytest.approx(0.0, abs=1e-15)
    assert_worst_case_differences(problem, x, base, 2)


def test_spatial_scenarios_share_one_design_and_one_dimension():
    with pytest.raises(flextop.SceneError, match=r"scenario 'b': its scene is planar, that of 'a' is not"):
        ScenarioProblem([Scenario("a", arm()), Scenario("b", flextop.scenes.robot_arm().to_dict())], "tip_deflection")
    with pytest.raises(flextop.SceneError, match=r"scenario 'b': its scene is spatial"):
        ScenarioProblem([Scenario("a", flextop.scenes.robot_arm().to_dict()), Scenario("b", arm())], "tip_deflection")
    with pytest.raises(flextop.SceneError, match=r"'b': its design variables \(or their x_min\) differ"):
        ScenarioProblem([Scenario("a", arm()), Scenario("b", spatial_robot_arm(nx=4, t_end=0.3).to_dict())],
                        "tip_deflection")
    with pytest.raises(flextop.SceneError, match="payload -1 must be a positive mass"):
        spatial_robot_arm(payload=-1)


def _same(a, b):
    return all(np.array_equal(p.values, q.values) and np.array_equal(p.dfdx, q.dfdx) for p, q in zip(a, b))


def test_spatial_scenarios_give_the_same_bits_on_every_executor_and_pickle_by_their_scenes():
    cases = two_payloads()
    sim = SpatialSimulation(cases[0].scene)
    designs = [design(sim.n_design, seed=s) for s in range(3)]
    names = ["tip_deflection", "reaction:lift"]
    serial = evaluate(cases, designs, names)
    flat = lambda runs: [r[c.name] for r in runs for c in cases]  # noqa: E731
    assert [type(r) for r in flat(serial)] == [flextop.spatial.SpatialSensitivities] * 6
    assert serial[2]["heavy"].values[0] == SpatialSimulation(cases[1].scene).run_with_sensitivities(designs[2], names).values[0]
    with ThreadPoolExecutor(2) as pool:
        assert _same(flat(serial), flat(evaluate(cases, designs, names, executor=pool)))
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        assert _same(flat(serial), flat(evaluate(cases, designs, names, executor=pool)))
    again = pickle.loads(pickle.dumps(sim))
    assert again.options == sim.options and again.spec == sim.spec
    assert np.array_equal(again.run_with_sensitivities(designs[0], names).values, flat(serial)[0].values)


def test_a_spatial_scenario_that_fails_is_named():
    cases = [Scenario("light", arm(payload=0.5)), Scenario("two tonnes", arm(payload=2000.0))]
    problem = ScenarioProblem(cases, "tip_deflection")
    with pytest.raises(flextop.optimizers.EvaluationError, match="scenario 'two tonnes': Newton did not converge"):
        problem.evaluate(np.full(problem.n, 0.5))
    assert ScenarioProblem(cases[:1], "tip_deflection").evaluate(np.full(problem.n, 0.5)).f0 == 1.0


def test_spatial_scenarios_held_to_a_tolerance_are_measured_only_where_an_accepted_design_moved():
    cases = two_payloads()
    problem = ScenarioProblem(cases, "tip_deflection", rtol=1e-2)
    x = design(problem.n_design)
    problem.accept(x, problem.evaluate(x))
    held = dict(problem.discretizations)
    assert problem.measured == [1] and all(isinstance(d, spatial_tolerance.EveryBeam) for d in held.values())
    far = np.clip(x - 0.2, problem.lower, problem.upper)
    trial = problem.evaluate(far)
    assert problem.measured == [1] and problem.discretizations == held

    def weighted(runs):
        return sum(s.weight * run.values[0] for s, run in zip(cases, runs))

    sims = [SpatialSimulation(s.scene) for s in cases]
    on_grids = [spatial_tolerance.on_grid(sim, held[s.name], list(far), ["tip_deflection"], [], False, {"method": "auto"})
                for s, sim in zip(cases, sims)]
    assert trial.f0 * problem.objective_scale == pytest.approx(weighted(on_grids), rel=1e-14)
    accepted = problem.accept(far, trial)
    assert problem.measured == [1, 3]
    measured = [sim.run_with_sensitivities(far, "tip_deflection", rtol=1e-2, start=held[s.name])
                for s, sim in zip(cases, sims)]
    assert accepted.f0 * problem.objective_scale == pytest.approx(weighted(measured), rel=1e-14)
    assert all(m.errors["tip_deflection"] <= 1e-2 for m in measured)
    again = ScenarioProblem.from_dict(problem.to_dict())
    assert again.discretizations == problem.discretizations
    assert [str(d) for d in again.discretizations.values()] == [str(d) for d in problem.discretizations.values()]
    assert again.evaluate(far).f0 == problem.evaluate(far).f0


def test_the_command_line_optimizes_spatial_scenarios_on_workers_and_resumes(tmp_path):
    for name, payload in [("light", 0.5), ("heavy", 3.0)]:
        (tmp_path / f"{name}.toml").write_text(spatial_robot_arm(nx=3, t_end=0.3, payload=payload).to_toml())
    (tmp_path / "cases.toml").write_text('aggregate = "worst"\n[[scenario]]\nname = "light"\nscene = "light.toml"\n'
                                         '[[scenario]]\nname = "heavy"\nscene = "heavy.toml"\n')
    cli = lambda *args: subprocess.run([sys.executable, "-m", "flextop.cli", "optimize", *map(str, args)],  # noqa: E731
                                       capture_output=True, text=True, timeout=600)
    straight = cli("--scenarios", tmp_path / "cases.toml", "--max-iter", 3, "--workers", 2, "--out", tmp_path / "a", "--vtk")
    assert straight.returncode == 3, straight.stderr  # stopped at --max-iter: not converged
    assert "2 scenarios of spatial_robot_arm" in straight.stdout and "heavy: tip_deflection = " in straight.stdout
    assert "volume:link1 <=" in straight.stdout and "motions with their adjoint sweeps" in straight.stdout
    for written in ("design.png", "history.png", "motion.pvd", "design.npy", "checkpoint.json"):
        assert (tmp_path / "a" / written).exists(), written
    half = cli("--scenarios", tmp_path / "cases.toml", "--max-iter", 2, "--out", tmp_path / "b", "--no-plots")
    assert half.returncode == 3, half.stderr
    rest = cli("--resume", "--max-iter", 3, "--workers", 2, "--out", tmp_path / "b", "--no-plots")
    assert rest.returncode == 3, rest.stderr
    assert np.array_equal(np.load(tmp_path / "a" / "design.npy"), np.load(tmp_path / "b" / "design.npy"))
    mixed = tmp_path / "mixed.toml"
    mixed.write_text('[[scenario]]\nname = "light"\nscene = "light.toml"\n[[scenario]]\nname = "planar"\nscene = "robot_arm"\n')
    refused = cli("--scenarios", mixed, "--out", tmp_path / "c")
    assert refused.returncode == 2 and "its scene is planar" in refused.stderr and refused.stderr.count("\n") == 1
    alone = cli(tmp_path / "light.toml", "--workers", 2, "--out", tmp_path / "d")
    assert alone.returncode == 2 and "--workers: for several scenarios" in alone.stderr


def test_a_scenario_takes_a_spatial_scene_its_dict_or_its_file(tmp_path):
    scene = spatial_robot_arm(nx=3, t_end=0.3)
    (tmp_path / "arm.toml").write_text(scene.to_toml())
    specs = [Scenario(name, given).spec() for name, given in (("a", scene), ("b", scene.to_dict()), ("c", tmp_path / "arm.toml"))]
    assert specs[0] == specs[1]
    x = design(SpatialSimulation(specs[0]).n_design)
    assert len({SpatialSimulation(s).run_with_sensitivities(x, "tip_deflection").values[0] for s in specs}) == 1
    with pytest.raises(flextop.SceneError, match="scenario 'd': its scene is a int"):
        Scenario("d", 3).spec()


def test_bad_input_to_spatial_runs_scenarios_and_sizing_is_named():
    """What a fuzz campaign and a review found leaking: each refused by a FlextopError
    naming it."""
    from flextop.problems import SizingProblem, SpatialProblem
    from flextop.scenes.spatial_catalogue import heavy_top

    sim = SpatialSimulation(arm())
    away = flextop.SpatialScene("slide", gravity=(0.0, 0.0, -9.81))  # a drive's table ending at 1e300 m/s
    away.rigid_body("b", mass=0.5, inertia=(1e-3, 1e-3, 1e-3), position=(1.0, 0.0, 0.0))
    away.prismatic("pr", (1.0, 0.0, 0.0), "b", axis=(1.0, 0.0, 0.0),
                   drive={"kind": "table", "t": [0.0, 0.02, 0.04], "theta": [0.0, 0.01, 0.0], "end_velocity": 1e300})
    away.simulation(t_end=0.04, h=2e-3)
    for call, error, message in [
        (lambda: SpatialSimulation(away).simulate(), flextop.SimulationError, "states or energies are not finite"),
        (lambda: sim.volume(float("nan")), flextop.DesignError, r"x\[0\] \(link1/bar0\) = nan is outside"),
        (lambda: sim.run_with_sensitivities(5.0, ["volume"]), flextop.DesignError, "= 5.0 is outside"),
        (lambda: sim.run_with_sensitivities(None, 5), flextop.SettingsError, "responses: names as text, got 5"),
        (lambda: sim.run_with_sensitivities(rtol=0.3, t_end=float("nan")), flextop.SettingsError, "t_end must be a finite"),
        (lambda: sim.run_with_sensitivities(rtol=0.3, start=5), flextop.SettingsError, "start: give a discretization"),
        (lambda: sim.run_with_sensitivities(atol=float("nan")), flextop.SettingsError, "atol must be a finite number"),
        (lambda: SpatialSimulation(heavy_top(), atol=-1), flextop.SettingsError, "atol must be ≥ 0"),
        (lambda: SpatialSimulation(heavy_top(t_end=0.05)).modes(count=2, at=5), flextop.SettingsError, "at: give an equilibrium"),
        (lambda: SizingProblem(arm(), "tip_deflection", sizes={"alu.outer": 0.012}), flextop.SettingsError,
         "'alu.outer': bounds as \\(lower, upper\\)"),
        (lambda: SizingProblem(arm(), "tip_deflection", [("mass",)], sizes={"alu.outer": (0.01, 0.02)}),
         flextop.SettingsError, r"constraint \('mass',\): give \(response, bound\)"),
        (lambda: SizingProblem(arm(), 5, sizes={"alu.outer": (0.01, 0.02)}), flextop.SettingsError, "objective: a response's"),
        (lambda: SizingProblem(arm(), "tip_deflection", sizes={"alu.outer": (0.01, 0.02)}, reference="a"),
         flextop.SettingsError, "reference must be a finite number"),
        (lambda: SizingProblem(arm(), "mass", sizes={"alu.outer": (0.01, 0.02)}).evaluate([[0.012]]), flextop.DesignError,
         r"the design has shape \(1, 1\)"),
        (lambda: SizingProblem(arm(), "mass", sizes={"alu.outer": (0.01, 0.02)}, atol=-5), flextop.SettingsError,
         "atol must be ≥ 0"),
        (lambda: SpatialProblem(sim, "tip_deflection", atol=float("nan")), flextop.SettingsError, "atol must be a finite"),
        (lambda: SizingProblem(arm(), "mass", [("volume", True)], sizes={"alu.outer": (0.01, 0.02)}), flextop.SettingsError,
         "constraint 'volume': the bound must be a finite number, got True"),
        (lambda: ScenarioProblem([5], "tip_deflection"), flextop.SceneError, "scenarios: give Scenario"),
        (lambda: ScenarioProblem(5, "tip_deflection"), flextop.SceneError, "scenarios: give a list, got 5"),
        (lambda: ScenarioProblem(two_payloads(), "tip_deflection", [5]), flextop.SettingsError, "constraint 5: give"),
        (lambda: ScenarioProblem(two_payloads(), "tip_deflection", objective_scale=0.0), flextop.SettingsError,
         "objective_scale must be > 0"),
        (lambda: ScenarioProblem(two_payloads(), "tip_deflection", settings=5), flextop.SettingsError, "settings: give"),
        (lambda: evaluate(two_payloads(), 5, "tip_deflection"), flextop.DesignError, "designs: give a list, got 5"),
        (lambda: evaluate(two_payloads(), [0.5], 5), flextop.SettingsError, "responses: give a list, got 5"),
    ]:
        with pytest.raises(error, match=message):
            call()
