"""Natural frequencies: closed-form Timoshenko beams, the arm against its converged structure
whatever the elements per bar, the Sturm proof, exact design derivatives (simple and
repeated frequencies)."""

import numpy as np
import pytest
from scipy.optimize import brentq

import flextop
from flextop.discretization.accuracy import split_by
from flextop.errors import SettingsError
from flextop.modal import ks_lowest

from conftest import cantilever

E, NU, RHO, D = 70e9, 0.32, 2700.0, 0.02
G = E / (2 * (1 + NU))
A, I = np.pi * D**2 / 4, np.pi * D**4 / 64
KAPPA = 6 * (1 + NU) / (7 + 6 * NU)


def timoshenko_frequencies(length: float, count: int, end: str = "free") -> np.ndarray:
    """Bending frequencies (Hz) of a Timoshenko beam with rotary inertia, clamped at x = 0
    and ``free`` or ``clamped`` at x = L.

    Harmonic solutions ``w = Σ C f(x)`` with ``f ∈ {cosh αx, sinh αx, cos βx, sin βx}``,
    where ``α² = S₁ > 0`` and ``−β² = S₂ < 0`` are the roots of
    ``κGA·EI S² + ω²(κGA ρI + ρA EI) S + ρAω²(ρIω² − κGA) = 0``; the rotation follows from
    ``ψ' = w'' + (ρAω²/κGA) w``. The end conditions (clamped: w = ψ = 0; free: ψ' = 0,
    w' − ψ = 0) give a 4×4 determinant whose sign changes bracket the frequencies.
    """
    kga, ei, ra, ri = KAPPA * G * A, E * I, RHO * A, RHO * I

    def det(omega):
        w2 = omega**2
        S = np.roots([kga * ei, w2 * (kga * ri + ra * ei), ra * w2 * (ri * w2 - kga)])
        alpha, beta = np.sqrt(S.max()), np.sqrt(-S.min())
        c = ra * w2 / kga
        a, b = (alpha**2 + c) / alpha, (c - beta**2) / beta  # ψ coefficients
        L = length
        ch, sh, co, si = np.cosh(alpha * L), np.sinh(alpha * L), np.cos(beta * L), np.sin(beta * L)
        # columns: cosh, sinh, cos, sin;  w, ψ = a·(sinh, cosh) + b·(sin, −cos)
        clamped_root = [[1.0, 0.0, 1.0, 0.0], [0.0, a, 0.0, -b]]  # w(0), ψ(0)
        if end == "free":
            far = [[(alpha**2 + c) * ch, (alpha**2 + c) * sh, (c - beta**2) * co, (c - beta**2) * si],  # ψ'(L)
                   [alpha * sh - a * sh, alpha * ch - a * ch, -beta * si - b * si, beta * co + b * co]]  # w'(L) − ψ(L)
        else:
            far = [[ch, sh, co, si], [a * sh, a * ch, b * si, -b * co]]  # w(L), ψ(L)
        m = np.array(clamped_root + far)
        return np.linalg.det(m / np.abs(m).max(axis=1, keepdims=True)) / np.cosh(alpha * L)

    grid = np.linspace(1.0, 2 * np.pi * 8000.0, 40000)
    values = [det(w) for w in grid]
    roots = [brentq(det, grid[i], grid[i + 1], xtol=1e-12) for i in range(len(grid) - 1) if values[i] * values[i + 1] < 0]
    return np.array(roots[:count]) / (2 * np.pi)


def test_timoshenko_reference_reduces_to_euler_bernoulli_when_slender():
    eb = np.sqrt(E * I / (RHO * A * 4.0**4)) / (2 * np.pi)
    assert timoshenko_frequencies(4.0, 1)[0] == pytest.approx(1.8751040687**2 * eb, rel=1e-4)
    # Shear and rotary inertia lower the clamped–clamped beam by about λ²(r/L)²(1 + E/κG)/2.
    assert timoshenko_frequencies(4.0, 1, "clamped")[0] == pytest.approx(4.7300407449**2 * eb, rel=3e-4)


def clamped_clamped(length: float, split: int) -> flextop.Scene:
    """Static, since a structure clamped twice over-constrains any rigid motion."""
    scene = cantilever(length, split, analysis="static")
    scene.clamp("far", "tip")
    return scene


