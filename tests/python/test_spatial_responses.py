"""Responses of spatial scenes. Stresses of beams and bars (``stress[:OPTIONS]``): a rectangular
cantilever's bending, a tube's torsion, both at once, and a rectangle's biaxial bending against
their closed forms, the mean below its peak
and growing to it, exact gradients through a motion and an equilibrium (beams and truss bars,
the relaxation ``x^q`` included) against fourth-order differences and direct against adjoint,
bad options named. The kinetic energy's time integral against the run's energies, with exact
gradients; refused at an equilibrium. A lattice of least volume under a peak stress limit."""

import math
import re
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import trapezoid

from conftest import lattice_cantilever
import flextop
from flextop import SettingsError, SpatialScene, SpatialSimulation
from flextop.problems import SpatialProblem
from flextop.scenes import spatial_robot_arm, trapezoidal
from test_spatial import G, flexible_pendulum

E, NU = 2.1e11, 0.3


def cantilever(section: dict, *, force=(0.0, 0.0, 0.0), moment=(0.0, 0.0, 0.0), split: int = 4) -> SpatialSimulation:
    """A 1 m steel beam along x clamped at its root, loaded at its end (small loads: linear)."""
    scene = SpatialScene("cantilever", analysis="static")
    scene.section("steel", E=E, rho=7850.0, nu=NU, **section)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (1.0, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="steel", split=split)
    scene.weld("clamp", "root")
    scene.load("push", "end", force=force, moment=moment)
    return SpatialSimulation(scene)


def test_a_bent_rectangle_has_the_beam_theory_stress_at_each_elements_middle():
    """A tip load P along the section's e₂ (its width b) bends the rectangle about e₃: every
    fibre read (corners, long sides' middles) lies at |y| = b/2, where σ = M b/(2 I₃) with M
    the moment at the element's middle (one point per element: its curvature is the mean of
    M/EI over it, exact for the linear moment). The p-mean over four equal elements is
    (¼ Σ σₑᵖ)^(1/p), at every p."""
    b, h, split, P = 0.01, 0.02, 4, 1e-3
    sim = cantilever({"shape": "rectangle", "width": b, "height": h}, force=(0.0, 0.0, P), split=split)
    middles = (np.arange(split) + 0.5) / split
    sigma = P * (1.0 - middles) * b / 2 / (h * b**3 / 12)
    for p in (2.0, 8.0, 32.0):
        expected = np.mean(sigma**p) ** (1 / p)
        value, rod = sim.run_with_sensitivities(None, [f"stress:p={p:g},q=0", f"stress:rod:p={p:g},q=0"]).values
        assert value == pytest.approx(expected, rel=1e-7) and rod == value, p


def test_a_twisted_tube_has_the_torsion_shear_everywhere_on_its_edge():
    """A torque T: τ = T (D/2)/J on the whole outer edge, σ_vM = √3 τ at every fibre of every
    element, so every p-mean is that, and the KS mean (s/ρ) ln cosh(ρσ/s)."""
    outer, inner, T = 0.012, 0.010, 1e-3
    sim = cantilever({"shape": "tube", "outer": outer, "inner": inner}, moment=(T, 0.0, 0.0))
    sigma = math.sqrt(3) * T * outer / 2 / (math.pi * (outer**4 - inner**4) / 32)
    for name in ("stress", "stress:p=3,q=0"):
        assert sim.run_with_sensitivities(None, name).values[0] == pytest.approx(sigma, rel=1e-7), name
    ks = sim.run_with_sensitivities(None, "stress:ks=50,scale=1e5").values[0]
    assert ks == pytest.approx(1e5 / 50 * math.log(math.cosh(50 * sigma / 1e5)), rel=1e-7)


