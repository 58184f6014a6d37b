"""Gradients of spatial mechanisms to the sizes of their beams' sections: a circle's
``diameter``, a tube's ``outer`` and ``inner`` diameters, a rectangle's ``width`` and
``height``, on frame beams and on a truss bar. Over a driven motion (every response,
the tip's deflection from its rigid trajectory, the stresses whose points move with the
section and the buckling ratios whose Euler loads do included) and at an equilibrium, against fourth-order differences of scenes
rebuilt with the size changed and direct against adjoint; a cantilever's tip deflection
against Timoshenko's closed form's derivative. Sizes a section does not have are refused."""

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

from flextop import SettingsError, SpatialScene, SpatialSimulation
from flextop.scenes import trapezoidal

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

# Each beam's section, by the beam: (section name, its dimensions).
SIZES = {
    "upper": ("tube", {"outer": 0.02, "inner": 0.016}),
    "fore": ("blade", {"width": 0.004, "height": 0.012}),
    "tail": ("rod", {"diameter": 0.006}),
    "stay": ("wire", {"diameter": 0.003}),
}

RESPONSES = ["strain_energy", "kinetic_energy", "x:end", "z:end", "tip_deflection", "stress", "stress:fore:q=0"]


def arm() -> dict:
    """A driven hinge on an oblique axis swinging a frame of a tube and a blade, a truss
    stay across them and a solid tail carrying 0.2 kg, under gravity: the tip leaves
    every plane, every beam bends, twists and stretches."""
    scene = SpatialScene("sizes", gravity=(0.0, 0.0, -9.81))
    scene.section("tube", E=7e10, rho=2700.0, nu=0.33, shape="tube", **SIZES["upper"][1])
    scene.section("blade", E=2.1e11, rho=7850.0, nu=0.3, shape="rectangle", **SIZES["fore"][1])
    scene.section("rod", E=2.1e11, rho=7850.0, nu=0.3, **SIZES["tail"][1])
    scene.section("wire", E=2.1e11, rho=7850.0, nu=0.3, **SIZES["stay"][1])
    for name, at in [("root", (0.0, 0.0, 0.0)), ("elbow", (0.3, 0.0, 0.0)), ("tip", (0.5, 0.1, 0.05)),
                     ("end", (0.6, 0.1, -0.05))]:
        scene.node(name, at)
    scene.beam("upper", "root", "elbow", section="tube", split=2)
    scene.beam("fore", "elbow", "tip", section="blade", split=2, up=(0.0, 0.3, 1.0))
    scene.beam("tail", "tip", "end", section="rod")
    scene.beam("stay", "root", "tip", section="wire", kind="truss")
    scene.point_mass("load", "end", 0.2)
    scene.revolute("hinge", "ground", "root", axis=(0.2, 0.3, 1.0),
                   drive=trapezoidal(0.0, 1.0, acceleration=30.0, speed=5.0))
    scene.tip = "end"
    scene.simulation(t_end=0.3, h=0.005, rho_inf=0.8)
    return scene.to_dict()


def resized(spec: dict, beam: str, kind: str, by: float) -> dict:
    changed = copy.deepcopy(spec)
    changed["sections"][SIZES[beam][0]][kind] += by
    return changed


def assert_exact(spec: dict, responses: list[str], step: float = 1e-3, x=None) -> None:
    """Direct = adjoint to 1e-9, fourth-order differences (a step of ``step`` of each size)
    to 1e-6 beside their noise (values reproducible to 1e-10 over the step)."""
    parameters = [(beam, kind) for beam, (_, dims) in SIZES.items() for kind in dims]
    names = [f"{kind}:{beam}" for beam, kind in parameters]
    sim = SpatialSimulation(spec)
    direct = sim.run_with_sensitivities(x, responses, names, method="direct")
    adjoint = sim.run_with_sensitivities(x, responses, names, method="adjoint")
    g, values = direct.gradient, np.abs(direct.values)
    for j, (beam, kind) in enumerate(parameters):
        delta = step * SIZES[beam][1][kind]
        noise = 1e-10 * values / delta
        assert np.all(np.abs(adjoint.gradient[:, j] - g[:, j]) <= 1e-9 * np.abs(g[:, j]) + noise), names[j]
        runs = [SpatialSimulation(resized(spec, beam, kind, k * delta)).run_with_sensitivities(x, responses, [])
                for k in (-2, -1, 1, 2)]
        v = [r.values for r in runs]
        fd = (v[0] - 8 * v[1] + 8 * v[2] - v[3]) / (12 * delta)
        assert np.all(np.abs(g[:, j] - fd) <= 1e-6 * np.abs(fd) + noise), (names[j], g[:, j], fd)
        assert np.any(np.abs(fd) > 1e3 * noise), names[j]


