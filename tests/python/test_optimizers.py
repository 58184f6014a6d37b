"""Tests of flextop.optimizers (CONLIN, MMA, GCMMA) on problems with known optima."""

import json

import numpy as np
import pytest
from scipy.optimize import minimize

from flextop.errors import FlextopError, SettingsError
from flextop.optimizers import (
    GCMMA,
    MMA,
    Conlin,
    Evaluation,
    EvaluationError,
    FunctionProblem,
    OptimalityCriteria,
    OptimizerState,
    Status,
    Trial,
    kkt_estimate,
    kkt_residual,
    optimize,
)

METHODS = ["mma", "gcmma", "conlin"]


def reference_optimum(problem, x0):
    """Independent optimum by scipy's SLSQP, to tight tolerance."""
    result = minimize(
        lambda x: problem.evaluate(x).f0, x0,
        jac=lambda x: problem.evaluate(x).df0,
        constraints=[{"type": "ineq",
                      "fun": lambda x: -problem.evaluate(x).g,
                      "jac": lambda x: -problem.evaluate(x).dg}],
        bounds=list(zip(problem.lower, problem.upper)),
        method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})
    assert result.success, result.message
    return result.x, result.fun


# -- Svanberg's five-segment cantilever beam ----------------------------------------------

CANTILEVER_C = np.array([61.0, 37.0, 19.0, 7.0, 1.0])


def cantilever():
    """minimize 0.0624 sum x  s.t.  sum c_i / x_i^3 <= 1,  1 <= x <= 10."""
    def objective(x):
        return 0.0624 * x.sum(), np.full(5, 0.0624)

    def constraint(x):
        return [np.sum(CANTILEVER_C / x**3) - 1.0], [-3.0 * CANTILEVER_C / x**4]

    return FunctionProblem(objective, constraint, np.ones(5), np.full(5, 10.0), m=1)


@pytest.fixture(scope="module")
def cantilever_optimum():
    x, f = reference_optimum(cantilever(), np.full(5, 5.0))
    # the optimum published by Svanberg (1987)
    assert f == pytest.approx(1.33996, abs=1e-5)
    assert x == pytest.approx([6.016, 5.309, 4.494, 3.502, 2.153], abs=1e-3)
    return x, f


# -- Rosenbrock, where plain MMA used to alternate between two points ----------------------

def rosenbrock_objective(x):
    a, b = x
    return (1 - a) ** 2 + 100 * (b - a * a) ** 2, np.array([-2 * (1 - a) - 400 * a * (b - a * a), 200 * (b - a * a)])


def rosenbrock_in(lower, upper, disc=None):
    """(1 − a)² + 100 (b − a²)² on the box [lower, upper], optionally inside the disc
    a² + b² ≤ disc (1.5 cuts off the unconstrained optimum (1, 1), 4 does not)."""
    def circle(x):
        return np.array([x[0] ** 2 + x[1] ** 2 - disc]), np.array([[2 * x[0], 2 * x[1]]])

    return FunctionProblem(rosenbrock_objective, None if disc is None else circle, lower, upper,
                           0 if disc is None else 1)


def rosenbrock(constrained):
    """On [−2, 2]², optionally with a² + b² ≤ 1.5 (which cuts off the unconstrained
    optimum (1, 1))."""
    return rosenbrock_in((-2, -2), (2, 2), 1.5 if constrained else None)


@pytest.mark.parametrize("constrained", [False, True])
@pytest.mark.parametrize("method", ["mma", "gcmma"])
def test_rosenbrock_converges_without_cycling(method, constrained):
    """A cycle never reaches a KKT point: the run ends at one, before the iteration limit."""
    problem = rosenbrock(constrained)
    x_star = reference_optimum(problem, np.array([-1.2, 1.0]))[0] if constrained else np.ones(2)
    result = optimize(problem, np.array([-1.2, 1.0]), method, max_iter=1000, xtol=0.0)
    assert result.status is Status.KKT and result.nit < 1000, result.message
    assert np.abs(result.x - x_star).max() < 1e-4, (result.x, x_star)
    assert np.max(result.constr_scaled, initial=-1.0) <= 1e-8


@pytest.mark.parametrize("method", METHODS)
def test_cantilever(method, cantilever_optimum):
    x_star, f_star = cantilever_optimum
    result = optimize(cantilever(), np.full(5, 5.0), method)
    assert result.success, result.message
    assert result.fun == pytest.approx(f_star, rel=1e-4)
    assert result.x == pytest.approx(x_star, rel=1e-3)
    assert result.constr[0] <= 1e-6
    print(f"{method}: f = {result.fun:.7f} (f* = {f_star:.7f}), {result.nit} iterations, "
          f"{result.nfev} evaluations, KKT {result.kkt:.2e}")


# -- Svanberg's two-bar truss ---------------------------------------------------------------

