"""Runs to a tolerance (flextop.discretization.tolerance): the estimator against known errors, the arm
against converged references, exact gradients on the grid that ran, and clear errors."""

from dataclasses import replace

import numpy as np
import pytest

import flextop
from flextop.discretization import tolerance
from flextop.errors import SettingsError, SimulationError, ToleranceError
from flextop.discretization.tolerance import Discretization, Tolerance, estimate, extrapolated_estimate, resolve

from conftest import on_accepted_grid

T_ARM = 1.3


def model_values(c_time=0.3, c_space=0.002, exact=2.0, t_end=1.0, gradient=False, c_cubic=0.0):
    """Quantities with a known error: f = exact + c_time·h² + c_cubic·h³ + c_space/r (what
    the estimator assumes at its limits: second order in h, first order in 1/r; the h³
    term is what Richardson's extrapolation leaves)."""
    calls = []

    def values(d, companion=False):
        calls.append(d)
        h = t_end / d.steps if d.steps else 0.0
        f = exact + c_time * h**2 + c_cubic * h**3 + c_space / (d.refinement * d.uniform)
        return [np.array([f])] + ([np.array([f, -2 * f])] if gradient else [])

    return values, calls


def test_the_estimate_is_exact_on_its_model_and_the_accepted_run_meets_rtol():
    values, calls = model_values()
    for rtol in (1e-2, 1e-3, 1e-4):
        d, est = resolve(values, Discretization(1, 8), Tolerance(["f"], np.array([rtol]), np.array([0.0])))
        f = values(d)[0][0]
        true = abs(f - 2.0)
        assert true <= rtol * abs(f)
        assert est.total[0] == pytest.approx(true, rel=1e-9), "Richardson is exact when the error is c·h² + c'/r"
        assert est.relative[0] == pytest.approx(true / abs(f), rel=1e-9)
        coarser = Discretization(d.refinement, d.steps // 2), Discretization(max(1, d.refinement // 2), d.steps)
        assert any(abs(values(c)[0][0] - 2.0) > rtol * 2.0 for c in coarser if c != d), "not refined beyond need"
    assert len(set(calls)) < len(calls), "companions reuse earlier runs"


def test_gradients_are_held_to_their_own_tolerance():
    values, _ = model_values(c_space=0.0, gradient=True)
    tol = tolerance.tolerance_of(["f"], 1e-3, 0.0, gradients=True)
    assert tol.rtol.tolist() == [1e-3, tolerance.GRADIENT_FACTOR * 1e-3]
    d, est = resolve(values, Discretization(1, 8), tol)
    assert est.relative[1] <= tolerance.GRADIENT_FACTOR * 1e-3 and est.relative[0] <= 1e-3


def test_the_observed_contraction_guards_the_preasymptotic_range():
    """When halving h only halves the error (first order, as on the full-density arm at
    h = 0.02), the second-order formula would understate it 3×; the observed contraction
    does not."""
    exact, fine, half, quarter = 1.0, [np.array([1.1])], [np.array([1.2])], [np.array([1.4])]
    split = half
    est = estimate(fine, half, quarter, split)
    assert est.time[0] == pytest.approx(abs(fine[0][0] - exact)), "exact for a first-order error"
    assert estimate(fine, half, [np.array([1.2 + 0.4])], split).time[0] == pytest.approx(0.1 / 3), "second order at most"
    assert estimate(fine, half, None, split).time[0] == pytest.approx(0.2), "no quarter run: the slowest contraction, 1.5"
    assert estimate(fine, half, [np.array([1.2 + 2.4])], split).time[0] == pytest.approx(0.2), \
        "a contraction of 24 means the quarter run is not asymptotic: the slowest is assumed"


def test_the_extrapolated_estimate_is_exact_for_an_h3_error_and_errs_high_for_h4():
    """R(h) = (4 f(h) − f(2h))/3 removes the h² term; its error estimate from the runs at
    h, 2h, 4h and 8h is exact when an h³ term is left, at most 2.2× high when an h⁴ term
    is, and not trusted (infinite) when R converges at first order or its difference has
    vanished by chance."""
    def runs(error):
        return [[np.array([1.0 + 0.7 * h**2 + error(h)]), np.array([2.0, -1.0]) * (1.0 + error(h))]
                for h in (0.01, 0.02, 0.04, 0.08)]

    no_space = np.zeros(2)
    for error, low, high in ((lambda h: 3.0 * h**3, 1.0, 1.0), (lambda h: -40.0 * h**4, 1.0, 2.2)):
        fine, half, quarter, eighth = runs(error)
        est = extrapolated_estimate(fine, half, quarter, eighth, no_space)
        true = [abs(r - q) for r, q in zip(tolerance.richardson(fine, half), ([1.0], [2.0, -1.0]))]
        for e, t in zip(est.time, true):
            assert low * np.linalg.norm(t) <= e * (1 + 1e-9) and e <= high * np.linalg.norm(t) * (1 + 1e-9)
    first_order = extrapolated_estimate(*runs(lambda h: 0.5 * h), no_space)
    assert np.all(np.isinf(first_order.time)), "a contraction of 2: R is not asymptotic"
    fine, half, quarter, eighth = runs(lambda h: 3.0 * h**3)
    now, before = tolerance.richardson(fine, half)[0], tolerance.richardson(half, quarter)[0]
    chance = [fine[0] + 0.75 * (before - now) + 1e-12, fine[1]]  # R(h) − R(2h) nearly zero in d by chance
    assert np.isinf(extrapolated_estimate(chance, half, quarter, eighth, no_space).time[0])


def test_a_run_to_a_tolerance_extrapolates_where_that_is_the_more_accurate():
    """With an h³ term beside the h² one, the extrapolated values meet rtol at a quarter of
    the steps, their estimate never below their error; without extrapolation the same
    tolerance takes the steps the h² term needs."""
    values, _ = model_values(c_cubic=2.0, c_space=0.0)
    tol = Tolerance(["f"], np.array([1e-6]), np.array([0.0]))
    plain, _ = resolve(values, Discretization(1, 8), tol)
    d, est = resolve(values, Discretization(1, 8), tol, extrapolate=True)
    assert d.extrapolated and not plain.extrapolated and d.steps <= plain.steps // 4
    r = tolerance.richardson(values(d.grid), values(d.half_steps))[0][0]
    assert abs(r - 2.0) <= 1e-6 * 2.0 and est.total[0] >= abs(r - 2.0) * (1 - 1e-6)
    assert "extrapolated from half the steps" in str(d) and d.grid == replace(d, extrapolated=False)


def test_the_arm_extrapolated_meets_rtol_in_fewer_steps(arm, arm_references):
    """The full-density arm at rtol = 1e-2 with gradients: extrapolated, it passes with
    fewer steps than without, within rtol of the reference and its estimate not below
    half its error."""
    x = np.ones(arm.n_design)
    plain = arm.run_with_sensitivities(x, "tip_deflection", rtol=1e-2, extrapolate=False)
    out = arm.run_with_sensitivities(x, "tip_deflection", rtol=1e-2)
    assert out.discretization.extrapolated and out.discretization.steps < plain.discretization.steps
    error = abs(out.values[0] / arm_references[1.0] - 1)
    assert error <= 1e-2 and out.errors["tip_deflection"] >= error / 2


def test_failed_runs_refine_the_step_and_limits_give_a_named_error(monkeypatch):
    values, _ = model_values()

    def failing(d, companion=False):
        if d.steps and d.steps < 64:
            raise SimulationError("Newton did not converge")
        return values(d)

    d, _ = resolve(failing, Discretization(1, 8), Tolerance(["f"], np.array([1e-2]), np.array([0.0])))
    assert d.steps // 2 >= 64, "the candidate and its half-steps companion ran (a failed quarter run is not needed)"
    def always_failing(d, companion=False):
        raise SimulationError("Newton did not converge at t = 0.1 s")

    with pytest.raises(ToleranceError, match=r"the runs still fail after 3 refinements, at 1× the scene's elements per bar and 64 steps: "
                                             r"Newton did not converge at t = 0.1 s"):
        resolve(always_failing, Discretization(1, 8), Tolerance(["f"], np.array([1e-2]), np.array([0.0])))
    monkeypatch.setattr(tolerance, "MAX_STEPS", 256)
    with pytest.raises(ToleranceError, match="rtol = 1e-08 cannot be met for f: estimated relative error"):
        resolve(values, Discretization(1, 8), Tolerance(["f"], np.array([1e-8]), np.array([0.0])))


def test_the_candidates_judged_are_bounded_and_the_bound_named(monkeypatch):
    values, calls = model_values()
    monkeypatch.setattr(tolerance, "MAX_CANDIDATES", 2)
    with pytest.raises(ToleranceError, match="no discretization met the tolerance within 2 candidates"):
        resolve(values, Discretization(1, 8), Tolerance(["f"], np.array([1e-4]), np.array([0.0])))


def test_the_time_estimate_is_asymptotically_correct_on_the_arm():
    """x = 0.4 and 1, one element per bar: the ratio of the estimate to the true time
    error (against 4352 steps, Richardson-extrapolated) tends to 1 as h → 0, and it never
    understates the error by more than 2×."""
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    for x in (0.4, 1.0):
        d = {n: sim.run(x, h=T_ARM / n).tip_deflection() for n in (17, 34, 68, 136, 272, 544, 2176, 4352)}
        exact = d[4352] + (d[4352] - d[2176]) / 3
        ratios = [estimate([np.array([d[n]])], [np.array([d[n // 2]])], [np.array([d[n // 4]])], [np.array([d[n // 2]])]).time[0]
                  / abs(d[n] - exact) for n in (68, 136, 272, 544)]
        assert min(ratios) >= 0.5, ratios
        assert abs(ratios[-1] - 1) < 0.25, ratios


def test_rtol_1e2_gets_the_arm_within_1_percent(arm_references):
    sim = flextop.Simulation(flextop.scenes.robot_arm(), rtol=1e-2)
    for x, reference in arm_references.items():
        res = sim.run(x)
        error = abs(res.tip_deflection() / reference - 1)
        assert error <= 1e-2, (x, error, res.discretization)
        assert res.errors["tip_deflection"] >= error / 2, "the estimate does not understate the error"
        assert res.error_estimate("tip_deflection") == pytest.approx(res.errors["tip_deflection"])


def test_a_fixed_run_tells_when_it_is_wrong(arm_references):
    """The full-density arm at h = 0.02 s is 16 % off: its estimate says so."""
    res = flextop.Simulation(flextop.scenes.robot_arm()).run(1.0)
    error = abs(res.tip_deflection() / arm_references[1.0] - 1)
    assert error > 0.1 and res.error_estimate("tip_deflection") >= error
    assert res.discretization is None and res.errors == {}


@pytest.mark.parametrize("hold", [True, False])
def test_gradients_on_the_grid_that_ran_are_exact(hold):
    """Spun beam at rtol = 1e-2: direct equals adjoint, and fourth-order central differences
    on the frozen discretization agree (with the gradients held, of the grid's own values,
    ``extrapolate=False``; not held, of the extrapolated value, which the values alone
    choose there)."""
    sim = flextop.Simulation(flextop.scenes.spun_beam(), rtol=1e-2)
    x = np.linspace(0.9, 0.3, sim.n_design)
    options = {"hold_gradients": hold, "extrapolate": not hold}
    direct = sim.run_with_sensitivities(x, ["tip_deflection", "compliance"], method="direct", **options)
    adjoint = sim.run_with_sensitivities(x, ["tip_deflection", "compliance"], method="adjoint", **options)
    assert direct.discretization.extrapolated == (not hold)
    assert direct.discretization == adjoint.discretization
    assert direct.discretization.refinement > 1 or direct.discretization.steps > 120, "the scene's own grid is not enough"
    np.testing.assert_allclose(direct.gradients, adjoint.gradients, rtol=1e-9, atol=1e-9 * np.abs(direct.gradients).max())
    assert max(direct.errors.values()) <= 1e-2 and max(direct.gradient_errors.values(), default=0.0) <= 5e-2
    d = direct.discretization
    frozen, t_end = sim.levels.at(d, x), sim.spec["simulation"]["t_end"]
    extrapolated = lambda xx: (4 * frozen.run(xx, h=t_end / d.steps).tip_deflection()  # noqa: E731
                               - frozen.run(xx, h=2 * t_end / d.steps).tip_deflection()) / 3
    f = extrapolated if d.extrapolated else (lambda xx: frozen.run(xx, h=t_end / d.steps).tip_deflection())  # noqa: E731
    delta = 1e-3
    for i in range(sim.n_design):
        e = np.eye(sim.n_design)[i] * delta
        fd = (8 * (f(x + e) - f(x - e)) - (f(x + 2 * e) - f(x - 2 * e))) / (12 * delta)
        assert fd == pytest.approx(direct.gradients[0, i], rel=1e-6, abs=1e-6 * np.abs(direct.gradients[0]).max())


def test_gradients_not_held_are_those_of_the_grid_chosen_on_the_values():
    """hold_gradients=False: the grid is chosen on the values (never finer than when the
    gradients are held too), and the gradients are exactly that grid's."""
    sim = flextop.Simulation(flextop.scenes.spun_beam(), rtol=1e-2)
    x = np.linspace(0.9, 0.3, sim.n_design)
    held = sim.run_with_sensitivities(x, "tip_deflection")
    free = sim.run_with_sensitivities(x, "tip_deflection", hold_gradients=False)
    d = free.discretization
    assert d.refinement <= held.discretization.refinement and d.steps <= held.discretization.steps
    assert free.errors["tip_deflection"] <= 1e-2 and not free.gradient_errors
    on_grid = on_accepted_grid(sim, d, x, "tip_deflection", sim.spec["simulation"]["t_end"])
    np.testing.assert_array_equal(free.gradients, on_grid.gradients)
    np.testing.assert_array_equal(free.values, on_grid.values)


def test_static_scenes_refine_elements_only():
    sim = flextop.Simulation(flextop.scenes.static_truss(), rtol=1e-4)
    res = sim.run(0.4)
    reference = flextop.Simulation(flextop.scenes.static_truss(split=16)).run(0.4).response("compliance")
    assert res.discretization.steps == 0
    assert abs(res.response("compliance") / reference - 1) <= 1e-4
    assert res.error_estimate("compliance") == pytest.approx(res.errors["compliance"])


def test_topology_problem_refines_only_and_records_it():
    sim = flextop.Simulation(flextop.scenes.spun_beam())
    problem = flextop.TopologyProblem(sim, "tip_deflection", flextop.volume_constraints(sim, 0.5), rtol=1e-2)
    result = flextop.optimize(problem, np.full(sim.n_design, 0.5), method="mma", max_iter=4)
    assert problem.refinements and problem.refinements[0][0] == 1
    steps = [d for _, d in problem.refinements]
    assert all(a.refinement <= b.refinement and a.steps <= b.steps for a, b in zip(steps, steps[1:]))
    again = flextop.TopologyProblem.from_dict(sim, problem.to_dict())
    assert again.discretization == problem.discretization and again.rtol == 1e-2
    check = sim.run_with_sensitivities(result.x, "tip_deflection", rtol=1e-2)
    assert check.values[0] == pytest.approx(result.fun, rel=2e-2)


def test_bad_tolerances_are_named():
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    for bad in (0.0, 1.0, -1e-3, float("nan"), True):
        with pytest.raises(SettingsError, match="rtol"):
            sim.run(0.4, rtol=bad)
    with pytest.raises(SettingsError, match="atol"):
        flextop.Simulation(flextop.scenes.robot_arm(), rtol=1e-2, atol=-1.0)
    with pytest.raises(SettingsError, match="not both"):
        sim.run(0.4, rtol=1e-2, h=0.01)
    assert flextop.Simulation(flextop.scenes.robot_arm(), rtol=1e-2).run(0.4, h=0.02, t_end=0.1).discretization is None, \
        "an explicit step wins over the simulation's tolerance"


def test_local_error_control_from_python_with_exact_gradients_on_its_steps():
    """Spun beam with steps chosen to local_tol: the steps vary and end at t_end, direct
    equals adjoint, central differences on the frozen steps agree, and the run has an error
    estimate like any other."""
    sim = flextop.Simulation(flextop.scenes.spun_beam())
    x = np.linspace(0.9, 0.3, sim.n_design)
    res = sim.run(x, local_tol=1e-6)
    assert res.steps.min() < 0.5 * res.steps.max() and res.time[-1] == pytest.approx(0.6, abs=1e-12)
    direct = sim.run_with_sensitivities(x, "tip_deflection", method="direct", local_tol=1e-6)
    adjoint = sim.run_with_sensitivities(x, "tip_deflection", method="adjoint", local_tol=1e-6)
    np.testing.assert_array_equal(direct.steps, res.steps)
    np.testing.assert_allclose(direct.gradients, adjoint.gradients, rtol=1e-9, atol=1e-9 * np.abs(direct.gradients).max())
    assert direct.values[0] == pytest.approx(res.tip_deflection(), rel=1e-12)
    f = lambda xx: sim.run_fixed(xx, {}, steps=res.steps).tip_deflection()  # noqa: E731
    for i in (0, 4, 7):
        e = np.eye(sim.n_design)[i] * 1e-4
        fd = (f(x + e) - f(x - e)) / 2e-4
        assert fd == pytest.approx(direct.gradients[0, i], rel=1e-5, abs=1e-6 * np.abs(direct.gradients[0]).max())
    assert 0 < res.error_estimate("tip_deflection") < 0.05
    with pytest.raises(SettingsError, match="local_tol"):
        sim.run(x, local_tol=1e-6, rtol=1e-2)


def test_companions_stop_newton_early_and_the_candidate_does_not(arm):
    res = arm.run(0.4, rtol=1e-2)
    half, _, split = res.companions
    assert "tol" not in res.settings, "the candidate keeps the run's own Newton tolerance"
    assert half.settings["tol"] == split.settings["tol"] == tolerance.companion_newton_tol(1e-2) == 1e-6
    tight = arm.run(0.4, h=half.raw["h"])
    assert abs(half.tip_deflection() / tight.tip_deflection() - 1.0) < 1e-5, "a thousand times below the rtol the estimate serves"
    assert half.newton["total"] < tight.newton["total"]


def test_companions_run_modified_newton_guided_and_fall_back_to_plain_runs(monkeypatch):
    """The companions run modified Newton and the space companion is guided by the time
    companion's states; where that fails, the plain run (full Newton, no guide) decides,
    so the accepted grid and its estimate are those of plain companions."""
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    res = sim.run(0.4, rtol=1e-2)
    half, _, split = res.companions
    assert half.settings["newton"] == split.settings["newton"] == "modified" and "newton" not in res.settings
    fixed = flextop.Simulation.run_fixed

    def failing_when_guided(self, xv, settings, **kwargs):
        if kwargs.get("guide") is not None or settings.get("newton") == "modified":
            raise SimulationError("Newton failed at t = 0.1 s (a guide that misled it)")
        return fixed(self, xv, settings, **kwargs)

    monkeypatch.setattr(flextop.Simulation, "run_fixed", failing_when_guided)
    plain = flextop.Simulation(flextop.scenes.robot_arm()).run(0.4, rtol=1e-2)
    assert plain.discretization == res.discretization
    assert plain.errors["tip_deflection"] == pytest.approx(res.errors["tip_deflection"], rel=1e-3)  # Newton at 1e-6
    assert "newton" not in plain.companions[2].settings


def test_a_time_error_clearly_over_budget_is_judged_without_a_space_error():
    """The candidate is refined on its time error alone; the estimate it reports (and a
    ToleranceError would quote) holds no space error, since no space companion ran."""
    values, calls = model_values(c_time=50.0, c_space=0.002)
    verdict = tolerance._judge(values, Discretization(1, 8), Tolerance(["f"], np.array([1e-3]), np.array([0.0])))
    assert verdict.worst_space == 0.0 and verdict.estimate.space[0] == 0.0 and verdict.worst_time > 2.0
    assert all(d.uniform == 1 for d in calls), "the space companion did not run"


def _rod(force):
    """A clamped bar loaded along its axis at its end: in tension no bar can buckle."""
    s = flextop.Scene("rod", analysis="static")
    s.section("s", E=70e9, nu=0.3, rho=2700.0, diameter=0.02)
    s.node("a", 0.0, 0.0)
    s.node("b", 1.0, 0.0)
    s.beam("a", "b", section="s", name="ab")
    s.clamp("c", "a")
    s.load("b", force=force)
    s.design(interpolation="simp", p=3.0)
    return flextop.Simulation(s).run(1.0)


def test_a_response_of_value_zero_has_no_relative_error_but_an_absolute_one():
    """error_estimate("buckling") returned inf where the value was 0."""
    tension, compression = _rod((1000.0, 0.0)), _rod((-1000.0, 0.0))
    assert tension.response("buckling") == 0.0 and compression.response("buckling") > 0.0
    assert tension.error_estimate("buckling") == 0.0  # 0 of 0: both companions agree exactly
    tension.companions = (None, None, compression)  # a companion that disagrees with the zero
    with pytest.raises(SettingsError, match=r"response 'buckling' is 0 on this run, so it has no relative error; "
                                            r"its estimated absolute error is 0\.369"):
        tension.error_estimate("buckling")
    absolute = tension.error_estimate("buckling", absolute=True)
    assert absolute > 0.0
    assert absolute == estimate([np.zeros(1)], None, None, [np.array([compression.response("buckling")])]).total[0]


def test_a_failed_companion_is_named_as_the_companion(monkeypatch):
    """A run that succeeded had its estimate fail with the coarser companion's "use a smaller
    step"; the failure now says that the run succeeded and which companion failed."""
    sim = flextop.Simulation(flextop.scenes.spun_beam())
    res = sim.run(1.0, t_end=0.1)
    fixed = sim.run_fixed

    def coarse_fails(xv, settings, **kw):
        if kw.get("steps") is not None:
            raise SimulationError("Newton did not converge at t = 0.02 s; use a smaller step h")
        return fixed(xv, settings, **kw)

    monkeypatch.setattr(sim, "run_fixed", coarse_fails)
    with pytest.raises(SimulationError, match=r"the error cannot be estimated: the run succeeded, but its companion on "
                                              r"its steps merged in pairs failed \(Newton did not converge"):
        res.error_estimate("tip_deflection")


def test_the_adjoint_time_errors_are_read_only_where_they_agree_with_the_half_steps():
    """``agreed_time``: within 2/3–3/2 of ``(f(2h) − f(h))/3`` the values' errors are the larger
    of the two readings, a gradient's ``a/2``, a first-order quantity's (a peak's) ``2a``;
    outside the band, or of the other sign, none."""
    fine = [np.array([1.0]), np.array([3.0, 4.0]), np.array([5.0])]
    half = [np.array([1.3]), np.array([3.0, 4.5]), np.array([5.2])]  # a = 0.3, 0.5, 0.2
    orders = np.array([2.0, 2.0, 1.0])
    time = tolerance.agreed_time(fine, half, np.array([0.12]), orders)
    assert time == pytest.approx([0.12, 0.25, 0.4])
    assert tolerance.agreed_time(fine, half, np.array([0.08]), orders)[0] == pytest.approx(0.1), "a/3 where the larger"
    for disagreeing in (0.06, 0.16, -0.1, np.nan):
        assert tolerance.agreed_time(fine, half, np.array([disagreeing]), orders) is None, disagreeing


def test_agreeing_adjoint_errors_judge_a_candidate_without_the_quarter_and_eighth_runs():
    """Where the adjoint's errors agree with the half steps, a candidate is judged raw on them:
    the same candidate accepted as by step doubling, its error within rtol, and neither the
    runs at 4h and 8h nor an extrapolation made; where they disagree (the wrong sign, as
    before the asymptotic range), the rule is step doubling's."""
    tol = Tolerance(["f"], np.array([1e-3]), np.array([0.0]))
    values, _ = model_values(c_time=0.3, c_space=0.0)
    seen = []

    def recorded(d, companion=False):
        seen.append((d, companion))
        return values(d, companion)

    first = Discretization(1, 16)
    plain, _ = resolve(recorded, first, tol, extrapolate=True)
    assert (first.quarter_steps, True) in seen, "step doubling reads the quarter steps"
    seen.clear()
    exact = lambda d: np.array([0.3 * (1.0 / d.steps) ** 2])  # noqa: E731
    d, est = resolve(recorded, first, tol, extrapolate=True, adjoint=exact)
    assert d == plain and not d.extrapolated and abs(values(d)[0][0] - 2.0) <= 1e-3 * 2.0
    assert est.time[0] == pytest.approx(exact(d)[0], rel=1e-6)
    assert {c for c, _ in seen} == {d, d.half_steps, d.split, d.split_twice}, \
        "the candidate, its half steps and its space companions (confirmed below rtol 1e-2)"
    seen.clear()
    wrong, _ = resolve(recorded, first, tol, extrapolate=True, adjoint=lambda d: -exact(d))
    assert wrong == plain and (first.quarter_steps, True) in seen


def test_step_doubling_never_believes_a_time_error_below_the_adjoints_that_agreed():
    """f = 1 + C/n² + 1e-4/r² judged at 64 steps to rtol 1.2e-3 with adjoint estimates 1.1 and
    1.3 times the true time error, both agreeing with the half steps: the first fails raw
    (time and space over budget) and so must the second, whose larger reading sent it to
    step doubling's estimate — which read less (a/3 at the quarter steps' contraction) and,
    believed, would have passed it."""
    c = 1e-3 * 64**2

    def values(d, companion=False):
        return [np.array([1.0 + c / d.steps**2 + 1e-4 / (d.refinement * d.uniform) ** 2])]

    tol = tolerance.tolerance_of(["f"], 1.2e-3, 0.0, gradients=False)
    for k in (1.1, 1.3):
        verdict = tolerance._judge(values, Discretization(1, 64), tol, False, lambda d: np.array([k * c / d.steps**2]))
        assert not verdict.passed and verdict.estimate.time[0] >= k * c / 64**2 * (1 - 1e-12), k


def test_a_space_error_over_budget_on_settled_steps_skips_the_candidates_own_runs():
    """After a candidate whose time error was within half the budget, one refined in space only
    on the same steps whose space companion alone is over budget cannot pass: it is refined
    again without its own run (nor its quarter and eighth steps); the run accepted meets
    rtol."""
    tol = Tolerance(["f"], np.array([1e-3]), np.array([0.0]))
    seen = []
    values, _ = model_values(c_time=1e-4, c_space=0.01)

    def recorded(d, companion=False):
        seen.append((d, companion))
        return values(d, companion)

    d, est = resolve(recorded, Discretization(1, 8), tol)
    assert abs(values(d)[0][0] - 2.0) <= 1e-3 * 2.0
    candidates = {replace(c, steps=2 * c.steps, uniform=1) for c, _ in seen if c.uniform == 2}  # whose space companion ran
    skipped = [c for c in candidates if (c, False) not in seen]
    assert skipped and all(c.refinement < d.refinement and c.steps == d.steps for c in skipped)


def test_a_static_scenes_candidates_run_once_each():
    """No steps, so no time error to settle: each candidate of an equilibrium runs once, at
    the run's own tolerance, and its space companion once (the space-first judgement is a
    motion's)."""
    seen = []

    def values(d, companion=False):
        seen.append((d, companion))
        return [np.array([1.0 + 0.05 / (d.refinement * d.uniform) ** 2])]

    d, _ = resolve(values, Discretization(1, 0), Tolerance(["f"], np.array([1e-3]), np.array([0.0])))
    assert d.refinement > 2 and len(seen) == len(set(seen))
    assert not any(companion and c.uniform == 1 for c, companion in seen), "no candidate made again as a companion"


def test_a_run_with_adjoint_gradients_carries_its_time_errors(arm):
    """The adjoint sweep that makes a run's gradients estimates its time errors too, the same
    numbers as ``time_errors``; the direct method makes none."""
    x = np.random.default_rng(3).uniform(0.1, 1.0, arm.n_design)
    names = ["tip_deflection", "strain_energy"]
    out = arm.run_with_sensitivities(x, names, h=T_ARM / 136, method="adjoint")
    alone = arm.time_errors(x, names, steps=136)
    assert out.time_errors == pytest.approx([alone[n][1] for n in names], rel=1e-12)
    assert arm.run_with_sensitivities(x, names, h=T_ARM / 136, method="direct").time_errors is None
    with pytest.raises(SettingsError, match="time_estimate"):
        arm.run_with_sensitivities(x, names, rtol=1e-2, time_estimate="richardson")
