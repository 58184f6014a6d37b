"""Shared fixtures: paths, and small scenes used across the tests."""

from pathlib import Path

import pytest

import flextop

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def cantilever(length: float = 1.0, split: int = 8, *, analysis: str = "dynamic") -> flextop.Scene:
    """A clamped aluminium cantilever along x (reference section), free end ``tip``."""
    scene = flextop.Scene("cantilever", analysis=analysis)
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    scene.node("root", 0.0, 0.0)
    scene.node("tip", length, 0.0)
    scene.beam("root", "tip", section="al", split=split, name="beam")
    scene.clamp("clamp", "root")
    return scene


@pytest.fixture(scope="session")
def arm() -> flextop.Simulation:
    return flextop.Simulation(flextop.scenes.robot_arm())