def two_bar_truss():
    """Svanberg (1987): x1 = bar cross-section area, x2 = half span (scaled).

    minimize    c1 x1 sqrt(1 + x2^2)
    subject to  c2 sqrt(1 + x2^2) (8/x1 +- 1/(x1 x2)) <= 1   (stresses in the two bars)
                0.2 <= x1 <= 4,  0.1 <= x2 <= 1.6
    """
    c1, c2 = 1.0, 0.124

    def objective(x):
        s = np.sqrt(1.0 + x[1] ** 2)
        return c1 * x[0] * s, [c1 * s, c1 * x[0] * x[1] / s]

    def constraints(x):
        x1, x2 = x
        s = np.sqrt(1.0 + x2**2)
        g, dg = [], []
        for sign in (1.0, -1.0):
            h = 8.0 / x1 + sign / (x1 * x2)
            g.append(c2 * s * h - 1.0)
            dg.append([c2 * s * (-h / x1),
                       c2 * (x2 / s * h - s * sign / (x1 * x2**2))])
        return g, dg

    return FunctionProblem(objective, constraints, [0.2, 0.1], [4.0, 1.6], m=2)


@pytest.mark.parametrize("method", METHODS)
def test_two_bar_truss(method):
    problem, x0 = two_bar_truss(), np.array([1.5, 0.5])
    x_star, f_star = reference_optimum(problem, x0)
    assert x_star == pytest.approx([1.41, 0.38], abs=0.01)  # published optimum
    assert f_star == pytest.approx(1.51, abs=0.01)
    result = optimize(problem, x0, method)
    assert result.success, result.message
    assert result.fun == pytest.approx(f_star, rel=1e-4)
    assert result.x == pytest.approx(x_star, rel=1e-3)
    print(f"{method}: f = {result.fun:.7f} (f* = {f_star:.7f}), {result.nit} iterations")


# -- several active constraints: KKT residual -----------------------------------------------