@pytest.mark.parametrize("end", ["free", "clamped"])
@pytest.mark.parametrize("length", [1.0, 0.25])
def test_beam_frequencies_match_timoshenko_theory_from_one_element(length, end):
    """One element in the scene; the eigen-analysis refines until 1e-5 and meets theory."""
    exact = timoshenko_frequencies(length, 3, end)
    scene = cantilever(length, split=1) if end == "free" else clamped_clamped(length, split=1)
    modes = flextop.Simulation(scene).modes(3, rtol=1e-5)
    np.testing.assert_allclose(modes.frequencies, exact, rtol=2e-5)
    # The estimate is the error, neither far above nor below it.
    true = np.abs(modes.frequencies / exact - 1)
    assert np.all(true <= 2 * modes.errors) and np.all(modes.errors <= 2 * true), (true, modes.errors)
    # The model as meshed converges to the same at second order in the element length.
    errors = [abs(flextop.Simulation(cantilever(length, split=m)).modes(1, rtol=None).frequencies[0] / exact[0] - 1)
              for m in (8, 16)] if end == "free" else None
    if errors is not None:
        assert 3.5 < errors[0] / errors[1] < 4.5, errors


@pytest.fixture(scope="module")
def arm_designs(arm):
    n = arm.n_design
    return {"x = 0.4": np.full(n, 0.4), "full density": np.ones(n),
            "seeded random": np.random.default_rng(7).uniform(0.05, 1.0, n)}


@pytest.fixture(scope="module")
def arm_converged(arm, arm_designs):
    """The lowest eight frequencies at 64× and 128× the elements per bar, extrapolated."""
    out = {}
    for name, x in arm_designs.items():
        fine, coarse = (arm.levels[r].modes(8, x, rtol=None).frequencies for r in (128, 64))
        out[name] = fine + (fine - coarse) / 3
    return out


@pytest.mark.parametrize("split", [1, 2])
@pytest.mark.parametrize("design", ["x = 0.4", "full density", "seeded random"])
def test_arm_frequencies_meet_the_tolerance_whatever_the_elements_per_bar(design, split, arm_designs, arm_converged):
    sim = flextop.Simulation(flextop.scenes.robot_arm(split=split))
    modes = sim.modes(6, arm_designs[design], rtol=1e-3)
    exact = arm_converged[design]
    np.testing.assert_allclose(modes.frequencies, exact[:6], rtol=1e-3)
    # None is missing: the list matches the converged one term by term, and at the finest
    # level the Sturm count proves that the modes found are all those below the bound.
    assert modes.below >= 6 and modes.frequencies[5] < modes.bound
    # The model as meshed misses the bars' own modes.
    if split == 1:
        meshed = sim.modes(6, arm_designs[design], rtol=None).frequencies
        assert np.abs(meshed / exact[:6] - 1).max() > 0.5


def test_frequency_gradients_pass_fourth_order_differences():
    """The modes of the model as meshed, differentiated exactly, against 4th-order central
    differences; the tolerance path returns the same combination of levels' gradients."""
    sim = flextop.Simulation(flextop.scenes.robot_arm(split=2))
    x = np.random.default_rng(3).uniform(0.1, 1.0, sim.n_design)
    modes = sim.modes(4, x, rtol=None)
    h = 1e-3
    for i in (0, 40, 100):
        f = {}
        for k in (-2, -1, 1, 2):
            xk = x.copy()
            xk[i] += k * h
            f[k] = sim.modes(4, xk, rtol=None).frequencies
        fd = (f[-2] - 8 * f[-1] + 8 * f[1] - f[2]) / (12 * h)
        np.testing.assert_allclose(modes.gradients[:, i], fd, rtol=1e-6, atol=1e-6 * modes.frequencies.max())


def twin_cantilevers(split: int = 4) -> flextop.Scene:
    """Two identical cantilevers with a design variable each: every frequency is double."""
    scene = flextop.Scene("twins")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    for k, y in enumerate((0.0, 0.5)):
        scene.node(f"root{k}", 0.0, y)
        scene.node(f"tip{k}", 0.8, y)
        scene.beam(f"root{k}", f"tip{k}", section="al", split=split, name=f"arm{k}", group=f"arm{k}")
        scene.clamp(f"clamp{k}", f"root{k}")
    return scene


def test_a_double_frequency_has_a_well_defined_ks_derivative():
    sim = flextop.Simulation(twin_cantilevers())
    assert sim.n_design == 2
    x = np.array([0.6, 0.6])
    modes = sim.modes(4, x, rtol=None)
    assert modes.frequencies[1] == pytest.approx(modes.frequencies[0], rel=1e-9)
    scale = modes.frequencies[0]
    ks, grad = ks_lowest(modes, scale)
    assert modes.frequencies[0] - scale * np.log(4) / 50 <= ks <= modes.frequencies[0]
    for direction in (np.array([1.0, 0.0]), np.array([0.3, -1.0]), np.array([1.0, 1.0])):
        h = 1e-4
        up, down = (ks_lowest(sim.modes(4, x + s * h * direction, rtol=None), scale)[0] for s in (1, -1))
        assert grad @ direction == pytest.approx((up - down) / (2 * h), rel=1e-6)