def test_combined_bending_and_torsion_and_biaxial_bending_against_their_closed_forms():
    """A tube bent by a tip force P along z and twisted by a torque T: at a fibre of its edge
    at angle θ, σ = M (D/2) sin θ / I and τ = T (D/2)/J (J = 2I), σ_vM = √(σ² + 3τ²), M at the
    element's middle; the peak is at the root element's fibres in the bending plane, and
    every p-mean is that of the eight fibres of the four elements. A rectangle (width b
    along z, height h along y) bent by tip forces along y and z at once: at the corner where
    both add, σ = M_y (h/2)/I_z + M_z (b/2)/I_y, the peak."""
    outer, inner, P, T = 0.012, 0.010, 1e-3, 2e-3
    sim = cantilever({"shape": "tube", "outer": outer, "inner": inner}, force=(0.0, 0.0, P), moment=(T, 0.0, 0.0))
    second = math.pi * (outer**4 - inner**4) / 64
    middles = (np.arange(4) + 0.5) / 4
    angles = np.arange(8) * np.pi / 4
    sigma = P * (1.0 - middles)[:, None] * (outer / 2) * np.sin(angles)[None, :] / second
    tau = T * (outer / 2) / (2 * second)
    von_mises = np.sqrt(sigma**2 + 3 * tau**2)
    names = ["stress:p=2,q=0", "stress:p=8,q=0"]
    run = sim.run_with_sensitivities(None, names)
    for name, value, p in zip(names, run.values, (2, 8)):
        assert value == pytest.approx(np.mean(von_mises**p) ** (1 / p), rel=1e-9), name
        assert run.peaks[name] == pytest.approx(von_mises.max(), rel=1e-9), name
    b, h, forces = 0.01, 0.02, (2e-3, 1e-3)
    sim = cantilever({"shape": "rectangle", "width": b, "height": h}, force=(0.0, *forces))
    root = 1.0 - middles[0]
    corner = root * (forces[0] * (h / 2) / (b * h**3 / 12) + forces[1] * (b / 2) / (h * b**3 / 12))
    assert sim.run_with_sensitivities(None, "stress:p=2,q=0").peaks["stress:p=2,q=0"] == pytest.approx(corner, rel=1e-9)


def test_the_mean_stays_below_its_peak_and_grows_towards_it():
    """Over a motion: p-means grow with p, never above the KS mean's limit, the peak; the
    relaxation x^q lowers a light design's stresses."""
    sim = SpatialSimulation(flexible_pendulum())
    x = np.array([0.7, 0.3])
    runs = [sim.run_with_sensitivities(x, f"stress:p={p},q=0") for p in (2, 4, 8, 16, 64, 256)]
    means, peak = [r.values[0] for r in runs], runs[0].peaks["stress:p=2,q=0"]
    assert np.all(np.diff(means) > 0) and means[-1] <= peak, (means, peak)
    assert 1 - means[-1] / peak < 0.05
    relaxed = sim.run_with_sensitivities(x, "stress:p=8,q=1").values[0]
    assert relaxed < means[2]


def assert_gradients(sim: SpatialSimulation, x: np.ndarray, responses: list[str], columns, step: float) -> None:
    """Direct = adjoint to 1e-9 of the largest entry, fourth-order differences within 1e-6
    of each response's largest entry."""
    direct = sim.run_with_sensitivities(x, responses, method="direct")
    f, adjoint = sim.run_with_sensitivities(x, responses, method="adjoint")
    scale = np.abs(adjoint).max(axis=1)
    assert np.all(scale > 0) and np.array_equal(direct.values, f)
    assert np.all(np.abs(direct.dfdx - adjoint) <= 1e-9 * scale[:, None])
    for i in columns:
        def at(k: float) -> np.ndarray:
            shifted = x.copy()
            shifted[i] += k * step
            return sim.run_with_sensitivities(shifted, responses).values
        fd = (at(-2) - 8 * at(-1) + 8 * at(1) - at(2)) / (12 * step)
        assert np.all(np.abs(adjoint[:, i] - fd) <= 1e-6 * scale), (i, adjoint[:, i], fd)


def test_stress_gradients_over_a_motion_are_exact():
    sim = SpatialSimulation(flexible_pendulum())
    responses = ["stress", "stress:p=4,q=0", "stress:ks=20,scale=1e7,q=1", "stress:lower:q=1"]
    assert_gradients(sim, np.array([0.7, 0.08]), responses, range(2), 1e-4)


@pytest.mark.parametrize("kind", ["frame", "truss"])
def test_stress_gradients_of_a_lattice_in_equilibrium_are_exact(kind):
    scene = lattice_cantilever()
    if kind == "truss":
        spec = scene.to_dict()
        spec["ground_structures"][0]["kind"] = "truss"
        for joint in spec["joints"]:
            joint["kind"] = "spherical"
        scene = SpatialScene.from_dict(spec)
    sim = SpatialSimulation(scene)
    rng = np.random.default_rng(3)
    x = rng.uniform(0.2, 1.0, sim.n_design)
    assert_gradients(sim, x, ["stress", "stress:p=16,q=0.3", "buckling", "buckling:ks=30,scale=0.01,q=0", "compliance"],
                     rng.choice(sim.n_design, 4, replace=False), 1e-4)


