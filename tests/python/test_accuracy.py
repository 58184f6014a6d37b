"""Accuracy presets refine the scene and order the errors as documented."""

import numpy as np
import pytest

import flextop
from flextop.accuracy import PRESETS


def test_presets_refine_split_and_step_and_keep_explicit_settings():
    for name, p in PRESETS.items():
        sim = flextop.Simulation(flextop.scenes.robot_arm(split=3), accuracy=name)
        per_bar = (sim.model.n_dofs // 3 - 30) / 148 + 1  # elements per bar from the node count
        assert per_bar == max(3, p.split)
        res = sim.run(0.4, t_end=0.1)
        assert res.raw["h"] == pytest.approx(0.02 / p.step_divisor)
    sim = flextop.Simulation(flextop.scenes.robot_arm(), accuracy="accurate")
    assert sim.run(0.4, h=0.02, t_end=0.1).raw["h"] == 0.02, "an explicit setting wins over the preset"
    with pytest.raises(ValueError, match="accuracy must be one of fast, balanced, accurate"):
        flextop.Simulation(flextop.scenes.robot_arm(), accuracy="exact")


def test_preset_errors_fall_as_documented():
    """d of the robot arm against a refined reference (m = 8, h = 0.0025): the documented
    errors (0.55 %, 0.23 %, 0.07 % against the converged value) with some margin."""
    reference = flextop.Simulation(flextop.scenes.robot_arm(split=8)).run(0.4, h=0.0025).tip_deflection()
    errors = {name: abs(flextop.Simulation(flextop.scenes.robot_arm(), accuracy=name).run(0.4).tip_deflection() / reference - 1)
              for name in PRESETS}
    assert errors["fast"] > errors["balanced"] > errors["accurate"]
    assert errors["fast"] < 8e-3 and errors["balanced"] < 3.5e-3 and errors["accurate"] < 1.2e-3, errors
