"""Scenario problems and batches on any executor: sums exact to round-off, the worst case
against finite differences, resume, the same bits on every executor, failures named."""

import os
import subprocess
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from multiprocessing import get_context

import numpy as np
import pytest

import flextop
from flextop import execution, scenes
from flextop.discretization.refinement import HELD_NEWTON_TOL
from flextop.errors import ExecutionError, FlextopError, SimulationError
from flextop.optimizers import EvaluationError
from conftest import assert_worst_case_differences, on_accepted_grid
from flextop.problems import Scenario, ScenarioProblem, evaluate, robust_robot_arm

ARM_T_END = 0.4  # a shorter motion keeps the tests quick; the physics is the arm's


def arm(**changes):
    spec = scenes.robot_arm(**changes).to_dict()
    spec["simulation"]["t_end"] = ARM_T_END
    return spec


def two_scenarios():
    return [Scenario("reference", arm()), Scenario("light and fast", arm(tip_mass=2.5, speed=1.0, acceleration=8.0), 2.0)]


def design(n, seed=0):
    return np.random.default_rng(seed).uniform(0.2, 1.0, n)


def volumes(scenario):
    return flextop.volume_constraints(flextop.Simulation(scenario.scene), 0.4)


def test_a_weighted_sum_of_two_scenarios_is_the_sum_of_their_runs():
    cases = two_scenarios()
    problem = ScenarioProblem(cases, "tip_deflection", volumes(cases[0]) + [("compliance", 50.0)])
    x = design(problem.n)
    e = problem.evaluate(x)
    alone = [flextop.Simulation(c.scene).run_with_sensitivities(x, ["tip_deflection", "compliance"]) for c in cases]
    f = sum(c.weight * a.values[0] for c, a in zip(cases, alone))
    df = sum(c.weight * a.gradients[0] for c, a in zip(cases, alone))
    assert abs(e.f0 * problem.objective_scale - f) <= 1e-14 * abs(f)
    assert np.max(np.abs(e.df0 * problem.objective_scale - df)) <= 1e-14 * np.max(np.abs(df))
    # volumes once, compliance once per scenario, named after it
    assert problem.names == ["volume:link1", "volume:link2", "reference: compliance", "light and fast: compliance"]
    for k, a in enumerate(alone):
        assert abs((e.g[2 + k] + 1.0) * 50.0 - a.values[1]) <= 1e-14 * a.values[1]
        assert np.max(np.abs(e.dg[2 + k] * 50.0 - a.gradients[1])) <= 1e-14 * np.max(np.abs(a.gradients[1]))


def test_the_worst_case_gradient_passes_finite_differences():
    cases = two_scenarios()
    problem = ScenarioProblem(cases, "tip_deflection", volumes(cases[0]), aggregate="worst")
    x = problem.start(design(problem.n - 1, seed=3))
    base = problem.evaluate(x)
    assert base.f0 == 0.0 and base.g.shape == (4,) and np.max(base.g[:2]) == pytest.approx(0.0, abs=1e-15)
    assert_worst_case_differences(problem, x, base, 3)


def test_scenarios_must_share_the_design_and_have_distinct_names():
    with pytest.raises(flextop.SceneError, match=r"design variables \(or their x_min\) differ"):
        ScenarioProblem([Scenario("a", arm()), Scenario("b", arm(nx=4))], "tip_deflection")
    with pytest.raises(flextop.SceneError, match="x_min"):
        ScenarioProblem([Scenario("a", arm()), Scenario("b", arm(x_min=0.05))], "tip_deflection")
    with pytest.raises(flextop.SettingsError, match="aggregate must be one of sum, worst"):
        ScenarioProblem(two_scenarios(), "tip_deflection", aggregate="max")
    with pytest.raises(flextop.SettingsError, match="give \\(response, bound\\)"):
        ScenarioProblem(two_scenarios(), "tip_deflection", [("compliance",)])
    with pytest.raises(flextop.SceneError, match="weight"):
        ScenarioProblem([Scenario("a", arm(), True)], "tip_deflection")
    worst = ScenarioProblem(two_scenarios(), "tip_deflection", aggregate="worst")
    with pytest.raises(flextop.DesignError, match="use start"):
        worst.evaluate(np.full(worst.n - 1, 0.4))
    assert worst.start(0.4).shape == (worst.n,) and worst.start(0.4)[-1] == 0.0
    with pytest.raises(flextop.SceneError, match="names must differ"):
        ScenarioProblem([Scenario("a", arm()), Scenario("a", arm())], "tip_deflection")
    with pytest.raises(flextop.SettingsError, match="'stress:p=16': stress and buckling limits are normalized"):
        ScenarioProblem(two_scenarios(), "tip_deflection", [("a", "stress:p=16", 1e8)])
    with pytest.raises(flextop.SceneError, match="no scenario named 'c'"):
        ScenarioProblem(two_scenarios(), "tip_deflection", [("c", "compliance", 1.0)])
    with pytest.raises(flextop.SceneError, match="weight"):
        ScenarioProblem([Scenario("a", arm(), -1.0)], "tip_deflection")


