"""Never crash, never hang, never answer nonsense quietly: the reproducers of the fuzz
campaign, each a clean named error, a bounded time or a plausible result. Cases that
used to crash or hang run in a subprocess, so that a regression fails instead of taking the
suite down."""

import signal
import subprocess
import sys
import time

import pytest

import flextop
from flextop import SceneError, SettingsError


def in_subprocess(code: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("where", ["joints'][0]['node", "ground_structures'][1]['origin"])
def test_deeply_nested_scene_values_are_a_scene_error(where):
    run = in_subprocess(f"""
import flextop, flextop._core as core
spec = flextop.scenes.robot_arm().to_dict()
value = "link1[0,0]"
for _ in range(100_000):
    value = [value]
spec['{where}'] = value
for build in (flextop.Simulation, core.Model.from_dict):
    try:
        build(spec)
    except flextop.SceneError as error:
        print(error)
""")
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["scene: nested too deeply to be a scene", "scene: nested more than 64 levels deep"]


@pytest.mark.parametrize("entry, value, message", [
    ("nx", 1000, "1000 × 3 grid nodes: at most 2000 per ground structure"),
    ("nx", 2**32, "4294967296 × 3 grid nodes"),
    ("split", 2**63 - 1, "split: must be from 1 to 1000, got 9223372036854775807"),
])
def test_sizes_beyond_the_limits_are_refused_before_building(entry, value, message):
    spec = flextop.scenes.robot_arm().to_dict()
    spec["ground_structures"][0][entry] = value
    with pytest.raises(SceneError, match=message):
        flextop.Simulation(spec)


def test_too_many_load_steps_are_refused():
    with pytest.raises(SettingsError, match="load_steps: 1000000000000: at most 1000000"):
        flextop.Simulation(flextop.scenes.static_truss()).run(0.4, load_steps=10**12)


def test_a_static_solve_past_a_limit_point_ends_with_a_clear_error():
    """The truss at x = 0.01 with a tip moment used to spin forever."""
    run = in_subprocess("""
import flextop
spec = flextop.scenes.static_truss().to_dict()
spec["loads"].append({**spec["loads"][0], "force": [0.0, 0.0], "moment": 1.0})
try:
    flextop.Simulation(spec).run(0.01)
except flextop.SimulationError as error:
    print(error)
""", timeout=120)
    assert run.returncode == 0, run.stderr
    assert "static equilibrium not reached past load factor" in run.stdout
    assert "the load increment fell below 1e-6" in run.stdout


def test_a_soft_truss_reaches_the_same_equilibrium_whatever_the_load_steps():
    spec = flextop.scenes.static_truss().to_dict()
    for section in spec["sections"].values():
        section["E"] = 1e3
    sim = flextop.Simulation(spec)
    compliances = [sim.run(0.4, load_steps=n).response("compliance") for n in (1, 10, 100, 1000)]
    assert compliances == pytest.approx([compliances[0]] * 4, rel=1e-6)


@pytest.mark.parametrize("call", ["sim.run(0.4, h=1e-4)", "sim.run_with_sensitivities(0.4, 'tip_deflection', h=2e-4, method='adjoint')",
                                  "sim.run_with_sensitivities(0.4, 'tip_deflection', h=2e-4, method='direct')"])
def test_ctrl_c_interrupts_a_long_run_within_half_a_second(call):
    code = f"""
import time, flextop
sim = flextop.Simulation(flextop.scenes.robot_arm(split=4))
print("ready", flush=True)
try:
    {call}
except KeyboardInterrupt:
    print("interrupted", time.monotonic(), flush=True)
"""
    process = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert process.stdout.readline().strip() == "ready"
        time.sleep(0.5)
        sent = time.monotonic()
        process.send_signal(signal.SIGINT)
        word, at = process.stdout.readline().split()
        assert word == "interrupted" and float(at) - sent < 0.5
    finally:
        process.kill()
        process.wait()

