"""Sensitivities through the Python seam ``Simulation.run_with_sensitivities``."""

import numpy as np
import pytest

import flextop
from flextop import SettingsError

from conftest import assert_exact_gradients


@pytest.mark.parametrize("scene, responses", [
    (flextop.scenes.robot_arm(), ["tip_deflection", "compliance"]),
    (flextop.scenes.robot_arm(), ["torque_rms:shoulder", "torque:elbow:p=16"]),
    (flextop.scenes.static_truss(), ["compliance"]),
    (flextop.scenes.static_truss(), ["strain_energy"]),
])
def test_gradients_match_finite_differences_for_both_methods(scene, responses):
    sim = flextop.Simulation(scene)
    x = np.random.default_rng(1).uniform(0.1, 0.95, sim.n_design)
    assert_exact_gradients(sim, x, responses, (3, sim.n_design - 5))


def test_values_equal_the_responses_of_a_plain_run(arm):
    x = np.full(arm.n_design, 0.4)
    f, _ = arm.run_with_sensitivities(x, ["tip_deflection", "compliance:link1", "volume"])
    res = arm.run(x)
    assert f[0] == pytest.approx(res.tip_deflection(), rel=1e-12)
    assert f[1] == pytest.approx(res.response("compliance:link1"), rel=1e-12)
    volume = 0.4 * np.sum(arm.bars.volume)
    assert f[2] == pytest.approx(volume, rel=1e-12)


def test_auto_picks_the_adjoint_for_few_responses(arm):
    x = np.full(arm.n_design, 0.5)
    assert arm.run_with_sensitivities(x, "tip_deflection").method == "adjoint"
    small = flextop.Simulation(flextop.scenes.static_truss(nx=2, ny=2))
    out = small.run_with_sensitivities(np.full(small.n_design, 0.5), ["compliance", "volume", "displacement:truss[1,0]:0,1",
                                                                "displacement:truss[1,1]:1,0", "displacement:truss[1,1]:0,1",
                                                                "displacement:truss[1,0]:1,0", "displacement:truss[1,0]:1,1"])
    assert small.n_design == 6 and out.method == "direct"


def test_volume_gradient_is_the_bar_volumes(arm):
    f, g = arm.run_with_sensitivities(np.full(arm.n_design, 0.3), ["volume:link2"])
    volumes = np.asarray(arm.bars.volume)
    link2 = np.asarray(arm.bars.component) == 1
    np.testing.assert_allclose(g[0], np.where(link2, volumes, 0.0))
    assert f[0] == pytest.approx(0.3 * volumes[link2].sum())


@pytest.mark.parametrize("name, match", [("stiffness", "unknown response"), ("compliance:link3", "unknown component 'link3'"),
                                         ("tip_deflection:nowhere", "unknown node"), ("displacement:link2[4,1]:0,0", "direction")])
def test_bad_responses_are_named(arm, name, match):
    with pytest.raises(SettingsError, match=match):
        arm.run_with_sensitivities(np.full(arm.n_design, 0.4), [name])


def test_the_engine_lists_every_response_it_parses(arm):
    """The names Python documents are the engine's: each parses (with its argument, where it
    needs one), the docstring and the CLI's help list them, and an unknown name's error does."""
    arguments = {"displacement": ":link2[4,2]:0,1", "integrated_displacement": ":link2[4,2]:0,1", "torque": ":shoulder",
                 "torque_rms": ":shoulder", "torque_squared": ":shoulder", "drive_work": ":shoulder",
                 "energy_drawn": ":shoulder", "joint_position": ":elbow", "reaction": ":elbow"}
    # The arm has no continuum cells: von_mises is checked on a member in test_continuum.
    names = [k.name + arguments.get(k.name, "") for k in flextop.responses.KINDS if k.planar and k.name != "von_mises"]
    f, g = arm.run_with_sensitivities(np.full(arm.n_design, 0.4), names, h=0.05)
    assert f.shape == (len(names),) and np.all(np.isfinite(f)) and np.all(np.isfinite(g))
    doc = flextop.Simulation.run_with_sensitivities.__doc__
    with pytest.raises(SettingsError) as unknown:
        arm.run_with_sensitivities(np.full(arm.n_design, 0.4), ["stiffness"])
    for kind in flextop.responses.KINDS:
        if kind.planar:
            assert f"``{kind.syntax}``" in doc and kind.name in str(unknown.value)
    assert set(flextop.responses.PEAK_LIMITED) == {"stress", "shear", "buckling", "von_mises", "torque", "reaction"}


