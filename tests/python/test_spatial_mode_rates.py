"""The rates of a spatial structure's natural modes to its parameters and densities, about
its unloaded reference: ``∂ω²/∂p = φᵀ(∂K − ω² ∂M)φ`` against fourth-order differences of
scenes rebuilt with the parameter moved, for a material's ``E`` and ``rho``, a rectangle's and
a tube's sizes, a body's mass and inertia entries and the beams' densities; in a cluster of
equal frequencies (a round tube's two bending planes), the cluster's sum. Parameters a
mode's rate is not built for are named."""

import copy

import numpy as np
import pytest

from flextop import SettingsError, SimulationError, SpatialScene, SpatialSimulation

MODES = 6


def frame(stay: bool = False) -> dict:
    """An L-shaped frame clamped at its root: an aluminium blade (12 × 30 mm) along x, then
    a steel tube (25/19 mm) along y, a 0.8 kg body with products of inertia at its end (held
    by a spring to the ground with ``stay``); no gravity, no load: its reference is its
    equilibrium, and every frequency is simple."""
    scene = SpatialScene("frame", analysis="static")
    scene.section("blade", E=7e10, rho=2700.0, nu=0.33, shape="rectangle", width=0.012, height=0.03)
    scene.section("tube", E=2.1e11, rho=7850.0, nu=0.3, shape="tube", outer=0.025, inner=0.019)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("corner", (0.5, 0.0, 0.0))
    scene.node("end", (0.5, 0.4, 0.0))
    scene.beam("arm", "root", "corner", section="blade", split=3, up=(0.0, 1.0, 0.3))
    scene.beam("fore", "corner", "end", section="tube", split=3)
    scene.rigid_body("weight", mass=0.8, inertia=(2e-3, 1e-3, 2.5e-3), products=(3e-4, -2e-4, 1e-4),
                     position=(0.5, 0.45, 0.02), points={"hub": (0.0, -0.05, -0.02)})
    scene.weld("clamp", "ground", "root")
    scene.weld("mount", "end", "weight.hub")
    if stay:
        scene.spring("stay", "weight", (0.5, 0.45, -0.3), k=100.0)
    return scene.to_dict()


def moved(spec: dict, name: str, by: float) -> dict:
    """``spec`` with parameter ``name`` moved by ``by``."""
    changed = copy.deepcopy(spec)
    kind, what = name.split(":")
    if what in ("arm", "fore"):
        section = {"arm": "blade", "fore": "tube"}[what]
        changed["sections"][section][kind] += by
    else:
        body = next(b for b in changed["rigid_bodies"] if b["name"] == what)
        entry = {"mass": ("mass", None), "Ixx": ("inertia", 0), "Iyy": ("inertia", 1), "Ixy": ("products", 0),
                 "Iyz": ("products", 2)}[kind]
        if entry[1] is None:
            body["mass"] += by
        else:
            body[entry[0]][entry[1]] += by
    return changed


def lowest(spec: dict, x=None) -> np.ndarray:
    return SpatialSimulation(spec).modes(x).omega_squared[:MODES]


PARAMETERS = {"E:arm": 7e10, "rho:fore": 7850.0, "width:arm": 0.012, "height:arm": 0.03, "outer:fore": 0.025,
              "inner:fore": 0.019, "mass:weight": 0.8, "Ixx:weight": 2e-3, "Iyy:weight": 1e-3, "Ixy:weight": 3e-4,
              "Iyz:weight": 1e-4}


def test_mode_rates_against_differences_of_rebuilt_scenes():
    spec = frame()
    x = np.array([0.7, 0.5])
    modes = SpatialSimulation(spec).modes(x, parameters=list(PARAMETERS))
    w2 = modes.omega_squared[:MODES]
    assert np.all(np.diff(w2) > 1e-2 * w2[1:])  # simple
    for j, (name, value) in enumerate(PARAMETERS.items()):
        delta = 1e-3 * value
        runs = [lowest(moved(spec, name, k * delta), x) for k in (-2, -1, 1, 2)]
        fd = (runs[0] - 8 * runs[1] + 8 * runs[2] - runs[3]) / (12 * delta)
        exact = modes.omega_squared_gradient[:MODES, j]
        assert np.allclose(exact, fd, rtol=1e-6, atol=1e-7 * np.abs(w2 / value).max()), (name, exact, fd)
    for i in range(2):
        delta = 1e-3
        runs = [lowest(spec, x + k * delta * np.eye(2)[i]) for k in (-2, -1, 1, 2)]
        fd = (runs[0] - 8 * runs[1] + 8 * runs[2] - runs[3]) / (12 * delta)
        assert np.allclose(modes.omega_squared_dfdx[:MODES, i], fd, rtol=1e-6, atol=1e-7 * w2.max()), i