@pytest.mark.parametrize("design", ["full", "low", "random"])
def test_section_sizes_over_a_motion(design):
    """At full density, at a uniform 0.2 and at a random design (each beam's density a
    variable of its own, SIMP's stiffness and the mass law scaling every size's rate)."""
    n = SpatialSimulation(arm()).n_design
    x = {"full": None, "low": np.full(n, 0.2), "random": np.random.default_rng(7).uniform(0.2, 1.0, n)}[design]
    assert_exact(arm(), RESPONSES, x=x)


def test_buckling_to_section_sizes_over_a_motion():
    """The buckling means (the wire stay's compression dominates them) vary fast with the
    upper tube's size: differences of steps of 1e-3 of each size are 3e-5 off the limit
    that steps of 1e-4 reach to 4e-9, so they are taken at 1e-4."""
    assert_exact(arm(), ["buckling", "buckling:stay:q=0", "buckling:fore"], step=1e-4)


def test_section_sizes_at_an_equilibrium():
    spec = arm()
    spec["analysis"] = "static"
    spec["joints"][0].pop("drive")
    spec["joints"][0]["kind"] = "weld"
    spec["joints"][0].pop("axis")
    spec.setdefault("loads", []).append({"name": "push", "at": "end", "force": [0.0, 5.0, -20.0],
                                         "moment": [0.3, 0.0, 0.0]})
    assert_exact(spec, ["strain_energy", "x:end", "y:end", "z:end", "stress", "buckling"])
    # Its compliance Fᵀu, the push's and gravity's work (the point mass's and the beams'
    # weights): without the push's moment, which Fᵀu cannot count.
    spec["loads"][-1]["moment"] = [0.0, 0.0, 0.0]
    assert_exact(spec, ["compliance", "strain_energy"])


def test_cantilever_against_timoshenko():
    """A steel rod clamped at one end, a small load P across its tip: the tip moves by
    ``δ = PL³/3EI + PL/κGA`` (one element per bar is exact), so ``dδ/dd = −(4δ_b + 2δ_s)/d``
    (``I ∝ d⁴``, ``A ∝ d²``), within the load's nonlinearity (``(δ/L)² ~ 1e-8``)."""
    E, nu, d, L, P = 2.1e11, 0.3, 0.02, 1.0, -1.0
    scene = SpatialScene("cantilever", analysis="static")
    scene.section("steel", E=E, rho=7850.0, nu=nu, diameter=d)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (L, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="steel")
    scene.weld("clamp", "ground", "root")
    scene.load("push", "end", force=(0.0, 0.0, P))
    I, A, kappa, G = math.pi * d**4 / 64, math.pi * d**2 / 4, 6 * (1 + nu) / (7 + 6 * nu), E / (2 * (1 + nu))
    bending, shear = P * L**3 / (3 * E * I), P * L / (kappa * G * A)
    s = SpatialSimulation(scene.to_dict()).run_with_sensitivities(None, ["z:end"], ["diameter:rod"])
    assert s.values[0] == pytest.approx(bending + shear, rel=1e-6)
    assert s.gradient[0, 0] == pytest.approx(-(4 * bending + 2 * shear) / d, rel=1e-6)


@pytest.mark.parametrize(("name", "culprit"), [
    ("diameter:upper", "upper"),       # a tube has outer and inner diameters
    ("outer:fore", "fore"),            # a rectangle has a width and a height
    ("height:tail", "tail"),           # a circle has a diameter
    ("width:nothing", "nothing"),      # no such beam
    ("inner:stay", "stay"),            # a truss bar's circle
])
def test_sizes_a_section_lacks_are_named(name, culprit):
    sim = SpatialSimulation(arm())
    with pytest.raises(SettingsError, match=culprit):
        sim.run_with_sensitivities(None, ["strain_energy"], [name])