def _same(a, b):
    return all(np.array_equal(p.values, q.values) and np.array_equal(p.gradients, q.gradients) for p, q in zip(a, b))


def test_every_executor_gives_the_same_bits():
    cases = two_scenarios()
    designs = [design(flextop.Simulation(cases[0].scene).n_design, seed=s) for s in range(3)]
    serial = evaluate(cases, designs, ["tip_deflection", "compliance"])
    flat = lambda runs: [r[c.name] for r in runs for c in cases]  # noqa: E731
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        assert _same(flat(serial), flat(evaluate(cases, designs, ["tip_deflection", "compliance"], executor=pool)))
    with ThreadPoolExecutor(2) as pool:
        assert _same(flat(serial), flat(evaluate(cases, designs, ["tip_deflection", "compliance"], executor=pool)))
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        assert _same(flat(serial), flat(evaluate(cases, designs, ["tip_deflection", "compliance"], executor=client.get_executor())))
        assert _same(flat(serial), flat(evaluate(cases, designs, ["tip_deflection", "compliance"], executor=client)))  # its executor
        # A whole optimization sent to the cluster (the problem pickled by its scene): the same bits.
        problem = flextop.TopologyProblem(flextop.Simulation(arm()), "tip_deflection",
                                          flextop.volume_constraints(flextop.Simulation(arm()), 0.4))
        x0 = np.full(problem.n, 0.4)
        there = client.submit(flextop.optimize, problem, x0, "mma", max_iter=2).result()
        here = flextop.optimize(problem, x0, "mma", max_iter=2)
        assert np.array_equal(there.x, here.x) and there.fun == here.fun
    with pytest.raises(ExecutionError, match="the Dask client is closed"):
        evaluate(cases, designs, "tip_deflection", executor=client)


def test_executors_that_cannot_work_are_refused_before_any_task_is_sent():
    cases = two_scenarios()
    x = design(flextop.Simulation(cases[0].scene).n_design)
    with ProcessPoolExecutor(1, mp_context=get_context("fork")) as forking:
        with pytest.raises(flextop.SettingsError, match="spawn"):
            evaluate(cases, [x], "tip_deflection", executor=forking)
        assert not forking._processes, "no worker was started"
    with pytest.raises(flextop.SettingsError, match="expected a concurrent.futures.Executor"):
        evaluate(cases, [x], "tip_deflection", executor=object())


def test_problems_and_simulations_pickle_by_their_scenes_and_optimize_in_another_process():
    """``pool.submit(flextop.optimize, problem, x0)``: the same optimum as here, bit for bit."""
    import pickle
    sim = flextop.Simulation(arm(), rtol=1e-2, refine="uniform")
    again = pickle.loads(pickle.dumps(sim))
    assert again.spec == sim.spec and again.options == sim.options and again.n_design == sim.n_design
    problem = flextop.TopologyProblem(flextop.Simulation(arm()), "tip_deflection", flextop.volume_constraints(flextop.Simulation(arm()), 0.4))
    x0 = np.full(problem.n, 0.4)
    here = flextop.optimize(problem, x0, "mma", max_iter=2)
    scenarios = ScenarioProblem(two_scenarios(), "tip_deflection", executor=ThreadPoolExecutor(1))
    copied = pickle.loads(pickle.dumps(scenarios))
    assert copied.executor is None
    xs = np.full(scenarios.n, 0.4)
    assert np.array_equal(copied.evaluate(xs).df0, scenarios.evaluate(xs).df0)
    scenarios.executor.shutdown()
    with ProcessPoolExecutor(1, mp_context=get_context("spawn")) as pool:
        there = pool.submit(flextop.optimize, flextop.TopologyProblem(flextop.Simulation(arm()), "tip_deflection",
                                                                      flextop.volume_constraints(flextop.Simulation(arm()), 0.4)),
                            x0, "mma", max_iter=2).result()
    assert np.array_equal(there.x, here.x) and there.fun == here.fun