def test_bad_requests_are_named():
    sim = flextop.Simulation(cantilever(1.0, split=2))
    with pytest.raises(SettingsError, match="n: the number of frequencies"):
        sim.modes(0)
    with pytest.raises(SettingsError, match="n: must be between 1 and 6, the modes the structure has"):
        sim.modes(50, rtol=None)
    with pytest.raises(SettingsError, match="n: the number of frequencies must be an integer from 1 to 200"):
        sim.modes(201)
    with pytest.raises(SettingsError, match="rtol"):
        sim.modes(2, rtol=0.0)
    free = flextop.Scene("free")
    free.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    free.node("a", 0.0, 0.0)
    free.node("b", 1.0, 0.0)
    free.beam("a", "b", section="al", split=2)
    free.pin("pin", "a")
    modes = flextop.Simulation(free).modes(2, rtol=None)
    assert modes.frequencies[0] < 1e-3 * modes.frequencies[1]  # the free rotation about the pin


def test_the_frequency_floor_constraint_has_exact_gradients():
    """``("min_frequency", f_min)`` in a TopologyProblem: g = 1 − KS/f_min, its gradient
    against central differences along a direction, and its value in Hz."""
    from flextop.problems import MIN_FREQUENCY, TopologyProblem, volume_constraints

    sim = flextop.Simulation(flextop.scenes.robot_arm())
    problem = TopologyProblem(sim, "tip_deflection", [*volume_constraints(sim, 0.4), (MIN_FREQUENCY, 2.5)])
    rng = np.random.default_rng(11)
    x = rng.uniform(0.3, 0.6, sim.n_design)
    d = rng.normal(size=sim.n_design)
    d /= np.linalg.norm(d)
    evaluation = problem.evaluate(x)
    # Fourth-order differences with a wide step: at 32× the elements per bar the values
    # carry round-off of about 1e-9 relative (the refined stiffness is ill-conditioned).
    h = 1e-2
    g = {k: problem.evaluate(x + k * h * d).g[-1] for k in (-2, -1, 1, 2)}
    fd = (g[-2] - 8 * g[-1] + 8 * g[1] - g[2]) / (12 * h)
    assert evaluation.dg[-1] @ d == pytest.approx(fd, rel=2e-5)
    _, constrained, _ = problem.physical(evaluation)
    from flextop.problems import FLOOR_MODES, FLOOR_RHO, FLOOR_RTOL

    lowest = sim.modes(FLOOR_MODES, x, rtol=FLOOR_RTOL).frequencies[0]
    assert lowest - 2.5 * np.log(FLOOR_MODES) / FLOOR_RHO <= constrained[-1] <= lowest


def test_a_crowd_of_identical_void_bars_is_solved_exactly():
    """At x = x_min every bar's own modes repeat across the bars of equal length: crowded,
    near-repeated frequencies (faer's Lanczos never returned on such a spectrum). The
    engine's lowest twelve at 2 elements per bar agree with a dense solve of the same
    matrices, and the Sturm count covers them."""
    import scipy.linalg as la

    sim = flextop.Simulation(flextop.scenes.robot_arm(split=2))
    modes = sim.modes(12, sim.x_min, rtol=None)
    M, K, G = sim.linearize(sim.x_min)
    basis = la.null_space(G.toarray())
    eig = la.eigh(basis.T @ (K @ basis), basis.T @ (M @ basis), eigvals_only=True, subset_by_index=[0, 11])
    dense = np.sqrt(eig) / (2 * np.pi)
    np.testing.assert_allclose(modes.frequencies[2:], dense[2:], rtol=1e-8)
    # The two near-mechanism modes (0.01 and 0.04 Hz, λ ≪ the stiffness scale), where the
    # dense solve itself loses digits to the conditioning.
    np.testing.assert_allclose(modes.frequencies[:2], dense[:2], rtol=1e-4)
    assert np.min(np.diff(dense[2:]) / dense[3:]) < 1e-3  # the crowd is there
    assert modes.below >= 12 or modes.frequencies[modes.below - 1] < modes.bound < modes.frequencies[modes.below]
