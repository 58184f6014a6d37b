"""Never crash, never hang, never answer nonsense quietly: the reproducers of the fuzz
campaign, each a clean named error, a bounded time or a plausible result. Cases that
used to crash or hang run in a subprocess, so that a regression fails instead of taking the
suite down."""

import re
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest
from conftest import seconds_to_interrupt

import flextop
import flextop.cli
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
    assert "static equilibrium not reached past load factor 0.244320" in run.stdout
    assert "the load increment fell below 1e-6" in run.stdout


def test_a_zero_pivot_names_the_node():
    spec = flextop.scenes.static_truss().to_dict()
    for section in spec["sections"].values():
        section["E"] = 3e-308  # accepted, but its stiffness underflows
    # The first pivot below the smallest normal number, dense or sparse factors alike.
    with pytest.raises(flextop.SimulationError, match=r"singular iteration matrix at t = 0\.000000 s \(zero pivot at x of node 'truss\[4,0\]' \(bar truss/bar16\)\)"):
        flextop.Simulation(spec).run(0.4)
    spec["sections"]["aluminium"]["E"] = 5e-324
    with pytest.raises(SceneError, match="sections.aluminium.E: must be positive and finite, got 5e-324"):
        flextop.Simulation(spec)


def test_a_light_truss_has_a_positive_compliance():
    """At x = 0.02 the truss used to report a compliance of −20.8 J (Fᵀu < 0 under a dead
    load): a Newton iteration had jumped to another branch."""
    compliance = flextop.Simulation(flextop.scenes.static_truss()).run(0.02).response("compliance")
    assert compliance > 0


def outcome(sim, **settings):
    try:
        return sim.run(0.4, **settings).response("compliance")
    except flextop.SimulationError as error:
        return str(error)


@pytest.mark.parametrize("E", [1e3, 1e7])
def test_a_soft_truss_reaches_the_same_equilibrium_whatever_the_load_steps_or_refuses(E):
    """E = 1e3 Pa used to give tip rotations of −1.1e6 … −1.1e3 rad depending on the load
    steps: it is now refused (each equilibrium found winds a node by more than π/2 within
    one load step, however small), while E = 1e7 Pa converges to one equilibrium."""
    spec = flextop.scenes.static_truss().to_dict()
    for section in spec["sections"].values():
        section["E"] = E
    sim = flextop.Simulation(spec)
    outcomes = [outcome(sim, load_steps=n) for n in (1, 10, 100, 1000)]
    if any(isinstance(o, float) for o in outcomes):
        assert outcomes == pytest.approx([outcomes[0]] * 4, rel=1e-6)
    else:
        assert all("more load steps" in o for o in outcomes), outcomes
    assert isinstance(outcomes[0], float) == (E > 1e3)


def interrupted_within(body: str, wait: float) -> float:
    """Seconds from a SIGINT, sent ``wait`` s after a subprocess starts ``body`` (code that
    makes ``sim``, the arm at 4× its elements, available), to its ``KeyboardInterrupt``;
    the process then exits cleanly."""
    code = f"""
import time, flextop
from concurrent.futures import ThreadPoolExecutor
sim = flextop.Simulation(flextop.scenes.robot_arm(split=4))
print("ready", flush=True)
try:
{textwrap.indent(body, "    ")}
except KeyboardInterrupt:
    print("interrupted", time.monotonic(), flush=True)
"""
    return seconds_to_interrupt(code, wait, exit_within=30)


@pytest.mark.timed
@pytest.mark.parametrize("call", ["sim.run(0.4, h=1e-4)", "sim.run_with_sensitivities(0.4, 'tip_deflection', h=2e-4, method='adjoint')",
                                  "sim.run_with_sensitivities(0.4, 'tip_deflection', h=2e-4, method='direct')"])
def test_ctrl_c_interrupts_a_long_run_within_half_a_second(call):
    assert interrupted_within(call, 0.5) < 0.5


