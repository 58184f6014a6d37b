"""Accuracy presets are named tolerances, and each holds on the arm."""

import pytest

import flextop
from flextop.discretization.accuracy import PRESETS
from flextop.errors import SettingsError


def test_presets_are_named_tolerances_and_an_explicit_step_wins():
    for name, rtol in PRESETS.items():
        assert flextop.Simulation(flextop.scenes.robot_arm(), accuracy=name).rtol == rtol
    sim = flextop.Simulation(flextop.scenes.robot_arm(), accuracy="accurate")
    res = sim.run(0.4, h=0.02, t_end=0.1)
    assert res.raw["h"] == 0.02 and res.discretization is None, "an explicit step wins over the preset"
    with pytest.raises(SettingsError, match="accuracy must be one of fast, balanced, accurate"):
        flextop.Simulation(flextop.scenes.robot_arm(), accuracy="exact")
    with pytest.raises(SettingsError, match="not both"):
        flextop.Simulation(flextop.scenes.robot_arm(), accuracy="fast", rtol=1e-3)


def test_each_preset_holds_its_tolerance_on_the_arm(arm_references):
    """d of the robot arm at x = 0.4 against the converged reference, for every preset."""
    for name, rtol in PRESETS.items():
        res = flextop.Simulation(flextop.scenes.robot_arm(), accuracy=name).run(0.4)
        error = abs(res.tip_deflection() / arm_references[0.4] - 1)
        assert error <= rtol, (name, error, res.discretization)
        assert res.errors["tip_deflection"] <= rtol