# Sizing: the sections' dimensions as an optimization's design.

BOUNDS = {"tube.outer": (0.012, 0.04), "tube.inner": (0.004, 0.018), "blade.width": (0.002, 0.02),
          "blade.height": (0.004, 0.03), "rod.diameter": (0.003, 0.02), "wire.diameter": (0.001, 0.01)}


def assert_differences(problem, z: np.ndarray, e) -> None:
    """The evaluation ``e`` of ``problem`` at ``z``: its objective's and constraints' gradients
    against fourth-order differences of the problem itself in every entry (steps of 1e-3 of
    the entry), to 1e-6."""
    for k in range(problem.n):
        delta = 1e-3 * z[k]

        def at(by: float, k=k, delta=delta) -> np.ndarray:
            moved = z.copy()
            moved[k] += by * delta
            ev = problem.evaluate(moved)
            return np.concatenate([[ev.f0], ev.g])

        fd = (at(-2) - 8 * at(-1) + 8 * at(1) - at(2)) / (12 * delta)
        exact = np.concatenate([[e.df0[k]], e.dg[:, k]])
        assert np.allclose(exact, fd, rtol=1e-6, atol=1e-8 * np.abs(fd).max()), (k, exact, fd)


def test_sizing_problem_gradients_against_differences():
    """The problem's objective and constraints (the tip's deflection, the mass and the
    peak-free stress mean) have the gradients of fourth-order differences of the problem
    itself, each size's summed over its section's beams, the mass's from ``A'/A``."""
    from flextop.problems import SizingProblem

    # Newton to 1e-12: at its default 1e-10 the differences' noise (the values' round-off over
    # steps of 3e-6 m) reaches 3e-6 of the smallest derivative.
    spec = arm()
    spec["simulation"]["tol"] = 1e-12
    problem = SizingProblem(spec, "tip_deflection", [("mass", 1.0), ("stress", 5e7)], sizes=BOUNDS)
    z = problem.z0
    e = problem.evaluate(z)
    sim = SpatialSimulation(problem.spec_at(z))
    assert (e.g[0] + 1.0) * 1.0 == pytest.approx(sim.mass(), rel=1e-12)
    assert_differences(problem, z, e)
    lightest = SizingProblem(arm(), "mass", sizes=BOUNDS)  # the mass alone: no run of the engine
    alone = lightest.evaluate(z)
    assert alone.f0 == 1.0 and np.allclose(alone.df0 * lightest.reference, e.dg[0], rtol=1e-12)


def test_sizing_by_mma_reaches_a_kkt_point():
    """The arm's tip deflection minimized over its six section sizes at the start's mass,
    by MMA: a KKT point (measured: 2e-5 after 57 iterations, the deflection 0.53 of the
    start's, the tube's wall thinned to its bound, the truss stay's material moved into
    the blade), the mass bound met, the deflection lower than the start's by a tenth at
    least."""
    from flextop import optimize
    from flextop.problems import SizingProblem

    problem = SizingProblem(arm(), "tip_deflection", [("mass", SpatialSimulation(arm()).mass())], sizes=BOUNDS)
    result = optimize(problem, problem.z0, "mma", max_iter=100, kkt_tol=1e-4)
    assert result.success, result.message
    f, r, _ = problem.physical(problem.evaluate(result.x))
    assert r[0] <= problem.bounds[0] * (1 + 1e-6)
    assert f < 0.9 * problem.reference


@pytest.mark.parametrize(("sizes", "culprit"), [
    ({"tube.diameter": (0.01, 0.03)}, "outer, inner"),
    ({"pipe.outer": (0.01, 0.03)}, "pipe"),
    ({"tube.outer": (0.03, 0.01)}, "lower < upper"),
    ({"tube.outer": (0.03, 0.05)}, "outside"),
    ({"tube.outer": ("a", 0.05)}, "bounds"),
    ({}, "at least one"),
])
def test_sizing_problem_refuses_sizes_the_scene_lacks(sizes, culprit):
    from flextop.problems import SizingProblem

    with pytest.raises(SettingsError, match=culprit):
        SizingProblem(arm(), "tip_deflection", sizes=sizes)