@pytest.mark.timed
def test_ctrl_c_stops_the_runs_on_a_thread_pool_too():
    """Python hears signals in its main thread only: the runs on the pool's threads stop at
    their next step when Ctrl-C reaches the main thread (11.8 s of waiting before)."""
    pool = "with ThreadPoolExecutor(2) as pool:\n    sim.map([0.4, 0.5, 0.6, 0.7], executor=pool, gradients=False, h=1e-4)"
    assert interrupted_within(pool, 1.0) < 1.0
    fresh = flextop.Simulation(flextop.scenes.robot_arm())
    flextop._core.cancel_running()
    assert fresh.run(0.4).tip_deflection() > 0, "a run started after a cancellation is not affected"


@pytest.mark.parametrize("name", ["robot_arm", "static_truss"])
@pytest.mark.parametrize("method", ["direct", "adjoint"])
def test_a_scene_without_design_variables_has_gradients_of_zero_columns(name, method):
    """Every bar fixed: the direct sweep used to panic (a chunk size of zero), and the
    gradients came back as (0, 0); the values equal a plain run's."""
    spec = getattr(flextop.scenes, name)().to_dict()
    for g in spec["ground_structures"]:
        g["fixed"] = True
    sim = flextop.Simulation(spec)
    out = sim.run_with_sensitivities(np.zeros(0), ["compliance", "volume"], method=method)
    assert out.gradients.shape == (2, 0)
    assert out.values[0] == pytest.approx(sim.run().response("compliance"), rel=1e-12)


def test_an_even_ny_arm_is_refused_by_its_builder():
    with pytest.raises(SceneError, match="robot_arm: ny must be odd"):
        flextop.scenes.robot_arm(ny=4)


def lee_frame(P: float) -> flextop.Scene:
    """Lee's frame (E = 720, A = 6, I = 2, L = 120, both supports pinned, P at 24 from the
    corner): its limit load is 18.55 EI/L² (Schweizerhof & Wriggers; Simo & Vu-Quoc)."""
    s = flextop.Scene("lee", analysis="static")
    s.section("frame", E=720.0, nu=0.3, rho=1.0, A=6.0, I=2.0, kappa=5.0 / 6.0)
    for name, x, y in [("base", 0.0, 0.0), ("corner", 0.0, 120.0), ("load", 24.0, 120.0), ("end", 120.0, 120.0)]:
        s.node(name, x, y)
    s.beam("base", "corner", section="frame", split=10)
    s.beam("corner", "load", section="frame", split=2)
    s.beam("load", "end", section="frame", split=8)
    s.pin("support_a", "base")
    s.pin("support_b", "end")
    s.load("load", force=(0.0, -P))
    s.simulation(load_steps=50)
    return s


def test_lee_frame_past_its_limit_load_reports_the_limit_load():
    limit = 18.55 * 720.0 * 2.0 / 120.0**2
    assert flextop.Simulation(lee_frame(0.9 * limit)).run().response("compliance") > 0
    P = 2.5
    with pytest.raises(flextop.SimulationError, match="a limit point or a mechanism may lie there") as info:
        flextop.Simulation(lee_frame(P)).run()
    load_factor = float(re.search(r"past load factor ([0-9.]+)", str(info.value)).group(1))
    assert load_factor * P == pytest.approx(limit, rel=0.015)  # 1.8646 against 1.855
    # A limit point, not a load too large for small displacements (the linear solution
    # moves the frame by 0.13 of its size): the linear analysis is not suggested.
    assert "linear" not in str(info.value)


@pytest.mark.parametrize("h", [1.0, 10.0, 100.0])
def test_huge_steps_over_a_long_time_fail_clearly(h):
    """t_end = 1e5 s with steps of 1 to 100 s used to fail Newton long after the arm had
    stopped, or to return rotations of hundreds of radians."""
    arm = flextop.Simulation(flextop.scenes.robot_arm())
    with pytest.raises(flextop.SimulationError, match=r"turned node '.*' by .* rad \(more than π/2 in one step\); use a smaller step h"):
        arm.run(0.4, t_end=1e5, h=h)