def test_a_batch_keeps_the_order_of_its_designs():
    sim = flextop.Simulation(arm())
    designs = [np.full(sim.n_design, v) for v in (0.9, 0.3, 0.6)]
    runs = sim.map(designs)
    for x, run in zip(designs, runs):
        assert np.array_equal(run.values, sim.run_with_sensitivities(x).values)
    values = sim.map(designs, gradients=False)
    assert np.allclose([v.values[0] for v in values], [r.values[0] for r in runs], rtol=1e-13, atol=0)
    assert values[0].gradients is None
    with pytest.raises(flextop.DesignError, match="design 1"):
        sim.map([designs[0], np.full(3, 0.5)])


def test_a_task_that_fails_in_a_worker_names_its_scenario():
    failing = arm()
    failing["simulation"]["max_iter"] = 1
    cases = [Scenario("reference", arm()), Scenario("stiff servo", failing)]
    x = design(flextop.Simulation(arm()).n_design)
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        with pytest.raises(SimulationError, match="scenario 'stiff servo', design 0: .*Newton"):
            evaluate(cases, [x], "tip_deflection", executor=pool)
        problem = ScenarioProblem(cases, "tip_deflection", executor=pool)
        with pytest.raises(EvaluationError, match="scenario 'stiff servo'") as failed:  # the optimizer steps back from it
            problem.evaluate(x)
        assert isinstance(failed.value, flextop.FlextopError)


def test_a_worker_that_dies_is_an_execution_error_naming_the_task():
    with ProcessPoolExecutor(1, mp_context=get_context("spawn")) as pool:
        with pytest.raises(ExecutionError, match="scenario 'payload 5 kg': the task did not complete"):
            execution.run_all(os._exit, [("scenario 'payload 5 kg'", 3)], pool)
    assert issubclass(ExecutionError, FlextopError)
    with pytest.raises(ExecutionError, match="design 0: the executor does not take tasks"):
        execution.run_all(abs, [("design 0", -1)], pool)  # shut down
    with ThreadPoolExecutor(1) as threads:  # a task's own error is raised as it would be here
        with pytest.raises(ZeroDivisionError):
            execution.run_all(lambda v: 1 / v, [("design 0", 0)], threads)


def test_resume_reproduces_an_uninterrupted_multi_scenario_run():
    cases = two_scenarios()
    make = lambda: ScenarioProblem(cases, "tip_deflection", volumes(cases[0]), aggregate="worst")  # noqa: E731
    problem = make()
    x0 = problem.start(np.full(problem.n - 1, 0.4))
    straight = flextop.optimize(problem, x0, "mma", max_iter=4)
    first = make()
    states = []
    flextop.optimize(first, x0, "mma", max_iter=2, callback=lambda record: states.append(record.state))
    again = ScenarioProblem.from_dict(first.to_dict())
    resumed = flextop.optimize(again, x0, "mma", max_iter=4, state=states[-1])
    assert np.array_equal(resumed.x, straight.x) and resumed.fun == straight.fun
    # in the responses' units: the worst d, each scenario's d, the volumes
    each = [flextop.Simulation(c.scene).run_with_sensitivities(straight.x[:-1], ["tip_deflection"]) for c in cases]
    worst = max(c.weight * e.values[0] for c, e in zip(cases, each))
    assert straight.fun == pytest.approx(worst, rel=1e-9)
    assert np.allclose(straight.constr[:2], [c.weight * e.values[0] for c, e in zip(cases, each)], rtol=1e-9)
    top = int(np.argmax([c.weight * e.values[0] for c, e in zip(cases, each)]))
    assert np.allclose(straight.jac[:-1], cases[top].weight * each[top].gradients[0], rtol=1e-7, atol=1e-12)