def test_a_sizing_problem_held_to_a_tolerance_measures_where_an_accepted_design_moved_and_checkpoints():
    """Held to rtol 1e-2, the first evaluation measures (the scene at its sizes run to the
    tolerance, gradients too); a trial moved by less than ``readapt`` of a range runs on
    the grid held, the same numbers as that grid's run; an accepted design that moved by
    more is measured from the grid held; the returned design is measured as a run ends.
    ``to_dict``/``from_dict`` rebuild it: the same evaluation, bit for bit."""
    from flextop.discretization import spatial as spatial_tolerance
    from flextop.problems import SizingProblem

    bounds = {"tube.outer": (0.012, 0.04), "blade.height": (0.004, 0.03)}
    problem = SizingProblem(arm(), "tip_deflection", [("mass", 2.0)], sizes=bounds, rtol=1e-2)
    z = problem.z0
    first = problem.accept(z, problem.evaluate(z))
    held = problem.held
    sim = SpatialSimulation(problem.spec_at(z))
    measured = sim.run_with_sensitivities(None, ["tip_deflection"], problem.parameters, rtol=1e-2, method="adjoint")
    assert measured.discretization == held and measured.errors["tip_deflection"] <= 1e-2
    assert first.f0 == 1.0 and problem.reference == measured.values[0]
    near = z + 0.05 * (problem.upper - problem.lower)
    trial = problem.evaluate(near)
    assert problem.held == held
    moved = SpatialSimulation(problem.spec_at(near))
    on_grid = spatial_tolerance.on_grid(moved, held, None, ["tip_deflection"], problem.parameters, False, {"method": "adjoint"})
    assert trial.f0 * problem.reference == on_grid.values[0]
    far = z + 0.3 * (problem.upper - problem.lower)
    accepted = problem.accept(far, problem.evaluate(far))
    again = SpatialSimulation(problem.spec_at(far)).run_with_sensitivities(
        None, ["tip_deflection"], problem.parameters, rtol=1e-2, start=held, method="adjoint")
    assert accepted.f0 * problem.reference == pytest.approx(again.values[0], rel=1e-14)
    np.testing.assert_array_equal(problem.rule.at, problem.scaled(far))
    rebuilt = SizingProblem.from_dict(json.loads(json.dumps(problem.to_dict())))
    assert rebuilt.held == problem.held and rebuilt.reference == problem.reference
    assert rebuilt.evaluate(near).f0 == problem.evaluate(near).f0
    assert problem.conclude(far, accepted) is accepted
    concluded = problem.conclude(near, problem.evaluate(near))
    np.testing.assert_array_equal(problem.rule.at, problem.scaled(near))
    assert concluded.f0 != trial.f0  # measured from the grid held: its own grid
    with pytest.raises(SettingsError, match="give h .* or rtol"):
        SizingProblem(arm(), "tip_deflection", sizes=bounds, rtol=1e-2, h=1e-3)


