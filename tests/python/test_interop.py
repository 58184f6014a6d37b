"""Adapters: scipy.optimize.minimize and OpenMDAO reach the optimum flextop's own MMA finds,
with gradients that pass their tools' checks, one simulation per design."""

import numpy as np
import pytest
from scipy.optimize import approx_fprime, minimize

import flextop
from flextop.interop.scipy import arguments


def convex_truss():
    """The paper's static truss with p = 1: compliance under a volume bound is convex."""
    return flextop.static_truss_problem(p=1.0)


@pytest.fixture(scope="module")
def mma_optimum():
    problem = convex_truss()
    result = flextop.optimize(problem, np.full(problem.n, 0.4), "mma", max_iter=300, kkt_tol=1e-8, xtol=1e-9)
    return problem.objective_scale, result.fun


def test_scipy_gradients_pass_its_check():
    problem = convex_truss()
    args = arguments(problem)
    x = np.random.default_rng(2).uniform(0.2, 0.9, problem.n)
    fd = approx_fprime(x, args["fun"], 1e-7)
    assert np.linalg.norm(fd - args["jac"](x)) <= 1e-5 * np.linalg.norm(args["jac"](x))
    (constraint,) = args["constraints"]
    fd_g = approx_fprime(x, lambda z: constraint.fun(z)[0], 1e-7)
    assert np.allclose(fd_g, constraint.jac(x)[0], rtol=1e-6, atol=1e-9)


def test_scipy_slsqp_reaches_the_optimum_with_one_evaluation_per_design(mma_optimum):
    scale, f_star = mma_optimum
    problem = convex_truss()
    problem.objective_scale = scale
    args = arguments(problem)
    result = minimize(x0=np.full(problem.n, 0.4), method="SLSQP", options={"ftol": 1e-12, "maxiter": 500}, **args)
    assert result.success, result.message
    assert result.fun * scale == pytest.approx(f_star, rel=1e-4)
    assert args["fun"].evaluations.calls <= result.nfev + result.njev  # fun, jac and g shared their runs


def test_the_scipy_result_holds_the_objective_in_its_own_units(mma_optimum):
    """The adapter's fun was f/f_ref; an OptimizeResult's users expect the objective's value."""
    from flextop.interop.scipy import minimize as flextop_minimize

    scale, f_star = mma_optimum
    problem = convex_truss()
    problem.objective_scale = scale
    result = flextop_minimize(problem, np.full(problem.n, 0.4), "SLSQP", options={"ftol": 1e-12, "maxiter": 500})
    assert result.success, result.message
    assert result.fun == pytest.approx(f_star, rel=1e-4) and result.fun == result.fun_scaled * scale
    assert np.allclose(result.jac, result.jac_scaled * scale, rtol=1e-10, atol=0)
    f, constrained, _ = problem.physical(problem.evaluate(result.x))
    assert result.fun == f and np.array_equal(result.constrained, constrained)


def test_openmdao_component_passes_check_partials_and_optimizes(mma_optimum):
    om = pytest.importorskip("openmdao.api")
    from flextop.interop.openmdao import ProblemComponent

    scale, f_star = mma_optimum
    problem = convex_truss()
    problem.objective_scale = scale
    prob = om.Problem(reports=False)
    prob.model.add_subsystem("truss", ProblemComponent(problem=problem), promotes=["*"])
    prob.model.add_design_var("x", lower=problem.lower, upper=problem.upper)
    prob.model.add_objective("f")
    prob.model.add_constraint("g", upper=0.0)
    prob.driver = om.ScipyOptimizeDriver(optimizer="SLSQP", tol=1e-12, maxiter=500, disp=False)
    prob.setup()
    prob.set_val("x", np.random.default_rng(3).uniform(0.2, 0.9, problem.n))
    prob.run_model()
    data = prob.check_partials(out_stream=None, method="fd", step=1e-7, form="central")
    for pair, errors in data["truss"].items():  # in the 2-norm: entrywise, near-zero entries measure the FD's noise
        exact, fd = errors["J_fwd"], errors["J_fd"]
        assert np.linalg.norm(exact - fd) <= 1e-5 * np.linalg.norm(fd), pair
    prob.set_val("x", np.full(problem.n, 0.4))
    prob.run_driver()
    assert prob.get_val("f")[0] * scale == pytest.approx(f_star, rel=1e-4)
    assert prob.get_val("g")[0] <= 1e-8


def test_the_scipy_result_at_a_tolerance_is_measured_at_its_design():
    """Through scipy a problem held to a tolerance measures an evaluation only where it moved
    by more than ``readapt``; the design SLSQP returns is measured as it ends (``conclude``),
    so the result's values are those of a run to rtol there."""
    from flextop.interop.scipy import minimize as flextop_minimize

    sim = flextop.Simulation(flextop.scenes.spun_beam())
    problem = flextop.TopologyProblem(sim, "tip_deflection", flextop.volume_constraints(sim, 0.4), rtol=1e-2)
    held = []
    original = problem._evaluate

    def evaluate(x, measure):
        held.append((None if problem.rule.at is None else problem.rule.at.copy(), problem.discretization))
        return original(x, measure)

    problem._evaluate = evaluate
    result = flextop_minimize(problem, np.full(problem.n, 0.5), "SLSQP", options={"maxiter": 6})
    at, grid = held[-1]
    assert not np.array_equal(at, result.x) and problem.measured[-1] == problem.evaluations
    np.testing.assert_array_equal(problem.rule.at, result.x)
    measured = sim.run_with_sensitivities(result.x, "tip_deflection", rtol=1e-2, start=grid, hold_gradients=False)
    assert result.fun == pytest.approx(measured.values[0], rel=1e-7)