def test_the_robust_arm_has_nine_scenarios_of_one_design():
    cases = robust_robot_arm()
    assert len(cases) == 9 and len({c.name for c in cases}) == 9
    assert "twice as fast, 2.5 kg" in {c.name for c in cases}
    assert all("point_masses" not in c.scene.to_dict() for c in cases if c.name.endswith(" 0 kg"))


def test_the_command_line_optimizes_scenarios_on_workers_and_resumes(tmp_path):
    for name, changes in [("slow", {}), ("fast", {"speed": 1.0, "acceleration": 8.0})]:
        (tmp_path / f"{name}.toml").write_text(flextop.Scene.from_dict(arm(**changes)).to_toml())
    (tmp_path / "cases.toml").write_text('aggregate = "worst"\n[[scenario]]\nname = "slow"\nscene = "slow.toml"\n'
                                         '[[scenario]]\nname = "fast"\nscene = "fast.toml"\nweight = 1.0\n')
    cli = lambda *args: subprocess.run([sys.executable, "-m", "flextop.cli", "optimize", *map(str, args)],  # noqa: E731
                                       capture_output=True, text=True, timeout=600)
    straight = cli("--scenarios", tmp_path / "cases.toml", "--max-iter", 3, "--workers", 2, "--out", tmp_path / "a", "--no-plots")
    assert straight.returncode == 3, straight.stderr  # stopped at --max-iter: not converged
    assert "2 scenarios" in straight.stdout and "slow: tip_deflection = " in straight.stdout
    half = cli("--scenarios", tmp_path / "cases.toml", "--max-iter", 2, "--out", tmp_path / "b", "--no-plots")
    assert half.returncode == 3, half.stderr
    rest = cli("--resume", "--max-iter", 3, "--workers", 2, "--out", tmp_path / "b", "--no-plots")
    assert rest.returncode == 3, rest.stderr
    assert np.array_equal(np.load(tmp_path / "a" / "design.npy"), np.load(tmp_path / "b" / "design.npy"))
    wrong = cli("--resume", "--scenarios", tmp_path / "cases.toml", "--out", tmp_path / "b")
    assert wrong.returncode == 2 and "give neither" in wrong.stderr
    np.save(tmp_path / "short.npy", np.full(3, 0.5))
    short = cli("--scenarios", tmp_path / "cases.toml", "--start", tmp_path / "short.npy", "--out", tmp_path / "c")
    assert short.returncode == 2 and "--start" in short.stderr and short.stderr.count("\n") == 1
    unknown = cli("--scenarios", "robust_arm", "--out", tmp_path / "d")
    assert unknown.returncode == 2 and "robust_robot_arm" in unknown.stderr


def test_scenarios_held_to_a_tolerance_are_measured_only_where_an_accepted_design_moved():
    cases = two_scenarios()
    problem = ScenarioProblem(cases, "tip_deflection", rtol=1e-2)
    x = design(problem.n_design)
    problem.accept(x, problem.evaluate(x))
    held = dict(problem.discretizations)
    far = np.clip(x - 0.2, problem.lower, problem.upper)
    trial = problem.evaluate(far)
    assert problem.measured == [1] and problem.discretizations == held

    def weighted(runs):
        return sum(s.weight * run.values[0] for s, run in zip(cases, runs))

    on_grids = [on_accepted_grid(flextop.Simulation(s.scene), held[s.name], x, "tip_deflection", ARM_T_END, design=far,
                                 newton="modified", tol=HELD_NEWTON_TOL) for s in cases]
    assert trial.f0 * problem.objective_scale == pytest.approx(weighted(on_grids), rel=1e-14)
    accepted = problem.accept(far, trial)
    assert problem.measured == [1, 3]
    measured = [flextop.Simulation(s.scene).run_with_sensitivities(far, "tip_deflection", rtol=1e-2, start=held[s.name],
                                                                   hold_gradients=False) for s in cases]
    assert accepted.f0 * problem.objective_scale == pytest.approx(weighted(measured), rel=1e-14)
    again = ScenarioProblem.from_dict(problem.to_dict())
    np.testing.assert_array_equal(again.rule.at, far)
    assert again.rule.accepts and again.discretizations == problem.discretizations
    # A run ends: the design it returns is measured unless it was the one measured last.
    assert problem.conclude(far, accepted) is accepted and problem.measured == [1, 3]
    near = np.clip(far + 0.05, problem.lower, problem.upper)
    held = dict(problem.discretizations)
    concluded = problem.conclude(near, problem.evaluate(near))
    assert problem.measured == [1, 3, 5]
    measured = [flextop.Simulation(s.scene).run_with_sensitivities(near, "tip_deflection", rtol=1e-2, start=held[s.name],
                                                                   hold_gradients=False) for s in cases]
    assert concluded.f0 * problem.objective_scale == pytest.approx(weighted(measured), rel=1e-14)