def test_the_command_line_sizes_a_spatial_scene_and_resumes(tmp_path):
    """``flextop optimize SCENE --size … --max-mass …``: sized by MMA, the sizes printed and
    written as the scene at them (``sized.toml``, which builds with them); stopped and
    resumed, the same design as in one go; sizing's refusals in one line each."""
    import subprocess
    import sys

    (tmp_path / "arm.toml").write_text(SpatialScene.from_dict(arm()).to_toml())
    mass = SpatialSimulation(arm()).mass()
    cli = lambda *args: subprocess.run([sys.executable, "-m", "flextop.cli", "optimize", *map(str, args)],  # noqa: E731
                                       capture_output=True, text=True, timeout=600)
    sizing = ("--size", "tube.inner=0.004:0.018", "--size", "blade.height=0.004:0.03", "--max-mass", mass)
    straight = cli(tmp_path / "arm.toml", *sizing, "--max-iter", 4, "--out", tmp_path / "a", "--no-plots")
    assert straight.returncode == 3, straight.stderr  # stopped at --max-iter
    assert "over 2 sizes and places (tube.inner, blade.height)" in straight.stdout and "blade.height: " in straight.stdout
    z = np.load(tmp_path / "a" / "design.npy")
    sized = SpatialSimulation(tmp_path / "a" / "sized.toml")
    assert sized.spec["sections"]["tube"]["inner"] == z[0] and sized.spec["sections"]["blade"]["height"] == z[1]
    assert sized.mass() <= mass * (1 + 1e-6)
    half = cli(tmp_path / "arm.toml", *sizing, "--max-iter", 2, "--out", tmp_path / "b", "--no-plots")
    assert half.returncode == 3, half.stderr
    rest = cli("--resume", "--max-iter", 4, "--out", tmp_path / "b", "--no-plots")
    assert rest.returncode == 3, rest.stderr
    assert np.array_equal(z, np.load(tmp_path / "b" / "design.npy"))
    for args, message in [((tmp_path / "arm.toml", "--size", "tube.outer=0.02", "--out", tmp_path / "c"),
                           "--size tube.outer=0.02: give NAME=LOWER:UPPER"),
                          ((tmp_path / "arm.toml", "--size", "tube.outer=0.012:0.04", "--volume-fraction", 0.3,
                            "--out", tmp_path / "c"), "--volume-fraction: not built for sizing"),
                          (("robot_arm", "--size", "tube.outer=0.012:0.04", "--out", tmp_path / "c"),
                           "--size: for a spatial scene (dimension = 3), not a planar one"),
                          ((tmp_path / "arm.toml", "--size", "pipe.outer=0.012:0.04", "--out", tmp_path / "c"),
                           "no section called 'pipe'"),
                          ((tmp_path / "arm.toml", "--densities", "--out", tmp_path / "c"),
                           "--densities designs the densities beside --size or --place"),
                          ((EXAMPLES / "spatial_slider_crank.toml", "--place", "crank.x=-0.1:0.1", "--out", tmp_path / "c"),
                           "--place: give --objective"),
                          ((tmp_path / "arm.toml", "--size", "tube.outer=0.012:0.04", "--objective", "nope",
                            "--out", tmp_path / "c"), "nope")]:
        refused = cli(*args)
        assert refused.returncode == 2 and message in refused.stderr and refused.stderr.count("\n") == 1, refused.stderr
    # the densities designed beside a size, under half the whole volume at the scene's sizes
    both = cli(tmp_path / "arm.toml", "--size", "tube.outer=0.012:0.04", "--densities", "--volume-fraction", 0.5,
               "--global-volume", "--max-iter", 40, "--out", tmp_path / "d", "--no-plots")
    assert both.returncode == 0 and "status: KKT" in both.stdout, both.stdout + both.stderr
    assert "over 1 sizes and places (tube.outer) and 4 densities" in both.stdout
    x = np.load(tmp_path / "d" / "densities.npy")
    assert SpatialSimulation(tmp_path / "d" / "sized.toml").volume(x) <= 0.5 * SpatialSimulation(arm()).volume(1.0) * (1 + 1e-6)


def test_sizes_and_densities_designed_together_have_exact_gradients():
    """``densities=True``: the beams' densities follow the sizes in the design. The tip's
    deflection, the mass and the volume (the two explicit, their size rates by ``A'/A`` over
    the section's beams, each at its density) against fourth-order differences of the
    problem in every entry; a volume or mass with the sizes' own parameters is refused where
    nothing gives its rate."""
    from flextop.problems import SizingProblem

    spec = arm()
    spec["simulation"]["tol"] = 1e-12
    sizes = {"tube.outer": (0.012, 0.04), "blade.height": (0.004, 0.03)}
    problem = SizingProblem(spec, "tip_deflection", [("mass", 1.0), ("volume", 1e-4)], sizes=sizes, x=0.6, densities=True)
    assert problem.n == 2 + 4 and problem.z0[2:].tolist() == [0.6] * 4 and problem.lower[2] == 0.01
    z = problem.z0 * np.array([1.0, 1.0, 1.0, 0.8, 1.2, 0.9])
    e = problem.evaluate(z)
    sim = SpatialSimulation(problem.spec_at(z))
    assert (e.g[1] + 1.0) * 1e-4 == pytest.approx(sim.volume(z[2:]), rel=1e-12)
    assert_differences(problem, z, e)
    with pytest.raises(SettingsError, match="'volume' to 'outer:upper': a volume's or mass's derivative to a section's"):
        sim.run_with_sensitivities(None, ["volume"], ["outer:upper"])