def test_one_registry_names_both_engines_responses(arm):
    """The engine's one table: a spatial scene offers the kinds it lists for spatial scenes,
    and its unknown name's error lists them; a spatial scene's own kind on a planar scene is
    refused as such. The shared names mean the same: on the paper's arm built as a spatial
    frame, the mean strain energy agrees with the planar engine's to the elements' difference
    (``test_spatial.py``)."""
    spatial = flextop.SpatialSimulation(flextop.scenes.spatial_robot_arm())
    with pytest.raises(SettingsError) as unknown:
        spatial.run_with_sensitivities(None, ["stiffness"])
    shared = {"compliance", "strain_energy", "tip_deflection", "stress", "buckling", "torque", "torque_squared",
              "reaction", "kinetic_energy"}
    assert set(flextop.responses.SPATIAL_NAMES) == shared | {"x", "y", "z"}
    assert shared <= set(flextop.responses.NAMES) and not {"x", "y", "z"} & set(flextop.responses.NAMES)
    for name in flextop.responses.SPATIAL_NAMES:
        assert name in str(unknown.value)
    with pytest.raises(SettingsError, match="a spatial scene's response; a planar scene offers compliance"):
        arm.run_with_sensitivities(np.full(arm.n_design, 0.4), ["x:link2[4,2]"])
    assert "``torque_squared:JOINT``" in flextop.responses.describe(spatial=True)


def test_static_scene_has_no_tip_deflection():
    sim = flextop.Simulation(flextop.scenes.static_truss())
    with pytest.raises(SettingsError, match="static scene has no motion"):
        sim.run_with_sensitivities(np.full(sim.n_design, 0.4), ["tip_deflection:truss[4,1]"])


def test_a_direct_analysis_too_large_for_memory_is_refused_up_front():
    sim = flextop.Simulation(flextop.scenes.robot_arm(nx=21, ny=5, split=4))
    with pytest.raises(SettingsError, match=r"direct method would hold 15\.0 GiB .* use method='adjoint'"):
        sim.run_with_sensitivities(np.full(sim.n_design, 0.4), ["tip_deflection"], method="direct")


def test_motor_torques_condense_the_drive_reactions(arm):
    """``torque_rms:JOINT`` is the RMS of the drive's torque τ = −λ by the trapezoidal
    rule; ``torque:JOINT`` a p-mean (p = 8) or KS mean over the motion, below the peak
    |τ| and rising towards it with p; the peak is reported beside the mean."""
    run = arm.run(0.4)
    tau, t = run.motor_torques["shoulder"], run.time
    rms = np.sqrt(np.trapezoid(tau**2, t) / t[-1])
    assert run.response("torque_rms:shoulder") == pytest.approx(rms, rel=1e-12)
    peak = np.abs(tau).max()
    assert run.peak("torque:shoulder") == pytest.approx(peak, rel=1e-12)
    means = [run.response(f"torque:shoulder:p={p}") for p in (2, 8, 32, 128)]
    assert means[0] == pytest.approx(rms, rel=1e-12)
    assert all(a < b for a, b in zip(means, means[1:])) and means[-1] < peak
    assert 1 - means[-1] / peak < 0.03  # the p-mean approaches the peak like 1/p
    ks = run.response("torque:shoulder:ks=50,scale=200")
    assert ks < peak and 1 - ks / peak < 0.1
    out = arm.run_with_sensitivities(0.4, ["torque:shoulder"])
    assert out.values[0] == pytest.approx(means[1], rel=1e-12) and out.peaks["torque:shoulder"] == pytest.approx(peak)
    with pytest.raises(SettingsError, match="not an aggregate"):
        run.peak("tip_deflection")


@pytest.mark.parametrize("name, match", [
    ("torque", "name the driven joint"),
    ("torque:bogus", "unknown joint 'bogus' .joints: shoulder, elbow"),
    ("torque_rms:elbow:p=4", "unknown option 'p'"),
])
def test_torque_responses_name_their_joint(arm, name, match):
    with pytest.raises(SettingsError, match=match):
        arm.run_with_sensitivities(0.4, [name])


def test_a_static_scene_has_no_motor_torque():
    truss = flextop.Simulation(flextop.scenes.static_truss())
    with pytest.raises(SettingsError, match="static scene has no motion to drive"):
        truss.run_with_sensitivities(0.4, ["torque_rms:support"])


@pytest.mark.parametrize("scene, settings", [
    (lambda: flextop.scenes.spun_beam(E=70e9 * 1e9), {}),  # material 1e9× nominal (a PlausibilityWarning too)
    (lambda: flextop.scenes.slider_crank(), {"tol": 1e-3}),  # a loose Newton tolerance
    (lambda: flextop.scenes.spun_beam(), {"tol": 1e-3, "newton": "modified"}),
])
def test_direct_and_adjoint_agree_at_the_extremes(scene, settings):
    """Both differentiate the same discrete solution, however loosely it was solved or
    however stiff its material: a fuzz campaign reported 29 % between them with material
    values 1e9× nominal or a Newton tolerance of 1e-3; measured here, they agree to round-off."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", flextop.errors.PlausibilityWarning)
        sim = flextop.Simulation(scene())
    direct = sim.run_with_sensitivities(0.5, ["tip_deflection", "strain_energy"], method="direct", **settings)
    adjoint = sim.run_with_sensitivities(0.5, ["tip_deflection", "strain_energy"], method="adjoint", **settings)
    assert np.array_equal(direct.values, adjoint.values)
    for d, a in zip(direct.gradients, adjoint.gradients):
        assert np.linalg.norm(d - a) <= 1e-12 * np.linalg.norm(d)