def test_side_by_side_runs_beside_on_another_thread_and_raises_either_failure(monkeypatch):
    threads = []

    def mark(value):
        threads.append(threading.get_ident())
        return value

    monkeypatch.setattr(execution, "_cores", lambda: 2)
    assert execution.side_by_side(lambda: mark(1), lambda: mark(2)) == (1, 2)
    assert len(set(threads)) == 2
    monkeypatch.setattr(execution, "_cores", lambda: 1)
    threads.clear()
    assert execution.side_by_side(lambda: mark(1), lambda: mark(2)) == (1, 2)
    assert len(set(threads)) == 1
    monkeypatch.undo()

    def fails():
        raise SimulationError("Newton diverged")

    with pytest.raises(SimulationError, match="diverged"):
        execution.side_by_side(fails, lambda: 2)
    with pytest.raises(SimulationError, match="diverged"):
        execution.side_by_side(lambda: 1, fails)


def test_ctrl_c_in_this_thread_stops_the_run_beside(monkeypatch):
    monkeypatch.setattr(execution, "_cores", lambda: 2)
    sim = flextop.Simulation(arm())
    stopped = []

    def long_run():  # a thousand times the scene's steps: seconds, if Ctrl-C does not stop it
        try:
            return sim.run(np.full(sim.n_design, 0.4), h=ARM_T_END / 20_000)
        except KeyboardInterrupt:
            stopped.append(True)
            raise

    def interrupted():
        time.sleep(0.5)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        execution.side_by_side(interrupted, long_run)
    assert stopped == [True]


def test_an_extrapolated_run_to_a_tolerance_is_the_same_bits_side_by_side_or_in_turn(monkeypatch):
    monkeypatch.setattr(execution, "_cores", lambda: 2)
    sim = flextop.Simulation(scenes.spun_beam())
    x = np.full(sim.n_design, 0.4)
    beside = sim.run_with_sensitivities(x, "tip_deflection", rtol=1e-2, hold_gradients=False)
    assert beside.discretization.extrapolated
    monkeypatch.setattr(execution, "_cores", lambda: 1)
    in_turn = flextop.Simulation(scenes.spun_beam()).run_with_sensitivities(x, "tip_deflection", rtol=1e-2, hold_gradients=False)
    assert np.array_equal(beside.values, in_turn.values) and np.array_equal(beside.gradients, in_turn.gradients)


MPI_STUDY = """
import numpy as np
from mpi4py.futures import MPIPoolExecutor
from flextop.problems import evaluate, robust_robot_arm
if __name__ == "__main__":
    cases = robust_robot_arm()[:4]
    designs = [np.full(148, v) for v in (0.3, 0.6)]
    serial = evaluate(cases, designs, "tip_deflection")
    with MPIPoolExecutor() as pool:
        mpi = evaluate(cases, designs, "tip_deflection", executor=pool)
    print(all(np.array_equal(a[c.name].values, b[c.name].values) and np.array_equal(a[c.name].gradients, b[c.name].gradients)
              for a, b in zip(serial, mpi) for c in cases))
"""


def test_mpi_gives_the_same_bits(tmp_path):
    """Skipped without an MPI runtime (``pip install mpich mpi4py`` gives one)."""
    import shutil

    pytest.importorskip("mpi4py")
    if shutil.which("mpiexec") is None:
        pytest.skip("no mpiexec")
    (tmp_path / "study.py").write_text(MPI_STUDY)
    run = subprocess.run(["mpiexec", "-n", "3", sys.executable, "-m", "mpi4py.futures", str(tmp_path / "study.py")],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and run.stdout.strip().splitlines()[-1] == "True", run.stdout + run.stderr