def test_energy_created_or_a_negative_compliance_is_warned_about():
    """No real run in the suite trips these guards (the arm's worst energy excess is 7e-4
    of its work, at h = 0.2 s), so they are checked on results made implausible by hand."""
    from flextop.simulation import _warn_if_energy_created, _warn_if_implausible_static

    res = flextop.Simulation(flextop.scenes.robot_arm()).run(0.4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _warn_if_energy_created(res)
    # Energy that appears after the start (the check compares changes since t = 0).
    res.raw["strain"] = res.raw["strain"] + 0.1 * np.abs(res.raw["drive_work"]).max() * (res.time > 0)
    with pytest.warns(flextop.PlausibilityWarning, match=r"the run created energy: at t = .* \(9\.1% of the largest\); use a smaller step h"):
        _warn_if_energy_created(res)
    static = flextop.Simulation(flextop.scenes.static_truss()).run(0.4)
    static.raw["q"] = -static.raw["q"]
    with pytest.warns(flextop.PlausibilityWarning, match=r"negative compliance F\^T u = -[0-9.]+ J under dead loads"):
        _warn_if_implausible_static(static)


def test_the_remaining_reproducers_give_named_errors(tmp_path, capsys):
    with pytest.raises(flextop.SceneFileError, match="no scene file given"):
        flextop.Scene.from_toml("")
    spec = flextop.scenes.static_truss().to_dict()
    spec["design"].update(x_min=1e-6, p=5.0)
    with pytest.raises(flextop.SimulationError, match="more than π/2 in one step"):
        flextop.Simulation(spec).run(1e-6)  # rotations of 1e27 rad before
    with pytest.raises(SettingsError, match="accuracy must be one of fast, balanced, accurate; got 'bogus'"):
        flextop.Simulation(flextop.scenes.static_truss(), accuracy="bogus")
    with pytest.raises(SettingsError, match="max_iter: must be at least 1"):
        flextop.Simulation(flextop.scenes.static_truss()).run(0.4, max_iter=0)
    with pytest.raises(SettingsError, match="step size 2 exceeds t_end 1.3"):
        flextop.Simulation(flextop.scenes.robot_arm()).run(0.4, h=2.0)
    blocker = tmp_path / "file"
    blocker.write_text("")
    code = flextop.cli.main(["simulate", "static_truss", "--out", str(blocker / "sub")])  # an output folder that cannot be made
    err = capsys.readouterr().err.strip()
    assert code == 1 and err.count("\n") == 0 and err.startswith("flextop: error:") and "Not a directory" in err, err


@pytest.mark.parametrize("key, value, words", [("E", 70.0, "sections.aluminium.E = 70 Pa is outside the plausible"),
                                               ("rho", 2.7, "sections.aluminium.rho = 2.7 kg/m³"),
                                               ("diameter", 20.0, "sections.aluminium.diameter = 20 m is wider than the whole")])
def test_a_slip_of_units_in_a_section_is_named_in_a_warning(key, value, words):
    """E = 70 (GPa meant) gave a 1,239 mm tip deflection on the 2 m arm, quietly."""
    spec = flextop.scenes.robot_arm().to_dict()
    spec["sections"]["aluminium"][key] = value
    with pytest.warns(flextop.errors.PlausibilityWarning, match=words):
        flextop.Simulation(spec)


@pytest.mark.parametrize("key, value, words", [("E", 70.0, r"members\[0\] \(rod\)\.E = 70 Pa is outside the plausible"),
                                               ("rho", 2.7, r"members\[0\] \(rod\)\.rho = 2\.7 kg/m³"),
                                               ("thickness", 5.0, r"members\[0\] \(rod\)\.thickness = 5 m is wider than the whole")])
def test_a_slip_of_units_in_a_member_is_named_in_a_warning(key, value, words):
    """A section with E = 70 and ρ = 2.7 was warned about twice, a continuum member with the
    same values (and a thickness of 5 m) not at all."""
    spec = flextop.scenes.continuum_slider_crank().to_dict()
    spec["members"][0][key] = value
    with pytest.warns(flextop.errors.PlausibilityWarning, match=words):
        flextop.Simulation(spec)


def test_the_reference_scenes_and_examples_are_plausible():
    import warnings
    from conftest import EXAMPLES
    with warnings.catch_warnings():
        warnings.simplefilter("error", flextop.errors.PlausibilityWarning)
        for path in sorted(EXAMPLES.glob("*.toml")):
            spatial = flextop.scenes.spatial.is_spatial(flextop.scenes.read_toml(path))
            (flextop.SpatialSimulation if spatial else flextop.Simulation)(path)
        for builder in flextop.scenes.BUILT_IN.values():
            flextop.Simulation(builder())


def test_a_drive_cut_off_by_t_end_is_named():
    """The arm's law brakes from 1.0472 s to T = (π/6)/0.5 + 0.5/2 = 1.2972 s: t_end = 1.2
    stops mid-braking, and an acceleration of 0.01 rad/s² is still accelerating at 1.3 s;
    a run that ends while a law cruises (a spin-up to constant speed) is left alone."""
    import warnings
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    T = np.pi / 6 / 0.5 + 0.25
    assert sim.joints[0].drive_phases == pytest.approx((0.25, T - 0.25, T))
    with pytest.warns(flextop.errors.SettingsWarning, match=r"joint 'shoulder': its motion law is still braking at t_end = 1.2 s "
                                                            r"\(done at t = 1.297 s\)"):
        sim.run(0.4, t_end=1.2)
    slow = flextop.Simulation(flextop.scenes.robot_arm(acceleration=0.01))
    with pytest.warns(flextop.errors.SettingsWarning, match="still accelerating"):
        slow.run(0.4)
    with warnings.catch_warnings():
        warnings.simplefilter("error", flextop.errors.SettingsWarning)
        sim.run(0.4)
        sim.run(0.4, t_end=0.8)  # cruising


WRONG = [0, -1, float("nan"), float("inf"), True, "x", None, 10**9, 1e9, 1e300, -0.0, 1e-300, (1, 2), [1], {"a": 1}, object()]
"""Values of the wrong type or range, as the fuzz campaign gave them."""


def test_the_example_builders_name_a_bad_argument():
    """ZeroDivisionError, IndexError, OverflowError and MemoryError came out of the example
    scenes' builders; every argument of every builder, given each wrong value, now builds a
    scene or raises a FlextopError."""
    import inspect
    foreign = []
    for name, builder in flextop.scenes.BUILT_IN.items():
        for argument in inspect.signature(builder).parameters:
            for value in WRONG:
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        flextop.Simulation(builder(**{argument: value}))
                except flextop.FlextopError:
                    pass
                except Exception as e:  # noqa: BLE001 - what the test looks for
                    foreign.append(f"{name}({argument}={value!r}): {type(e).__name__}: {e}")
    assert not foreign, "\n".join(foreign[:20])
    with pytest.raises(SceneError, match="pendulum: length must be > 0, got 0"):
        flextop.scenes.pendulum(length=0)
    with pytest.raises(SceneError, match="spun_beam: bars must be a whole number ≥ 1, got -1"):
        flextop.scenes.spun_beam(bars=-1)
    with pytest.raises(SceneError, match="robot_arm: nx must be a whole number ≥ 1, got '5'"):
        flextop.scenes.robot_arm(nx="5")
    with pytest.raises(SceneError, match="static_truss: force must be 2 numbers"):
        flextop.scenes.static_truss(force=(1.0,))
    with pytest.raises(SceneError, match="continuum_slider_crank: crank = 1e[+]300 is too large: the scene made of it overflows a float"):
        flextop.scenes.continuum_slider_crank(crank=1e300)  # an OverflowError of crank**2


@pytest.mark.parametrize("builder, counts, words", [
    (flextop.scenes.spun_beam, {"bars": 1_100_000}, "spun_beam: these arguments make 1,100,001 nodes, beyond the limit of 1,000,000"),
    (flextop.scenes.slider_crank, {"bars": 2_000_000}, "slider_crank: these arguments make 2,000,001 nodes"),
    (flextop.scenes.robot_arm, {"nx": 10**9}, "robot_arm: these arguments make 3,000,000,000 grid nodes, beyond the limit of 2,000"),
    (flextop.scenes.spun_beam, {"split": 5000}, "spun_beam: these arguments make 5,000 split, beyond the limit of 1,000"),
])
def test_the_builders_check_sizes_before_allocating(builder, counts, words):
    """spun_beam(bars=1_100_000) took 37 s and 2.5 GB before its size error; the limits are the
    engine's own (flextop.scenes.LIMITS), checked on the arguments."""
    tracemalloc = pytest.importorskip("tracemalloc")
    tracemalloc.start()
    try:
        with pytest.raises(SceneError, match=re.escape(words)):
            builder(**counts)
        assert tracemalloc.get_traced_memory()[1] < 10_000_000  # nothing of that size was made
    finally:
        tracemalloc.stop()


def test_scene_methods_given_wrong_types_raise_scene_errors():
    """189 cases of the builder's methods given wrong types ended in foreign exceptions
    (unhashable names, float() of a string, iterating a number); each wrong argument of
    each method is now a FlextopError, at the call or when the scene is built."""
    import itertools

    def base():
        s = flextop.Scene("f")
        s.section("s", E=70e9, nu=0.3, rho=2700.0, diameter=0.02)
        s.node("a", 0.0, 0.0)
        s.node("b", 1.0, 0.0)
        s.beam("a", "b", section="s", name="ab")
        s.pin("p", "a", drive=flextop.trapezoidal(0.0, 1.0, acceleration=1.0, speed=1.0))
        return s

    calls = {
        "section": (("t",), dict(E=70e9, nu=0.3, rho=2700.0, diameter=0.02)),
        "node": (("c", 2.0, 0.0), {}),
        "ground_structure": (("g",), dict(nx=3, ny=3, length=1.0, height=0.1, section="s")),
        "beam": (("a", "b"), dict(section="s", split=2, name="x")),
        "rigid_body": (("rb",), dict(mass=1.0, position=(0.0, 1.0))),
        "point_mass": (("b", 1.0), {}),
        "load": (("b",), dict(force=(0.0, 1.0), table=([0.0, 1.0], [0.0, 1.0]))),
        "clamp": (("c", "b"), {}),
        "hinge": (("h", "a", "b"), {}),
        "prismatic": (("s", "b"), dict(axis=(1.0, 0.0))),
        "spring": (("sp", "a", "b"), dict(k=1.0)),
        "joint_spring": (("js", "p"), dict(k=1.0)),
        "motor": (("m", "p"), dict(torque=1.0)),
        "split": (("ab", 2), {}),
        "initial_rate": (("p", 1.0), {}),
        "design": ((), dict(interpolation="simp", p=3.0)),
        "simulation": ((), dict(t_end=0.1, h=0.01)),
    }
    foreign = []
    for method, (args, kwargs) in calls.items():
        slots = [*range(len(args)), *kwargs]
        for slot, value in itertools.product(slots, WRONG):
            a, k = list(args), dict(kwargs)
            if isinstance(slot, int):
                a[slot] = value
            else:
                k[slot] = value
            scene = base()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    getattr(scene, method)(*a, **k)
                    flextop.Simulation(scene).run(t_end=0.05)
            except flextop.FlextopError:
                pass
            except Exception as e:  # noqa: BLE001 - what the test looks for
                foreign.append(f"{method}({slot}={value!r}): {type(e).__name__}: {e}")
    assert not foreign, "\n".join(foreign[:20])


def test_a_long_run_reports_its_progress_and_its_reporter_can_stop_it():
    """A long `flextop simulate` showed no progress: the engine now reports the time it
    reached to a callback (the command line's progress bar)."""
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    reached = []
    res = sim.run(0.4, h=5e-4, progress=reached.append)  # about a second of work: reports every 50 ms
    assert len(reached) >= 3 and np.all(np.diff(reached) > 0) and 0.0 <= reached[0] and reached[-1] <= res.time[-1]
    assert set(reached) <= set(res.time.tolist())  # the times of states reached, not guesses

    class Enough(Exception):
        pass

    def stop(t):
        if t > 0.2:
            raise Enough(t)
    with pytest.raises(Enough):
        sim.run(0.4, h=5e-4, progress=stop)
    with pytest.raises(SettingsError, match="a run to a tolerance makes several"):
        sim.run(0.4, rtol=1e-2, progress=print)