@pytest.mark.parametrize(("name", "culprit"), [("stress:p=1", "p=1"), ("stress:q=2", "q=2"), ("stress:box", "box"),
                                               ("stress:ks=10", "scale"), ("stress:t=3", "'t'"), ("stresses", "stresses")])
def test_bad_stress_options_are_named(name, culprit):
    sim = SpatialSimulation(flexible_pendulum())
    with pytest.raises(SettingsError, match=culprit):
        sim.run_with_sensitivities(None, name)


def test_the_kinetic_energy_integrates_the_runs_and_its_gradients_are_exact():
    """The responses integrate the energies a run reports at its design (they were once the
    full-density mechanism's: 17 % off the kinetic, 1500× the strain energy here): the
    kinetic energy's integral, the strain energy's mean (as on a planar scene)."""
    sim = SpatialSimulation(flexible_pendulum())
    x = np.array([0.7, 0.08])
    run = sim.simulate(x)
    values = sim.run_with_sensitivities(x, ["kinetic_energy", "strain_energy"]).values
    duration = run.time[-1] - run.time[0]
    expected = [trapezoid(run.kinetic, run.time), trapezoid(run.strain, run.time) / duration]
    assert values == pytest.approx(expected, rel=1e-12)
    lattice = SpatialSimulation(lattice_cantilever())
    y = np.random.default_rng(5).uniform(0.1, 1.0, lattice.n_design)
    assert lattice.equilibrium(y).strain == pytest.approx(lattice.run_with_sensitivities(y, "strain_energy").values[0], rel=1e-12)
    assert_gradients(sim, x, ["kinetic_energy"], range(2), 1e-4)
    with pytest.raises(SettingsError, match="kinetic energy is a motion's"):
        sim.run_with_sensitivities(x, "kinetic_energy", equilibrium=True)


