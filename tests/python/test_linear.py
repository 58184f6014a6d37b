"""The linear static analysis (``analysis = "linear"``): ``K₀ u = f`` about the reference, the
joints linear about it, the load at once. Exactly linear in the load, the nonlinear
equilibrium's small-load limit, exact gradients; the 88-line code's half-MBB in the code's
own units through the command line; the nonlinear failure that points to it; bad input
named."""

import json
import re
import warnings

import numpy as np
import pytest
from conftest import EXAMPLES, assert_exact_gradients, fourth_order
from top88 import top88

import flextop
import flextop.cli
from flextop import Scene
from flextop.errors import PlausibilityWarning
from flextop.spatial import from_planar

STEEL = flextop.scenes.STEEL


def braced_plate(load: float = 1e3, analysis: str = "linear") -> flextop.Simulation:
    """A steel plate of 6 × 2 plain cells pinned along its left edge and braced from above by
    a beam (a bar, designed too) to its top-right corner, ``load`` (N) down at its
    bottom-right corner: continuum member and bar in one static scene."""
    s = Scene("braced plate", analysis="static")
    m = s.member("plate", nx=6, ny=2, length=0.6, height=0.2, thickness=0.01, **STEEL, solid_at_joints=False, cell="plain")
    for j in range(3):
        s.pin(f"wall{j}", m.node(0, j))
    section = s.section("steel", **STEEL, diameter=0.02)
    s.pin("anchor", s.node("top", 0.0, 0.5))
    s.beam("top", m.node(6, 2), section=section, name="brace")
    s.load(m.node(6, 0), force=(0.0, -load))
    s.design(interpolation="simp", p=3.0, x_min=1e-3)
    s.simulation(analysis=analysis)
    with warnings.catch_warnings():  # the pinned edge only repeats rows
        warnings.simplefilter("ignore", flextop.errors.MechanismWarning)
        return flextop.Simulation(s)


RESPONSES = ["compliance", "strain_energy", "strain_energy:plate", "displacement:plate[6,0]:0,1", "volume"]


def design(sim: flextop.Simulation) -> np.ndarray:
    return np.random.default_rng(5).uniform(0.3, 1.0, sim.n_design)


def test_the_linear_analysis_is_exactly_linear_in_the_load():
    """Seven times the load: seven times the displacement, 49 times the compliance and the
    energies and their gradients, to round-off; the strain energy is half the compliance
    (Clapeyron), the plate's and the brace's together."""
    x = design(braced_plate())
    (f1, g1), (f7, g7) = (braced_plate(load).run_with_sensitivities(x, RESPONSES) for load in (1e3, 7e3))
    scale = np.array([49, 49, 49, 7, 1])
    np.testing.assert_allclose(f7, scale * f1, rtol=1e-13)
    np.testing.assert_allclose(g7, scale[:, None] * g1, rtol=0, atol=1e-13 * np.abs(g7).max())
    assert f1[1] == pytest.approx(f1[0] / 2, rel=1e-13) and f1[2] < f1[1]
    run = braced_plate().run(x)
    assert run.analysis == "linear" and run.newton == {"total": 1, "load_steps": 1}
    assert run.response("strain_energy") == pytest.approx(f1[1], rel=1e-14)


def test_the_nonlinear_equilibrium_tends_to_the_linear_solution_as_the_load_falls():
    """The nonlinear analysis departs from the linear one at first order in the load: values
    and gradients divided by the load's power, 100 times less load, 100 times less departure
    (measured 1.8e-4 at 1 kN, 1.8e-6 at 10 N); the displacement at 10 N within 2e-6."""
    x = design(braced_plate())
    linear = np.column_stack(braced_plate(1.0).run_with_sensitivities(x, RESPONSES[:4]))
    departures = []
    for load in (1e3, 10.0):
        f, g = braced_plate(load, "nonlinear").run_with_sensitivities(x, RESPONSES[:4], tol=1e-13)
        powers = np.array([2, 2, 2, 1])[:, None]
        computed = np.column_stack([f, g]) / load**powers
        departures.append(np.abs(computed - linear).max(axis=1) / np.abs(linear).max(axis=1))
    ratio = departures[0] / departures[1]
    assert np.all((ratio > 90) & (ratio < 110)), departures
    assert departures[1].max() < 2e-6, departures