def test_a_clusters_sum_has_the_sum_of_its_rates():
    """A round tube's cantilever bends alike in both planes: each pair's sum moves as the sum
    of its two rates, whichever two shapes the solver picked in the pair."""
    scene = SpatialScene("tube", analysis="static")
    scene.section("tube", E=2.1e11, rho=7850.0, nu=0.3, shape="tube", outer=0.025, inner=0.019)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (0.8, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="tube", split=6)
    scene.weld("clamp", "ground", "root")
    spec = scene.to_dict()
    modes = SpatialSimulation(spec).modes(parameters=["outer:rod"])
    w2 = modes.omega_squared
    assert w2[1] == pytest.approx(w2[0], rel=1e-9)
    delta = 1e-3 * 0.025

    def pair(k: float) -> float:
        changed = copy.deepcopy(spec)
        changed["sections"]["tube"]["outer"] += k * delta
        return float(SpatialSimulation(changed).modes().omega_squared[:2].sum())

    fd = (pair(-2) - 8 * pair(-1) + 8 * pair(1) - pair(2)) / (12 * delta)
    assert modes.omega_squared_gradient[:2, 0].sum() == pytest.approx(fd, rel=1e-6)


def test_rates_a_mode_lacks_are_named():
    with pytest.raises(SettingsError, match="not built"):
        SpatialSimulation(frame(stay=True)).modes(parameters=["k:stay"])
    with pytest.raises(SettingsError, match="nothing"):
        SpatialSimulation(frame()).modes(parameters=["width:nothing"])
    with pytest.raises(SettingsError, match="'rst' is neither an equilibrium nor \"rest\""):
        SpatialSimulation(frame()).modes(at="rst")
    preloaded = frame(stay=True)
    preloaded["springs"][0]["length"] = 0.1
    with pytest.raises(SimulationError, match="at rest .* a preloaded spring holds it elsewhere.*not an equilibrium"):
        SpatialSimulation(preloaded).modes(at="rest")


def test_a_frequency_floor_at_rest_has_exact_gradients_and_holds_after_mma():
    """The lattice cantilever's energy at 30 % of its volume with its lowest frequency at rest
    (its loads taken away) held at or above 1.15× the unconstrained optimum's: the floor's
    constraint ``1 − KS/f_min`` has the gradient of fourth-order differences of the problem
    at a random design, and MMA's design holds the floor (measured: the unconstrained optimum
    at 2.66 Hz, near-void bars' own modes; the floor's after 150 iterations at 3.12 Hz,
    KKT residual 3e-4, its energy within 0.01 % of the unconstrained one's)."""
    from conftest import lattice_cantilever
    from flextop import optimize
    from flextop.problems import SpatialProblem

    sim = SpatialSimulation(lattice_cantilever())
    free = optimize(SpatialProblem(sim, "strain_energy", volume=0.3), np.full(sim.n_design, 0.3), "mma", max_iter=100,
                    kkt_tol=1e-4)
    assert free.success
    floor = 1.15 * sim.modes(free.x, at="rest", count=2).frequencies[0]
    problem = SpatialProblem(sim, "strain_energy", [("min_frequency", floor)], volume=0.3)
    assert problem.names[0].startswith("min_frequency ≥")
    x = np.random.default_rng(3).uniform(0.3, 1.0, sim.n_design)
    e = problem.evaluate(x)
    noise = 1e-11 * abs(e.g[0]) / 1e-4  # the frequencies' round-off over the step
    for i in np.argsort(-np.abs(e.dg[0]))[:3]:  # the bars the floor reads most
        delta = 1e-4

        def g(k: float, i=i) -> float:
            moved = x.copy()
            moved[i] += k * delta
            return problem.evaluate(moved).g[0]

        fd = (g(-2) - 8 * g(-1) + 8 * g(1) - g(2)) / (12 * delta)
        assert abs(fd) > 1e3 * noise and e.dg[0, i] == pytest.approx(fd, rel=1e-6, abs=noise), i
    result = optimize(problem, np.full(sim.n_design, 0.3), "mma", max_iter=150, kkt_tol=1e-4)
    f = sim.modes(result.x, at="rest", count=2).frequencies
    assert f[0] >= floor and sim.volume(result.x) <= 0.3 * sim.volume(1.0) * (1 + 1e-6)