def test_a_lattice_of_least_volume_under_a_peak_stress_limit(tmp_path):
    """Minimum volume subject to the peak stress (3× the solid design's): the bound
    normalizes the p-mean to its peak (Le et al. 2010), MMA reaches a KKT point (residual
    below 1e-6) at 16 % of the volume, where the peak meets the limit to 5e-6 (what the
    normalization's damped approach leaves at that stop: 1.4e-6 here; a p-mean
    bounded alone, 2× its solid value, left the peak 56 % above it); the command line's
    --max-stress sets the same limit."""
    sim = SpatialSimulation(lattice_cantilever())
    solid = sim.run_with_sensitivities(1.0, "stress")
    limit = 3.0 * solid.peaks["stress"]
    problem = SpatialProblem(sim, "volume", [("stress", limit)])
    result = flextop.optimize(problem, np.ones(sim.n_design), method="mma", max_iter=300)
    assert result.success and result.kkt < 1e-6
    end = sim.run_with_sensitivities(result.x, "stress")
    assert end.peaks["stress"] == pytest.approx(limit, rel=5e-6)
    assert 0.1 < sim.volume(result.x) / sim.volume(1.0) < 0.2
    (tmp_path / "lattice.toml").write_text(lattice_cantilever().to_toml())
    run = subprocess.run([sys.executable, "-m", "flextop.cli", "optimize", str(tmp_path / "lattice.toml"), "--max-stress",
                          f"{limit:.6g}", "--max-iter", "2", "--out", str(tmp_path / "out")], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 3 and "subject to stress ≤ 3.168e+07, volume:box ≤" in run.stdout, run.stdout + run.stderr
    # --max-buckling bounds the bars' peak buckling ratio in the same way.
    run = subprocess.run([sys.executable, "-m", "flextop.cli", "optimize", str(tmp_path / "lattice.toml"), "--max-buckling",
                          "0.05", "--max-iter", "1", "--out", str(tmp_path / "buckling")], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 3 and "subject to buckling ≤ 0.05, volume:box ≤" in run.stdout, run.stdout + run.stderr


def test_the_mass_follows_the_mass_law_with_its_gradient():
    """One material: the solid lattice's mass is ρ times its volume; with the linear mass law
    it is ρ Σ xᵢVᵢ at any design; with the default law (Du–Olhoff's) its gradient matches
    central differences; per ground structure it is the same here (one structure), and a
    structure that is not there is named."""
    scene = lattice_cantilever()
    sim = SpatialSimulation(scene)
    assert sim.mass(1.0) == pytest.approx(7850.0 * sim.volume(1.0), rel=1e-12)
    x = np.random.default_rng(9).uniform(0.05, 1.0, sim.n_design)
    scene.design(x_min=1e-3, mass="linear")
    linear = SpatialSimulation(scene)
    assert linear.mass(x) == pytest.approx(7850.0 * linear.volume(x), rel=1e-12)
    f, dfdx = sim.run_with_sensitivities(x, ["mass", "mass:box"])
    assert f[0] == pytest.approx(sim.mass(x), rel=1e-14) and f[1] == pytest.approx(f[0], rel=1e-12)
    for i in (0, 7, 40):
        step = 1e-6 * np.eye(sim.n_design)[i]
        fd = (sim.mass(x + step) - sim.mass(x - step)) / 2e-6
        assert dfdx[0, i] == pytest.approx(fd, rel=1e-6)
    with pytest.raises(SettingsError, match="'arm' is no ground structure"):
        sim.run_with_sensitivities(x, "mass:arm")
    # the volume reads no parameter; the mass reads a beam's ρ, whose share is not built
    assert sim.run_with_sensitivities(x, ["volume"], ["E:box/bar0"]).gradient[0, 0] == 0.0
    with pytest.raises(SettingsError, match="'mass' to 'rho:box/bar0'"):
        sim.run_with_sensitivities(x, ["mass"], ["rho:box/bar0"])


def spun_arm(*, omega: float, analysis: str = "dynamic", drive: dict | None = None) -> SpatialScene:
    """A 2 kg body whose centre lies 0.3 m from a hinge about z, under gravity along −z,
    turning at ``omega`` rad/s (or held by ``drive``), hinged to the ground at its ``pivot``."""
    scene = SpatialScene("spun arm", gravity=(0.0, 0.0, -G), analysis=analysis)
    scene.rigid_body("arm", mass=2.0, inertia=(0.01, 0.05, 0.05), position=(0.3, 0.0, 0.0),
                     points={"pivot": (-0.3, 0.0, 0.0)}, velocity=(0.0, 0.3 * omega, 0.0),
                     angular_velocity=(0.0, 0.0, omega))
    scene.revolute("hinge", "ground", "arm.pivot", axis=(0.0, 0.0, 1.0), drive=drive)
    scene.simulation(t_end=0.5, h=1e-3, rho_inf=0.9)
    return scene


def test_a_spun_body_loads_its_hinge_with_its_centripetal_force_and_its_weight():
    """Turning freely at ω about a vertical hinge, the body pulls on it by m ω² r and
    hangs on it by m g: |F| = m √((ω² r)² + g²), constant, which every p-mean of it is (a
    KS mean is (s/ρ) ln cosh(ρ|F|/s)); the hinge's moments (its locked tilt) are not part of
    the force. The peak is the largest value at a step: within 1e-3 (the scheme's first
    steps, at ωh = 0.006)."""
    sim = SpatialSimulation(spun_arm(omega=6.0))
    run = sim.run_with_sensitivities(None, ["reaction:hinge", "reaction:hinge:p=2", "reaction:hinge:ks=50,scale=100"])
    force = 2.0 * math.hypot(36.0 * 0.3, G)
    expected = [force, force, 2.0 * math.log(math.cosh(force / 2.0))]
    assert run.values == pytest.approx(expected, rel=1e-5)
    assert run.peaks["reaction:hinge"] == pytest.approx(force, rel=1e-3)


def test_a_drive_holding_an_arm_out_bears_its_weight_and_its_moment():
    """Held level by its drive about a horizontal hinge, the arm's weight loads the hinge
    with m g and the drive with the torque m g r: the equilibrium's closed forms, to
    Newton's tolerance, with exact gradients to the arm's mass (g and g r)."""
    scene = spun_arm(omega=0.0, analysis="static", drive=trapezoidal(0.0, 0.0, acceleration=1.0, speed=1.0))
    spec = scene.to_dict()
    spec["joints"][0]["axis"] = [0.0, 1.0, 0.0]
    sim = SpatialSimulation(spec)
    run = sim.run_with_sensitivities(None, ["reaction:hinge", "torque:hinge"], ["mass:arm"])
    assert run.values == pytest.approx([2.0 * G, 2.0 * G * 0.3], rel=1e-9)
    assert run.gradient[:, 0] == pytest.approx([G, G * 0.3], rel=1e-9)


def test_every_response_over_the_arms_motion_has_exact_gradients():
    """The spatial robot arm (links of 3 × 2 × 2 nodes, 100 bars) over 0.2 s of its motion at
    a random design: its tip deflection (Eq. 40), strain and kinetic energies, a relaxed
    p-mean of its stresses, a KS mean of its bars' buckling ratios, its payload's final
    height, its lift drive's torque squared, a link's mass and volume: direct = adjoint to
    1e-9, fourth-order differences to 1e-6 at three bars (its reactions, torques and
    compliance below; its frequencies' rates in ``test_spatial_mode_rates.py``)."""
    sim = SpatialSimulation(spatial_robot_arm(nx=3, t_end=0.2, h=0.01))
    rng = np.random.default_rng(6)
    x = rng.uniform(0.3, 1.0, sim.n_design)
    responses = ["tip_deflection", "strain_energy", "kinetic_energy", "stress:p=8,q=0.5",
                 "buckling:ks=30,scale=0.01,q=0", "z:payload", "torque_squared:lift", "mass:link1", "volume:link2"]
    assert_gradients(sim, x, responses, rng.choice(sim.n_design, 3, replace=False), 1e-4)


def test_reaction_and_torque_gradients_over_a_motion_are_exact():
    """The spatial robot arm's shoulder and elbow reactions and its drives' torques (p-means
    and a KS mean) to its bars' densities, direct against adjoint and against differences."""
    sim = SpatialSimulation(spatial_robot_arm(nx=3, t_end=0.2, h=0.01))
    rng = np.random.default_rng(5)
    x = rng.uniform(0.3, 1.0, sim.n_design)
    responses = ["reaction:lift", "reaction:fold:p=2", "torque:turn", "torque:lift:ks=20,scale=10", "compliance"]
    assert_gradients(sim, x, responses, rng.choice(sim.n_design, 3, replace=False), 1e-4)


@pytest.mark.parametrize(("name", "culprit"), [("reaction:nope", "nope"), ("torque:hinge", "not driven"),
                                               ("reaction:hinge:q=1", "'q'"), ("reaction", "reaction"),
                                               ("reaction:hinge:p=1", "p=1")])
def test_bad_reactions_and_torques_are_named(name, culprit):
    sim = SpatialSimulation(spun_arm(omega=1.0))
    with pytest.raises(SettingsError, match=culprit):
        sim.run_with_sensitivities(None, name)


def test_a_compressed_column_reads_its_euler_ratio_and_its_sizes_rates():
    """A 1 m steel column of a 12 × 30 mm rectangle in four elements, clamped and pushed
    along its axis by P = 2 kN: every element reads the bar's ratio b = P L²/(π² E I_min),
    L the whole bar's length and I_min = h w³/12 about the weak axis, so each mean and the
    peak are b; its rates to the width and height are −3b/w and −b/h (N = P whatever the
    size), through the strains and the Euler load together; in tension it reads zero."""
    section = {"shape": "rectangle", "width": 0.012, "height": 0.03}
    sim = cantilever(section, force=(-2000.0, 0.0, 0.0))
    run = sim.run_with_sensitivities(None, ["buckling", "buckling:p=2,q=0"], ["width:rod", "height:rod"])
    b = 2000.0 / (math.pi**2 * E * 0.03 * 0.012**3 / 12.0)
    assert run.values == pytest.approx([b, b], rel=1e-9)
    assert run.peaks["buckling"] == pytest.approx(b, rel=1e-9)
    assert run.gradient[0] == pytest.approx([-3.0 * b / 0.012, -b / 0.03], rel=1e-6)
    pulled = cantilever(section, force=(2000.0, 0.0, 0.0)).run_with_sensitivities(None, ["buckling"])
    assert pulled.values[0] == 0.0


def test_static_compliance_is_the_work_of_the_loads_and_the_weights():
    """A cantilever bent by a tip load P and its own weight: its compliance is Fᵀu = P·u_tip
    plus the weights' work, every node's half of each element's ρAL g on its sinking; in the
    linear range twice the strain energy (Clapeyron); with gradients to the mass (a body's
    weight, explicitly) exact; a moment, which Fᵀu cannot count, refused."""
    scene = SpatialScene("bent", analysis="static", gravity=(0.0, 0.0, -G))
    scene.section("steel", E=E, rho=7850.0, nu=NU, diameter=0.02)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (1.0, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="steel", split=4)
    scene.point_mass("bob", "end", 0.5)
    scene.weld("clamp", "root")
    scene.load("push", "end", force=(0.0, 3.0, -20.0))
    sim = SpatialSimulation(scene)
    names = ["compliance", "strain_energy", "y:end", "z:end"] + [f"z:rod[{k}]" for k in (1, 2, 3)]
    run = sim.run_with_sensitivities(None, names, ["mass:bob"])
    c, u, y, z = run.values[:4]
    element = 7850.0 * math.pi * 0.01**2 * 0.25
    weights = element * G * (0.5 * z + sum(run.values[4:]))  # the root does not sink
    assert c == pytest.approx(3.0 * y - 20.0 * z - 0.5 * G * z - weights, rel=1e-9)
    assert c == pytest.approx(2.0 * u, rel=1e-4)  # to the nonlinearity's (δ/L)² ≈ 2e-5
    f = lambda m: SpatialSimulation(_with_mass(scene, m)).run_with_sensitivities(None, "compliance").values[0]  # noqa: E731
    fd = (f(0.5 - 2e-3) - 8 * f(0.5 - 1e-3) + 8 * f(0.5 + 1e-3) - f(0.5 + 2e-3)) / 12e-3
    assert run.gradient[0, 0] == pytest.approx(fd, rel=1e-6)
    spec = scene.to_dict()
    spec["loads"][0]["moment"] = [0.0, 1.0, 0.0]
    with pytest.raises(SettingsError, match="'push' is a follower load, a moment or a motor"):
        SpatialSimulation(spec).run_with_sensitivities(None, "compliance")


def _with_mass(scene: SpatialScene, mass: float) -> dict:
    spec = scene.to_dict()
    spec["point_masses"][0]["mass"] = mass
    return spec



def test_the_lattice_of_least_compliance_is_a_kkt_point():
    """The classic problem in 3D: the lattice cantilever's compliance Fᵀu at 30 % of its
    volume by MMA from the uniform design reaches a KKT point (measured: 23 iterations,
    residual 9e-7) whose compliance is a twentieth of the uniform design's and still twice
    its strain energy (small loads)."""
    sim = SpatialSimulation(lattice_cantilever())
    problem = SpatialProblem(sim, "compliance", volume=0.3)
    result = flextop.optimize(problem, np.full(sim.n_design, 0.3), method="mma", max_iter=100)
    assert result.success and result.kkt < 1e-6 and result.fun < 0.1
    c, u = sim.run_with_sensitivities(result.x, ["compliance", "strain_energy"]).values
    assert c == pytest.approx(2.0 * u, rel=1e-3)
    assert sim.volume(result.x) == pytest.approx(0.3 * sim.volume(1.0), rel=1e-6)


def test_a_bar_past_its_euler_load_is_named_where_newton_fails():
    """The spatial arm at uniform 0.2: its one-element bars pass their Euler loads in the
    first 0.13 s of the motion and Newton diverges soon after, at every step size; the
    failure names the bar nearest its Euler load, and how far past it."""
    sim = SpatialSimulation(spatial_robot_arm())
    x = np.full(sim.n_design, 0.2)
    with pytest.raises(flextop.SimulationError) as failure:
        sim.simulate(x, t_end=0.2)
    found = re.search(r"Newton did not converge .*; bar '(link\d/bar\d+)' was at ([0-9.]+) times its Euler load",
                      str(failure.value))
    assert found is not None, str(failure.value)
    assert float(found[2]) > 1.0
    ratio = sim.run_with_sensitivities(x, "buckling:" + found[1].split("/")[0], t_end=0.13, h=0.0025).peaks
    assert max(ratio.values()) > 1.0, ratio