def test_the_gradients_of_the_linear_analysis_are_exact():
    """Densities of the plate's cells and of the brace: direct = adjoint to 1e-9, fourth-order
    differences to 1e-6, for the compliance, the strain energies and a displacement."""
    sim = braced_plate()
    assert_exact_gradients(sim, design(sim), RESPONSES[:4], columns=[0, 4, 11, sim.n_design - 1])


def test_the_gradients_are_exact_on_a_mix_of_void_and_solid_cells():
    """Void cells (0.03: their blend below its step, which the linear cell does not read,
    its K₀ the same at every blend) beside solid ones (0.99): direct = adjoint to 1e-9, and
    fourth-order differences to 1e-6 of each response's largest entry (measured 3e-7),
    void, solid and the brace; the solve's round-off at this contrast of stiffness (3.6e4)
    keeps differences from resolving the solid cells' small entries better."""
    sim = braced_plate()
    x = np.resize([0.03, 0.6, 0.99], sim.n_design)
    x[[4, 10, sim.n_design - 1]] = 0.99  # the tip's cells and the brace carry the load
    run = lambda xx, method="adjoint": sim.run_with_sensitivities(xx, RESPONSES[:4], method=method)  # noqa: E731
    (f, g), (_, g_direct) = run(x), run(x, "direct")
    np.testing.assert_allclose(g_direct, g, rtol=0, atol=1e-9 * np.abs(g).max())
    largest = np.abs(g).max(axis=1)
    for j in (0, 3, 4, sim.n_design - 1):
        step = np.zeros_like(x)
        step[j] = 1.0
        fd = fourth_order(lambda h: run(x + h * step)[0], 5e-4)
        assert np.all(np.abs(fd - g[:, j]) <= 1e-6 * largest), (j, np.abs(fd - g[:, j]) / largest)