def quadratic_with_constraints(n=20):
    """Weighted least squares toward a target, pulled into a box, a volume and a
    compliance-like constraint, with a third (linear) constraint on the first half:

        minimize    sum w_i (x_i - a_i)^2
        subject to  sum x_i / n - 0.5 <= 0
                    sum b_i / x_i / n - 1.65 <= 0
                    sum_{i < n/2} x_i / n - 0.2 <= 0
                    0.1 <= x <= 1
    """
    t = np.linspace(0.0, 1.0, n)
    w, a, b = 1.0 + t, 0.9 - 0.3 * t, 0.5 + t**2
    first = (np.arange(n) < n // 2).astype(float)

    def objective(x):
        return np.sum(w * (x - a) ** 2), 2.0 * w * (x - a)

    def constraints(x):
        g = [x.mean() - 0.5, np.sum(b / x) / n - 1.65, first @ x / n - 0.2]
        dg = [np.full(n, 1.0 / n), -b / x**2 / n, first / n]
        return g, dg

    return FunctionProblem(objective, constraints, np.full(n, 0.1), np.ones(n), m=3)


@pytest.fixture(scope="module")
def quadratic_optimum():
    return reference_optimum(quadratic_with_constraints(), np.full(20, 0.5))


@pytest.mark.parametrize("method", METHODS)
def test_several_constraints_kkt(method, quadratic_optimum):
    problem, x0 = quadratic_with_constraints(), np.full(20, 0.5)
    x_star, f_star = quadratic_optimum
    result = optimize(problem, x0, method, max_iter=300, xtol=0.0)
    assert result.status == Status.KKT, result.message
    assert result.kkt < 1e-5
    assert (result.multipliers > 1.0).all()  # all three constraints active
    assert result.fun == pytest.approx(f_star, rel=1e-6)
    assert result.x == pytest.approx(x_star, abs=1e-4)
    print(f"{method}: KKT {result.kkt:.2e} after {result.nit} iterations, "
          f"multipliers {result.multipliers}")


# -- failure recovery -----------------------------------------------------------------------

class SimulationCrashed(EvaluationError):
    """Stands in for a simulation error wrapped by the engine."""


def test_failure_region_is_avoided():
    """The analysis crashes for x1 > 5.5 (the optimum has x1 = 6.02): the
    optimizer steps back, halves its move limit and ends near the crash border."""
    inner = cantilever()

    def objective(x):
        if x[0] > 5.5:
            raise SimulationCrashed(f"solver diverged at x1 = {x[0]:.3f}", x)
        return inner.objective(x)

    problem = FunctionProblem(objective, inner.constraints, inner.lower, inner.upper, m=1)
    x0 = np.full(5, 5.0)
    result = optimize(problem, x0, "mma")
    assert "solver diverged" in result.message
    assert result.state.failures >= 1
    assert result.x[0] <= 5.5
    assert result.constr[0] <= 1e-6
    assert result.fun <= problem.evaluate(x0).f0
    print(result.message, result.fun)


def test_persistent_failure_returns_best_feasible():
    """The analysis stops working for good after 6 evaluations."""
    inner = cantilever()
    calls = []

    def objective(x):
        calls.append(x.copy())
        if len(calls) > 6:
            raise SimulationCrashed("license server unreachable", x)
        return inner.objective(x)

    problem = FunctionProblem(objective, inner.constraints, inner.lower, inner.upper, m=1)
    result = optimize(problem, np.full(5, 5.0), "gcmma")
    assert result.status == Status.EVALUATION_FAILED and not result.success
    assert "license server unreachable" in result.message
    assert "best feasible" in result.message
    assert result.state.consecutive_failures == 4  # max_retries = 3 retries after the first
    assert len(calls) == 6 + 4
    feasible = [x for x in calls[:6] if inner.evaluate(x).g[0] <= 1e-6]
    best = min(feasible, key=lambda x: inner.evaluate(x).f0)
    assert result.x == pytest.approx(best, abs=0.0)
    assert result.constr[0] <= 1e-6
    assert result.fun <= inner.evaluate(np.full(5, 5.0)).f0


def test_failing_start_returns_result():
    def objective(x):
        raise SimulationCrashed("mesh is inverted", x)

    problem = FunctionProblem(objective, None, [1.0], [2.0], m=0)
    result = optimize(problem, [1.5])
    assert result.status == Status.EVALUATION_FAILED and not result.success
    assert "mesh is inverted" in result.message
    assert result.nfev == 1 and np.isnan(result.fun)


# -- resume from a checkpoint ---------------------------------------------------------------

@pytest.mark.parametrize("method", METHODS)
def test_resume_from_checkpoint_is_exact(method):
    problem, x0 = quadratic_with_constraints(), np.full(20, 0.5)
    options = {"max_iter": 25, "kkt_tol": 0.0, "xtol": 0.0}
    full = optimize(problem, x0, method, **options)
    assert full.nit == 25

    checkpoints = {}

    def checkpoint(record):
        checkpoints[record.iteration] = json.dumps(record.state.to_dict())

    first = optimize(problem, x0, method, callback=checkpoint, **{**options, "max_iter": 10})
    assert first.nit == 10 and first.status == Status.MAX_ITER
    state = OptimizerState.from_dict(json.loads(checkpoints[10]))
    resumed = optimize(problem, None, method, state=state, **options)
    assert resumed.nit == 25
    np.testing.assert_allclose(resumed.x, full.x, rtol=0.0, atol=1e-12)
    assert [r.f0 for r in resumed.history] == [r.f0 for r in full.history]
    assert resumed.nfev == full.nfev


def test_callback_can_stop():
    result = optimize(cantilever(), np.full(5, 5.0), "mma", callback=lambda record: record.iteration == 3)
    assert result.status == Status.CALLBACK and result.nit == 3
    record = result.history[-1]
    assert record.eval_time >= 0.0 and record.solve_time > 0.0


def test_a_bad_start_or_method_is_named():
    """The start is one number (for every variable) or one per variable, finite; anything
    else is a DesignError, an unknown method a SettingsError."""
    from flextop.errors import DesignError, SettingsError

    problem = cantilever()
    with pytest.raises(DesignError, match="x0 must be one finite number or 5"):
        optimize(problem, [1.0, 2.0])
    with pytest.raises(DesignError, match="x0 must be one finite number"):
        optimize(problem, np.full(5, np.nan))
    with pytest.raises(DesignError, match="x0 must be numbers"):
        optimize(problem, "five")
    with pytest.raises(SettingsError, match="unknown method 'newton'"):
        optimize(problem, 5.0, "newton")
    assert np.array_equal(optimize(problem, 5.0, max_iter=3).x, optimize(problem, np.full(5, 5.0), max_iter=3).x)


@pytest.mark.parametrize(("settings", "words"), [
    ({"move": -0.1}, r"move must be in \(0, 1\], got -0\.1"),
    ({"move": 0.0}, r"move must be in \(0, 1\], got 0\.0"),
    ({"move": 1.5}, r"move must be in \(0, 1\], got 1\.5"),
    ({"move": float("nan")}, r"move must be a finite number, got nan"),
    ({"move": "0.2"}, r"move must be a finite number, got '0\.2'"),
    ({"kkt_tol": -1e-6}, r"kkt_tol must be ≥ 0, got -1e-06"),
    ({"xtol": -1.0}, r"xtol must be ≥ 0, got -1\.0"),
    ({"ftol": float("inf")}, r"ftol must be a finite number, got inf"),
    ({"feas_tol": -1e-6}, r"feas_tol must be ≥ 0, got -1e-06"),
    ({"max_iter": 2.5}, r"max_iter must be a whole number ≥ 0, got 2\.5"),
    ({"max_retries": -1}, r"max_retries must be a whole number ≥ 0, got -1"),
])
def test_bad_settings_of_optimize_are_named_with_their_range(settings, words):
    """``move=-0.1`` was accepted, and through a density filter the returned design reached
    −0.12, below ``x_min``; every setting of :func:`optimize` is now checked before the
    start design is evaluated."""
    evaluations = []
    problem = FunctionProblem(lambda x: (evaluations.append(1) or float(np.sum(1 / x)), -1 / x**2), None,
                              np.full(2, 0.1), np.ones(2), 0)
    with pytest.raises(SettingsError, match=words):
        optimize(problem, 0.5, **settings)
    assert not evaluations


@pytest.mark.parametrize(("make", "words"), [
    (lambda: OptimalityCriteria(eta=0.0), r"OptimalityCriteria: eta must be in \(0, 1\], got 0\.0"),
    (lambda: OptimalityCriteria(eta=-1.0), r"OptimalityCriteria: eta must be in \(0, 1\], got -1\.0"),
    (lambda: OptimalityCriteria(eta=float("nan")), r"OptimalityCriteria: eta must be a finite number, got nan"),
    (lambda: OptimalityCriteria(tol=0.0), r"OptimalityCriteria: tol must be in \(0, 1\)"),
    (lambda: MMA(asyinit=0.0), r"MMA: asyinit must be in \[0\.01, 10\], got 0\.0"),
    (lambda: MMA(asyincr=0.5), r"MMA: asyincr must be ≥ 1, got 0\.5"),
    (lambda: MMA(asydecr=1.5), r"MMA: asydecr must be in \(0, 1\], got 1\.5"),
    (lambda: MMA(c=-1.0), r"MMA: c must be ≥ 0, got -1\.0"),
    (lambda: MMA(d=0.0), r"MMA: d must be > 0, got 0\.0"),
    (lambda: MMA(rho="1e-5"), r"MMA: rho must be a finite number, got '1e-5'"),
    (lambda: GCMMA(rho_min=0.0), r"GCMMA: rho_min must be > 0, got 0\.0"),
    (lambda: GCMMA(max_inner=-1), r"GCMMA: max_inner must be a whole number ≥ 0, got -1"),
    (lambda: GCMMA(asyincr=float("inf")), r"GCMMA: asyincr must be a finite number, got inf"),
    (lambda: Conlin(move_incr=0.9), r"Conlin: move_incr must be ≥ 1, got 0\.9"),
    (lambda: Conlin(move_decr=0.0), r"Conlin: move_decr must be in \(0, 1\], got 0\.0"),
    (lambda: Conlin(d=-1.0), r"Conlin: d must be > 0, got -1\.0"),
])
def test_bad_settings_of_a_method_are_named_with_their_range(make, words):
    """``OptimalityCriteria(eta=-1)`` ended 149 % over the volume bound; each method's
    numeric settings are checked as it is made."""
    with pytest.raises(SettingsError, match=words):
        make()


def test_a_problem_without_accept_still_optimizes():
    """Any object with n, m, lower, upper and evaluate works: ``accept`` is optional."""
    inner = cantilever()

    class Bare:
        n, m, lower, upper, names = inner.n, inner.m, inner.lower, inner.upper, None
        evaluate = staticmethod(inner.evaluate)
        physical = staticmethod(inner.physical)

    assert np.array_equal(optimize(Bare(), 5.0, max_iter=3).x, optimize(inner, 5.0, max_iter=3).x)


@pytest.mark.parametrize("method", ["mma", "gcmma"])
def test_trials_make_gradients_only_where_the_design_is_kept(method):
    """A problem whose gradients cost extra gives MMA and GCMMA trials: the values first, the
    gradients only for the designs they keep (one per iteration and the start), and the
    same iterates, bit for bit, as evaluating everything."""
    whole = rosenbrock(constrained=True)

    class Lazy(FunctionProblem):
        made = 0

        def trial(self, x):
            e = self.evaluate(x)

            def gradients():
                Lazy.made += 1
                return e

            return Trial(e.f0, e.g, gradients)

    lazy = Lazy(rosenbrock_objective, whole.constraints, whole.lower, whole.upper, 1)
    result = optimize(lazy, np.array([-1.2, 1.0]), method, max_iter=60, xtol=0.0)
    reference = optimize(whole, np.array([-1.2, 1.0]), method, max_iter=60, xtol=0.0)
    assert np.array_equal(result.x, reference.x) and result.nfev == reference.nfev
    assert Lazy.made == result.nit < result.nfev - 1, (Lazy.made, result.nit, result.nfev)


# -- success means a KKT point ----------------------------------------------------------------

ROSENBROCK_BOUNDS = {"issue's box": ((-1.7, -0.8), (1.9, 2.6)), "[-2, 2]²": ((-2, -2), (2, 2))}
ROSENBROCK_DISCS = {"no constraint": None, "inactive disc": 4.0, "active disc": 1.5}
ROSENBROCK_STARTS = [(-1.3, 1.9), (-1.2, 1.0), (1.5, -0.5)]


def rosenbrock_optimum(problem):
    """(1, 1) where no constraint cuts it off, else SLSQP's optimum."""
    inside = problem.m == 0 or problem.evaluate(np.ones(2)).g[0] <= 0.0
    return np.ones(2) if inside else reference_optimum(problem, np.array([0.5, 0.5]))[0]


@pytest.mark.parametrize("disc", ROSENBROCK_DISCS)
@pytest.mark.parametrize("bounds", ROSENBROCK_BOUNDS)
@pytest.mark.parametrize("method", ["mma", "gcmma"])
def test_rosenbrock_success_is_a_kkt_point(method, bounds, disc):
    """From three starts in two boxes, without a constraint and with an inactive and an
    active disc: success=True only at a KKT residual below kkt_tol and within 1e-4 of the
    optimum, success=False only with a message naming the KKT residual; and MMA and GCMMA
    get there from every start."""
    problem = rosenbrock_in(*ROSENBROCK_BOUNDS[bounds], ROSENBROCK_DISCS[disc])
    x_star, tol = rosenbrock_optimum(problem), 1e-6
    reached = []
    for start in ROSENBROCK_STARTS:
        result = optimize(problem, start, method, max_iter=1500, kkt_tol=tol)
        assert result.kkt == kkt_estimate(result.x, problem.evaluate(result.x), problem.lower, problem.upper,
                                          result.state.multipliers)[0] == result.history[-1].kkt
        if result.success:
            assert result.status is Status.KKT and result.kkt < tol, result.message
            assert np.abs(result.x - x_star).max() <= 1e-4, (start, result.x, x_star)
            assert np.max(result.constr_scaled, initial=-1.0) <= 1e-6
        else:
            assert f"KKT residual {result.kkt:.3g} not below kkt_tol = {tol:g}" in result.message
        reached.append(result.success)
        print(f"{method} {bounds} {disc} from {start}: {result.nit} iterations, {result.nfev} evaluations, "
              f"|x - x*| = {np.abs(result.x - x_star).max():.1e}, KKT {result.kkt:.1e}, success {result.success}")
    assert all(reached), "MMA reaches the optimum from every start within 1500 iterations"


def test_the_issues_false_stop_is_no_success():
    """The issue's run: a design change below xtol = 1e-4 (the old default) after 27
    iterations at (0.723, 0.521), where the gradient is far from zero. It is a stall, not
    a success, and the KKT residual there is the gradient's largest component. By default
    a small step does not stop the run (test_rosenbrock_success_is_a_kkt_point follows it
    to the optimum)."""
    problem = rosenbrock_in((-1.7, -0.8), (1.9, 2.6))
    stalled = optimize(problem, (-1.3, 1.9), "mma", xtol=1e-4)
    assert stalled.status is Status.XTOL and not stalled.success
    assert stalled.nit == 27 and stalled.x == pytest.approx([0.723, 0.521], abs=1e-3)
    gradient = rosenbrock_objective(stalled.x)[1]
    assert stalled.kkt == pytest.approx(np.abs(gradient).max(), rel=1e-12) and stalled.kkt > 0.2
    assert stalled.message.startswith("stalled: max design change 8.29e-05 below xtol = 0.0001")
    assert stalled.history[-1].change < 1e-4 <= stalled.history[-2].change
    assert f"KKT residual {stalled.kkt:.3g} not below kkt_tol = 1e-06" in stalled.message
    limited = optimize(problem, (-1.3, 1.9), "mma")  # by default: on to the iteration limit
    assert limited.status is Status.MAX_ITER and limited.nit == 100 and not limited.success
    assert limited.fun < stalled.fun and f"KKT residual {limited.kkt:.3g} not below" in limited.message


def test_the_kkt_residual_where_it_is_known():
    """On a box: the projected gradient, capped by the distance to a bound and nothing
    where the gradient pushes outward at one, relative to |f| where |f| > 1. With a disc:
    zero at the optimum with the multiplier that balances the gradient; a multiplier on
    an inactive constraint costs its complementarity; infeasibility counts."""
    def objective(x):
        return 0.5 * ((x[0] - 2.5) ** 2 + (x[1] + 0.5) ** 2), np.array([x[0] - 2.5, x[1] + 0.5])

    box = FunctionProblem(objective, None, [0.0, 0.0], [2.0, 2.0], 0)
    for x, want in [((2.0, 0.0), 0.0),   # grad (-0.5, 0.5) pushes out of both bounds
                    ((2.0, 0.3), 0.3),   # grad_1 = 0.8, but x_1 is 0.3 from its bound
                    ((1.8, 0.1), 0.2),   # grad_0 = -0.7, but x_0 is 0.2 from its bound
                    ((0.5, 1.5), 0.5)]:  # f = 4: grad / f = (-0.5, 0.5)
        x = np.array(x)
        assert kkt_estimate(x, box.evaluate(x), box.lower, box.upper)[0] == pytest.approx(want, abs=1e-15), x
    disc = rosenbrock(True)
    x_star = reference_optimum(disc, np.array([0.5, 0.5]))[0]
    e = disc.evaluate(x_star)
    lam_star = -(e.df0 @ e.dg[0]) / (e.dg[0] @ e.dg[0])  # grad f + lam grad g = 0 on the circle
    residual, lam = kkt_estimate(x_star, e, disc.lower, disc.upper)
    assert residual < 1e-6 and lam == pytest.approx([lam_star], rel=1e-6)
    assert kkt_residual(x_star, e, np.zeros(1), disc.lower, disc.upper) == pytest.approx(np.abs(e.df0).max())
    inside = np.array([0.5, 0.25])  # on the valley floor: grad f = (-1, 0), g = -1.1875
    residual, lam = kkt_estimate(inside, disc.evaluate(inside), disc.lower, disc.upper, np.array([2.0]))
    assert residual == 1.0 and lam == [0.0]  # lam = 2 would leave min(lam, -g) = 1.1875
    outside = np.array([1.0, 1.0])  # the unconstrained optimum: grad f = 0, g = 0.5
    assert kkt_estimate(outside, disc.evaluate(outside), disc.lower, disc.upper)[0] == 0.5


def test_every_exit_names_the_kkt_residual_of_its_design():
    """Iteration limit, callback, stall and repeated evaluation failures: no success, and
    the message names the KKT residual of the design returned."""
    calls = []

    def crashing(x):
        calls.append(1)
        if len(calls) > 4:
            raise SimulationCrashed("license server unreachable", x)
        return cantilever().objective(x)

    runs = {Status.MAX_ITER: (cantilever(), {"max_iter": 3}),
            Status.CALLBACK: (cantilever(), {"callback": lambda record: record.iteration == 2}),
            Status.XTOL: (cantilever(), {"xtol": 0.5}),
            Status.EVALUATION_FAILED: (FunctionProblem(crashing, cantilever().constraints, np.ones(5),
                                                       np.full(5, 10.0), m=1), {})}
    for status, (problem, options) in runs.items():
        result = optimize(problem, np.full(5, 5.0), "mma", **options)
        assert result.status is status and not result.success, result.message
        calls.clear()  # the license server is back, to evaluate the design returned
        kkt = kkt_estimate(result.x, problem.evaluate(result.x), problem.lower, problem.upper,
                           result.state.best.multipliers if status is Status.EVALUATION_FAILED
                           else result.state.multipliers)[0]
        assert result.kkt == kkt > 1e-6
        assert f"KKT residual {kkt:.3g} not below kkt_tol = 1e-06" in result.message


def test_conlin_names_a_lower_bound_that_is_not_positive():
    """CONLIN's reciprocal variables 1/x need x > 0: a lower bound <= 0 is a SettingsError
    naming the variable and the bound, raised before any evaluation."""
    evaluated = []

    def objective(x):
        evaluated.append(x)
        return rosenbrock_objective(x)

    for lower, match in [((-1.7, -0.8), r"x\[0\] has lower bound -1.7 \(and 1 more\)"),
                         ((0.5, 0.0), r"x\[1\] has lower bound 0;")]:
        problem = FunctionProblem(objective, None, lower, (1.9, 2.6), 0)
        with pytest.raises(SettingsError, match=match) as raised:
            optimize(problem, (1.0, 1.0), "conlin")
        assert isinstance(raised.value, FlextopError) and "reciprocal" in str(raised.value)
    assert not evaluated
    assert optimize(FunctionProblem(objective, None, (0.5, 0.5), (1.9, 2.6), 0), (1.2, 1.2), "conlin").nit > 0


def test_optimality_criteria_reach_the_known_optimum_of_a_sum_of_reciprocals():
    """min Σ cᵢ/xᵢ s.t. Σ xᵢ ≤ V (the compliance of springs in series, stiffness ∝ x): the
    optimum is xᵢ = V √cᵢ / Σ √cⱼ, the fixed point of the OC update; with η = ½ from a
    uniform start the error contracts by half per iteration, and the KKT residual says so."""
    c = np.array([1.0, 4.0, 9.0, 0.25, 2.0])
    volume = 2.0
    problem = FunctionProblem(lambda x: (np.sum(c / x), -c / x**2),
                              lambda x: (np.array([x.sum() / volume - 1.0]), np.ones((1, x.size)) / volume),
                              np.full(5, 1e-3), np.ones(5), 1)
    result = optimize(problem, 0.4, method="oc", max_iter=80, kkt_tol=1e-9)
    optimum = volume * np.sqrt(c) / np.sqrt(c).sum()
    assert result.success and result.status is Status.KKT
    np.testing.assert_allclose(result.x, optimum, rtol=1e-8)
    assert result.multipliers[0] == pytest.approx(np.sqrt(c).sum() ** 2 / volume, rel=1e-6)


def volume_bounded(objective, n, fraction):
    """min objective(x) s.t. Σ x ≤ fraction n on 1e-3 ≤ x ≤ 1 (a volume)."""
    return FunctionProblem(objective, lambda x: (np.array([x.sum() / (fraction * n) - 1.0]), np.full((1, n), 1.0 / (fraction * n))),
                           np.full(n, 1e-3), np.ones(n), 1)


def oc_steps(problem, x0, **options):
    """The steps of an OC run, each as the evaluation it started from and the state it
    made, and the run's result."""
    states = []
    result = optimize(problem, x0, method="oc", callback=lambda record: states.append(record.state), **options)
    return [(problem.evaluate(state.x_prev1), state) for state in states], result


def test_optimality_criteria_do_not_raise_a_sum_of_densities():
    """f = Σx under Σx ≤ 0.4 n from the feasible x = 0.4: the volume's multiplier is zero, and
    the update used to send every variable up its move limit (x = 0.6, 50 % over the bound,
    f up). Every variable's objective grows with it: each iterate is feasible, f falls, and
    the run ends at the lower bounds, a KKT point."""
    n = 10
    steps, result = oc_steps(volume_bounded(lambda x: (x.sum(), np.ones(x.size)), n, 0.4), 0.4, max_iter=20)
    assert steps and steps[0][0].g[0] == 0
    for before, after in steps:
        assert after.evaluation.g[0] <= 1e-12 and after.evaluation.f0 < before.f0
    assert result.status is Status.KKT and np.array_equal(result.x, np.full(n, 1e-3))


def test_optimality_criteria_keep_variables_the_objective_grows_with_from_rising():
    """Σ cᵢ/xᵢ over the first four variables (a compliance: its gradient negative) plus
    Σ dⱼ xⱼ over the last three (a mass the objective pays for: positive), from x = 0.2
    under Σx ≤ 0.5 n: the first steps leave the constraint inactive (λ = 0), the later ones
    hold it active (λ > 0). No iterate leaves the feasible set, and no variable with a
    positive gradient ever rises; the others gain the volume."""
    c, d = np.array([1.0, 4.0, 9.0, 2.0]), np.array([0.5, 1.0, 3.0])

    def objective(x):
        return np.sum(c / x[:4]) + d @ x[4:], np.concatenate((-c / x[:4] ** 2, d))

    steps, result = oc_steps(volume_bounded(objective, 7, 0.5), 0.2, max_iter=40)
    multipliers = np.array([after.multipliers[0] for _, after in steps])
    assert (multipliers == 0).any() and (multipliers > 0).any()
    for before, after in steps:
        assert before.g[0] <= 0 and after.evaluation.g[0] <= 1e-12
        rising = before.df0 > 0
        assert rising[4:].all() and np.all(after.x[rising] <= after.x_prev1[rising])
    assert np.array_equal(result.x[4:], np.full(3, 1e-3)) and np.all(result.x[:4] > 0.2)


def test_optimality_criteria_converge_on_their_design_change_only_off_the_move_limit():
    """OC's update changes a design by its optimality residual: with ``xtol``, Σ cᵢ/xᵢ² under a
    volume (the update contracts the error by half per iteration) stops converged (FIXED_POINT, a success) at the first change below it, long
    before the KKT residual reaches kkt_tol; a change held at the move limit is no fixed
    point (xtol above the move limit: stalled, XTOL); MMA's small step stays a stall."""
    c = np.array([1.0, 4.0, 9.0, 0.25, 2.0])
    problem = volume_bounded(lambda x: (np.sum(c / x**2), -2 * c / x**3), 5, 0.4)
    result = optimize(problem, 0.4, method="oc", max_iter=80, xtol=1e-3)
    changes = [record.change for record in result.history[1:]]
    assert result.status is Status.FIXED_POINT and result.success and result.nit < 80
    assert changes[-1] < 1e-3 <= min(changes[:-1]) and result.kkt > 1e-6
    assert "max design change" in result.message and "no variable at its move limit" in result.message
    held = optimize(problem, 0.4, method="oc", max_iter=80, move=0.1, xtol=0.5)
    assert held.status is Status.XTOL and not held.success and held.nit == 1
    mma = optimize(problem, 0.4, method="mma", max_iter=80, xtol=1e-3, kkt_tol=1e-12)
    assert mma.status is Status.XTOL and not mma.success


def test_optimality_criteria_take_one_constraint_that_grows_with_every_variable():
    two = FunctionProblem(lambda x: (np.sum(1 / x), -1 / x**2),
                          lambda x: (np.array([x.sum() - 1, x[0] - 0.5]), np.array([[1.0, 1.0], [1.0, 0.0]])),
                          np.full(2, 0.1), np.ones(2), 2)
    with pytest.raises(SettingsError, match="exactly one constraint"):
        optimize(two, 0.4, method="oc")
    falling = FunctionProblem(lambda x: (np.sum(1 / x), -1 / x**2),
                              lambda x: (np.array([1 - x.sum()]), -np.ones((1, 2))), np.full(2, 0.1), np.ones(2), 1)
    with pytest.raises(SettingsError, match="grows with every variable"):
        optimize(falling, 0.4, method="oc")


def test_a_rejected_trial_raises_rho_until_the_approximation_bounds_it():
    """:func:`raised_rho` on Rosenbrock in the disc a² + b² ≤ 1.5 from (−1.2, 1), from
    GCMMA's start and larger ones: where an approximation falls below its function at MMA's
    trial, rho_i becomes 1.1 (rho_i + delta_i), which bounds the function there from above,
    unless that exceeds GCMMA's cap of 10 rho_i; where it already bounds it, rho_i stays."""
    from flextop.optimizers.mma import MMA, initial_rho, raised_rho

    problem = rosenbrock(True)
    x0 = np.array([-1.2, 1.0])
    evaluation = problem.evaluate(x0)
    state = OptimizerState("mma", 0, x0, evaluation, np.zeros(1), 1.0, 0.2)
    method = MMA()
    mma = method.approximation(problem, state, 0.2, np.full(2, method.rho))
    trial = method.solve(mma, state.multipliers).x
    exact = problem.evaluate(trial)
    values = np.array([exact.f0, *exact.g])
    bounded = 0
    for scale in (1.0, 3.0, 10.0, 30.0):
        start = scale * initial_rho(evaluation, problem.upper - problem.lower)
        rho = raised_rho(mma, start, trial, exact)
        below = values > mma.regularized(start).values(trial)
        capped = rho == 10.0 * start
        assert np.all(rho[~below] == start[~below])
        assert np.all(mma.regularized(rho).values(trial)[below & ~capped] >= values[below & ~capped])
        assert np.all((rho > start)[below])
        bounded += int(np.sum(below & ~capped))
    assert bounded >= 1, "the bound reached without the cap at least once"


def test_a_failure_in_accept_is_recovered_like_one_in_evaluate():
    """A problem whose ``accept`` fails once (a problem held to a tolerance measures the
    accepted design there, and that run may fail): the iteration is redone from the same
    design with half the move limit, and the run still reaches the cantilever's optimum."""
    inner = cantilever()

    class FailsOnce(type(inner)):
        accepted = 0

        def accept(self, x, evaluation):
            self.accepted += 1
            if self.accepted == 3:
                raise EvaluationError("the accepted design's measurement failed", x)
            return evaluation

    problem = FailsOnce(inner.objective, inner.constraints, inner.lower, inner.upper, inner.m)
    result = optimize(problem, np.full(5, 5.0), "mma")
    assert result.success and result.fun == pytest.approx(1.33996, abs=1e-5), result.message
    assert result.state.failures == 1 and "1 evaluation failure(s) recovered" in result.message
    assert result.history[2].move == pytest.approx(0.5 * result.history[1].move)


def test_the_returned_design_is_the_one_the_problem_concludes():
    """``conclude`` (a problem held to a tolerance measures the returned design as the run
    ends): the result reports the concluded evaluation and judges convergence on it. A
    conclusion that moves the objective's gradient away from the KKT point is no success
    (UNCONFIRMED, the residual of the concluded gradient named); one that fails keeps the
    held values and says so; one that changes nothing changes nothing."""
    inner = cantilever()

    class Concludes(type(inner)):
        def __init__(self, change):
            super().__init__(inner.objective, inner.constraints, inner.lower, inner.upper, inner.m)
            self.change, self.concluded = change, []

        def conclude(self, x, evaluation):
            self.concluded.append(x.copy())
            return self.change(x, evaluation)

    plain = optimize(inner, np.full(5, 5.0), "mma")
    same = Concludes(lambda x, e: e)
    result = optimize(same, np.full(5, 5.0), "mma")
    assert result.success and np.array_equal(result.x, plain.x) and len(same.concluded) == 1
    np.testing.assert_array_equal(same.concluded[0], result.x)

    tilted = Concludes(lambda x, e: Evaluation(1.001 * e.f0, e.g, e.df0 + [0.01, -0.01, 0.0, 0.0, 0.0], e.dg))
    result = optimize(tilted, np.full(5, 5.0), "mma")
    assert result.status is Status.UNCONFIRMED and not result.success, result.message
    assert result.fun == pytest.approx(1.001 * plain.fun, rel=1e-12) and result.kkt > 1e-6
    assert result.state.evaluation.f0 == result.fun_scaled and f"KKT residual {result.kkt:.3g} not below" in result.message

    def fails(x, e):
        raise EvaluationError("the returned design's run to rtol did not converge", x)

    result = optimize(Concludes(fails), np.full(5, 5.0), "mma")
    assert result.status is Status.UNCONFIRMED and not result.success and result.fun == plain.fun
    assert "could not be measured (the returned design's run to rtol did not converge)" in result.message


def feasible_best(result):
    """The smallest scaled objective of a run's feasible iterates and its iteration."""
    return min((record.f0, record.iteration) for record in result.history if np.max(record.g, initial=-np.inf) <= 1e-6)


def test_at_the_iteration_limit_the_best_feasible_iterate_is_returned_and_said_so():
    """OC's update with η = ½ overshoots Σ cᵢ/xᵢ⁶ under a volume (its fixed-point map's
    slope is 1 − 7/2): from x = 0.1 (feasible, far worse) f0 falls for three iterations,
    then the iterates cycle between two feasible designs, both worse. Stopped in the cycle
    (after 7 or 8 iterations), the result is the third iterate, its objective,
    constraints and KKT residual that design's, and the message names it; stopped after 3,
    that last iterate is returned as it is. Plain MMA on Rosenbrock from (−1.2, 1), not a
    descent method, likewise."""
    c = np.array([1.0, 4.0, 9.0, 0.25, 2.0])
    problem = volume_bounded(lambda x: (np.sum(c / x**6), -6 * c / x**7), 5, 0.4)
    for max_iter in (3, 7, 8):
        result = optimize(problem, 0.1, method="oc", max_iter=max_iter)
        last = result.history[-1]
        f0, iteration = feasible_best(result)
        assert result.status is Status.MAX_ITER and not result.success and iteration == 3
        assert result.fun_scaled == f0 and problem.evaluate(result.x).f0 == f0
        assert result.kkt == kkt_estimate(result.x, problem.evaluate(result.x), problem.lower, problem.upper,
                                          result.multipliers)[0]
        if max_iter == 3:
            assert "best feasible" not in result.message and np.array_equal(result.x, result.state.x)
            continue
        assert last.f0 > f0 and np.max(last.g) <= 1e-6
        assert f"returning the best feasible design, iteration 3's (f0 = {f0:.6g}; " \
               f"the last, iteration {max_iter}: f0 = {last.f0:.6g})" in result.message
        assert np.array_equal(result.x, result.state.best.x) and not np.array_equal(result.x, result.state.x)
    rosenbrock_run = optimize(rosenbrock(False), np.array([-1.2, 1.0]), MMA(safeguard=False), max_iter=40)
    assert rosenbrock_run.history[-1].f0 > feasible_best(rosenbrock_run)[0]
    assert rosenbrock_run.fun_scaled == feasible_best(rosenbrock_run)[0] and "best feasible" in rosenbrock_run.message


def test_at_the_iteration_limit_an_infeasible_last_iterate_gives_way_to_the_best_feasible_one():
    """Σ cᵢ/xᵢ under a volume whose bound drops from 2 to 0.3 after the sixth evaluation (a
    model changed under the run, as a problem held to a tolerance may see it): from x = 0.1
    the last iterate is infeasible, and the result is the best of the feasible ones before
    it, said so."""
    c = np.array([1.0, 4.0, 9.0, 0.25, 2.0])
    calls = []

    def volume(x):
        calls.append(x.copy())
        bound = 2.0 if len(calls) <= 6 else 0.3
        return np.array([x.sum() / bound - 1.0]), np.full((1, x.size), 1.0 / bound)

    problem = FunctionProblem(lambda x: (np.sum(c / x), -c / x**2), volume, np.full(5, 1e-3), np.ones(5), 1)
    result = optimize(problem, 0.1, method="mma", max_iter=7)
    last = result.history[-1]
    assert np.max(last.g) > 1e-6 and result.status is Status.MAX_ITER
    f0, iteration = feasible_best(result)
    assert result.fun_scaled == f0 and iteration < last.iteration
    assert f"returning the best feasible design, iteration {iteration}'s (f0 = {f0:.6g}; the last, iteration 7: infeasible)" \
        in result.message