def half_mbb_unit() -> flextop.Simulation:
    """The example; its E = 1 and rho = 1 are not warned about: a linear analysis has no
    units of its own (the same scene solved nonlinear warns)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlausibilityWarning)
        sim = flextop.Simulation(flextop.Scene.from_toml(EXAMPLES / "half_mbb_unit.toml"))
    spec = sim.spec | {"simulation": {}}
    with pytest.warns(PlausibilityWarning, match=r"members\[0\] \(beam\)\.(E|rho) = 1 "):
        flextop.Simulation(Scene.from_dict(spec))
    return sim


def test_the_half_mbb_in_the_codes_own_units_through_the_command_line(tmp_path, capsys):
    """``examples/half_mbb_unit.toml`` (E = 1, a unit load, the linear analysis) through
    ``flextop optimize`` with the code's density filter, OC and stop: every iterate's
    compliance is the code's with its bisection made exact (measured 1.2e-9 over the 146
    iterations; the 1e-9 load of ``test_top88.py`` agrees to 1.1e-8), the run stops where
    it stops, and the published code's numbers come out, 1007.02 at the start and 233.71
    at the end. The nonlinear analysis cannot carry that load."""
    exact, _ = top88(60, 20, 0.5, 3.0, 2.4, 2, bisection=1e-13)
    published, _ = top88(60, 20, 0.5, 3.0, 2.4, 2)
    out = tmp_path / "mbb"
    argv = ["optimize", str(EXAMPLES / "half_mbb_unit.toml"), "--global-volume", "--volume-fraction", "0.5", "--x0", "0.5",
            "--filter-cells", "2.4", "--method", "oc", "--xtol", "0.01", "--max-iter", "200", "--out", str(out), "--no-plots",
            "--no-cad"]
    assert flextop.cli.main(argv) == 0
    saved = json.loads((out / "history.json").read_text())
    ours = np.array([record["f0"] for record in saved["history"]]) * saved["objective_scale"]
    assert saved["status"] == "FIXED_POINT" and len(ours) == len(exact) + 1
    np.testing.assert_allclose(ours[:-1], exact, rtol=1e-8)
    assert ours[0] == pytest.approx(published[0], rel=1e-9) and ours[0] == pytest.approx(1007.02, abs=5e-3)
    assert ours[-2] == pytest.approx(published[-1], rel=1e-3) and ours[-1] == pytest.approx(233.71, abs=5e-3)
    assert "233.71" in capsys.readouterr().out


def test_a_nonlinear_failure_under_a_large_load_points_to_the_linear_analysis():
    """The half-MBB in the code's units, solved nonlinear, fails; the linear solution moves
    the loaded corner by 15.9 times the beam's size (its diagonal), and the message says how
    to select the linear analysis. The steel half-MBB whose Newton is given one iteration
    fails too, where the linear solution moves it by 3e-5 of its size: no such hint."""
    sim = half_mbb_unit()
    with pytest.raises(flextop.SimulationError) as raised:
        sim.run(0.5, analysis="nonlinear")
    message = str(raised.value)
    assert message.startswith("static equilibrium not reached"), message
    assert re.search(r"The linear solution moves node 'beam\[0,20\]' by 15\.92\d times the model's size", message), message
    assert 'analysis = "linear" in the scene\'s [simulation] table, analysis="linear" in Python' in message
    assert "--analysis linear" in message
    steel = flextop.Simulation(flextop.scenes.half_mbb())
    with pytest.raises(flextop.SimulationError) as raised:
        steel.run(0.5, max_iter=1)
    assert "linear" not in str(raised.value)


def test_bad_input_is_named():
    """An unknown analysis, the linear analysis of a dynamic scene (asked for by a run or in
    its [simulation] table) or given as the scene's kind, a response it does not offer, scene
    parameters and a spatial scene's equilibrium (not built there): each a SettingsError or
    SceneError that names it."""
    sim = braced_plate()
    x = design(sim)
    with pytest.raises(flextop.SettingsError, match=r"^analysis: must be one of 'nonlinear', 'linear', got 'Linear'$"):
        sim.run(x, analysis="Linear")
    with pytest.raises(flextop.SettingsError, match=r"^response 'von_mises': not built for the linear analysis .*"
                                                    r"offers compliance, strain_energy, volume, displacement"):
        sim.run_with_sensitivities(x, ["compliance", "von_mises"])
    with pytest.raises(flextop.SettingsError, match=r"^response 'von_mises': not built for the linear analysis"):
        sim.run(x).response("von_mises")
    with pytest.raises(flextop.SettingsError, match=r"^parameters: the scene parameters' gradients are not built"):
        sim.run_with_sensitivities(x, ["compliance"], parameters=["E:steel"])
    dynamic = flextop.Simulation(flextop.scenes.robot_arm())
    with pytest.raises(flextop.SettingsError, match=r"^analysis: 'linear' is a static analysis"):
        dynamic.run(0.4, analysis="linear", t_end=0.1)
    spec = flextop.scenes.robot_arm().to_dict()
    spec["simulation"]["analysis"] = "linear"
    with pytest.raises(flextop.SceneError, match=r"^simulation\.analysis: 'linear' is a static analysis"):
        flextop.Simulation(Scene.from_dict(spec))
    spec = flextop.scenes.half_mbb(nx=4, ny=2).to_dict() | {"analysis": "linear"}
    with pytest.raises(flextop.SceneError, match=r'^analysis: unknown value `linear`, expected `dynamic` or `static`: a static '
                                                 r'scene\'s linear analysis is analysis = "static" here and analysis = "linear" in its'):
        flextop.Simulation(Scene.from_dict(spec))
    with pytest.raises(flextop.SceneError, match=r"^half_mbb: analysis must be 'nonlinear' or 'linear', got 'lin'$"):
        flextop.scenes.half_mbb(analysis="lin")
    spatial = from_planar(flextop.scenes.static_truss()).to_dict()
    spatial["simulation"] = {"analysis": "linear"}
    with pytest.raises(flextop.SettingsError, match=r"^analysis: the linear analysis is built for planar scenes"):
        flextop.SpatialSimulation(spatial).equilibrium()
