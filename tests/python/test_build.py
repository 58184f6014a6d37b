"""Building a scene: the mechanism analysis (mobility, redundant rows and the joints that
over-constrain, refusals) on mechanisms with loops, as the dense analysis it replaced
reported them; loops of hundreds of bodies; and Ctrl-C during the build of a large scene."""

import subprocess
import sys
import textwrap
import warnings

import pytest
from conftest import HEARS_CTRL_C, seconds_to_interrupt

import flextop
from flextop import SceneError
from flextop.errors import MechanismWarning


def link(scene: flextop.Scene, name: str, p: tuple[float, float], q: tuple[float, float]) -> None:
    """A rigid body from ``p`` to ``q`` (1 kg, 0.1 kg m²) with its ends as points ``p`` and ``q``."""
    mid = ((p[0] + q[0]) / 2, (p[1] + q[1]) / 2)
    scene.rigid_body(name, mass=1.0, inertia=0.1, position=mid,
                     points={"p": (p[0] - mid[0], p[1] - mid[1]), "q": (q[0] - mid[0], q[1] - mid[1])})


def four_bar(analysis: str = "dynamic") -> flextop.Scene:
    """A four-bar of rigid bodies: crank, coupler and rocker, pinned at (0, 0) and (3, 0)."""
    s = flextop.Scene("four_bar", analysis=analysis, gravity=(0.0, -9.81))
    link(s, "crank", (0.0, 0.0), (0.0, 1.0))
    link(s, "coupler", (0.0, 1.0), (2.5, 1.5))
    link(s, "rocker", (2.5, 1.5), (3.0, 0.0))
    s.pin("A", "crank.p")
    s.hinge("B", "crank.q", "coupler.p")
    s.hinge("C", "coupler.q", "rocker.p")
    s.pin("D", "rocker.q")
    return s


def frames(name: str) -> flextop.Scene:
    s = flextop.Scene(name, gravity=(0.0, -9.81))
    s.section("al", E=70e9, nu=0.3, rho=2700.0, diameter=0.02)
    return s


def chain(n: int, rise: float, pins: tuple[int, ...] = ()) -> flextop.Scene:
    """A hinge chain of ``n`` bodies from (0, 0) to (n, 0), every other joint raised by
    ``rise``, pinned at both ends and at the left end of each body in ``pins``."""
    s = flextop.Scene("chain", gravity=(0.0, -9.81))
    joint = [(float(k), rise * (k % 2)) for k in range(n + 1)]
    for k in range(n):
        link(s, f"b{k}", joint[k], joint[k + 1])
    s.pin("start", "b0.p")
    for k in range(1, n):
        s.hinge(f"h{k}", f"b{k - 1}.q", f"b{k}.p")
    s.pin("end", f"b{n - 1}.q")
    for k in pins:
        s.pin(f"pin{k}", f"b{k}.p")
    return s


def test_a_rigid_four_bar_has_one_free_mode_and_starts_in_the_motion_of_its_crank():
    sim = flextop.Simulation(four_bar())
    assert sim.mechanism == {"frames": 3, "mobility": 1, "redundant_rows": 0, "repeated_rows": 0, "over_constraining": []}
    scene = four_bar()
    scene.initial_rate("A", 1.0)
    qdot = flextop.Simulation(scene).run(t_end=0.01, h=0.01).qdot[0]
    expected = [-0.5, 0.0, 1.0, -0.96875, -0.15625, -0.125, -0.46875, -0.15625, 0.625]
    assert qdot == pytest.approx(expected, abs=1e-12)
    scene.initial_rate("B", 0.5)
    with pytest.raises(SceneError, match="initial_rates: these rates ask for a motion the joints forbid"):
        flextop.Simulation(scene)


def test_a_static_four_bar_is_refused_for_its_free_mode_unless_a_spring_holds_it():
    with pytest.raises(SceneError, match=r"mechanism with 1 free rigid-body mode\(s\)"):
        flextop.Simulation(four_bar("static"))
    held = four_bar("static")
    held.joint_spring("torsion", "A", k=10.0)
    assert flextop.Simulation(held).mechanism["mobility"] == 1


def three_rockers() -> flextop.Scene:
    """Three rockers pinned below a rigid coupler (two beams meeting at the middle rocker)."""
    s = frames("three_rockers")
    for k in range(3):
        s.node(f"g{k}", float(k), 0.0)
        s.node(f"t{k}", float(k), 1.0)
        s.node(f"c{k}", float(k), 1.0)
        s.beam(f"g{k}", f"t{k}", section="al", name=f"rocker{k}")
        s.pin(f"ground{k}", f"g{k}")
    s.beam("c0", "c1", section="al", name="coupler_a")
    s.beam("c1", "c2", section="al", name="coupler_b")
    for k in range(3):
        s.hinge(f"top{k}", f"t{k}", f"c{k}")
    return s


def test_a_coupler_on_three_parallel_rockers_is_over_constrained_by_every_joint():
    """A parallelogram with one rocker too many: one redundant row, whose dependency runs
    through every pin and hinge."""
    s = three_rockers()
    names = ["ground0", "ground1", "ground2", "top0", "top1", "top2"]
    with pytest.warns(MechanismWarning, match=r"'ground0', 'ground1', 'ground2', 'top0', 'top1', 'top2' over-constrain .* \(1 redundant"):
        sim = flextop.Simulation(s)
    assert sim.mechanism == {"frames": 4, "mobility": 1, "redundant_rows": 1, "repeated_rows": 0, "over_constraining": names}


def test_a_body_pinned_twice_is_refused_and_a_frame_pinned_twice_repeats_a_row_without_a_warning():
    """A rigid body's two pins repeat a constraint on its three unknowns: the second pin is
    named. A beam pinned at both ends runs (the beam stretches): its rigid frame has one
    redundant row between the two pins, a repetition that holds in every motion (the frame
    welded to the ground), so no warning. A drive on one of the pins makes it a conflict."""
    s = flextop.Scene("bar")
    link(s, "bar", (0.0, 0.0), (1.0, 0.0))
    s.pin("left", "bar.p")
    s.pin("right", "bar.q")
    with pytest.raises(SceneError, match=r"joints\[1\] \(right\): over-constrained"):
        flextop.Simulation(s)

    def beam(drive: bool) -> flextop.Scene:
        s = frames("beam")
        s.node("a", 0.0, 0.0)
        s.node("b", 1.0, 0.0)
        s.beam("a", "b", section="al")
        s.pin("left", "a", drive=flextop.trapezoidal(0.0, 0.1, acceleration=1.0, speed=0.1) if drive else None)
        s.pin("right", "b")
        return s

    with warnings.catch_warnings():
        warnings.simplefilter("error", MechanismWarning)
        sim = flextop.Simulation(beam(drive=False))
    assert sim.mechanism == {"frames": 1, "mobility": 0, "redundant_rows": 1, "repeated_rows": 1, "over_constraining": []}
    with pytest.warns(MechanismWarning, match=r"'left', 'right' over-constrain .* \(1 redundant"):
        sim = flextop.Simulation(beam(drive=True))
    assert sim.mechanism == {"frames": 1, "mobility": 0, "redundant_rows": 2, "repeated_rows": 1, "over_constraining": ["left", "right"]}


def test_a_ring_hinged_at_every_node_of_an_edge_repeats_rows_without_a_warning():
    """The continuum arm's rings (a light body hinged at each node of a member's edge) weld
    the body to the member: all but three of their rows repeat, and nothing is warned.
    (A repetition beside a true over-constraint: test_stability's locked four-bar.)"""
    with warnings.catch_warnings():
        warnings.simplefilter("error", MechanismWarning)
        sim = flextop.Simulation(flextop.scenes.continuum_robot_arm(nx=4, ny=2))
    info = sim.mechanism
    assert info["over_constraining"] == [] and info["redundant_rows"] == info["repeated_rows"]
    # Three rings of three nodes each: 6 rows a ring on 3 relative coordinates.
    assert info["redundant_rows"] == 3 * (2 * 3 - 3)


def test_a_loop_of_three_hundred_bodies_keeps_every_free_mode_and_a_straight_one_is_at_a_dead_centre():
    """A zig-zag chain pinned at both ends: 3n unknowns, 2(n + 1) independent rows; two more
    pins take four more. Straight, its end pin repeats what the chain's rows already hold
    (a dead centre), and is named."""
    n = 300
    assert flextop.Simulation(chain(n, 0.25)).mechanism == {"frames": n, "mobility": n - 2, "redundant_rows": 0, "repeated_rows": 0,
                                                            "over_constraining": []}
    assert flextop.Simulation(chain(n, 0.25, pins=(100, 200))).mechanism["mobility"] == n - 6
    with pytest.raises(SceneError, match=rf"joints\[{n}\] \(end\): over-constrained"):
        flextop.Simulation(chain(n, 0.0))


def interrupted_within(call: str, wait: float, n: int = 200_000) -> float:
    """Seconds from a SIGINT, sent ``wait`` s after a subprocess starts building a hinge
    chain of ``n`` bodies over and over with ``call`` (on ``spec``), to its
    ``KeyboardInterrupt``; the process then exits cleanly. The interpreter's cyclic garbage
    collector is off in it: a full collection over the scene dict and the Simulation's deep
    copy of it (four million objects) pauses signal handling for half a second or more on a
    loaded machine (two clean-clone CI runs failed at 0.57 and 0.60 s), a pause of Python's,
    not of the build's polls that this measures."""
    code = f"""
import gc, time, flextop
gc.disable()
n = {n}
spec = {{"name": "chain", "gravity": [0.0, -9.81],
        "rigid_bodies": [{{"name": f"b{{k}}", "mass": 1.0, "inertia": 0.1, "position": [k + 0.5, 0.0],
                          "points": {{"l": [-0.5, 0.0], "r": [0.5, 0.0]}}}} for k in range(n)],
        "joints": [{{"kind": "pin", "name": "p0", "node": "b0.l"}}]
                  + [{{"kind": "hinge", "name": f"h{{k}}", "nodes": [f"b{{k - 1}}.r", f"b{{k}}.l"]}} for k in range(1, n)]}}
print("ready", flush=True)
try:
    while True:
{textwrap.indent(call, " " * 8)}
except KeyboardInterrupt:
    print("interrupted", time.monotonic(), flush=True)
"""
    return seconds_to_interrupt(code, wait, exit_within=60)


@pytest.mark.timed
@pytest.mark.parametrize(("call", "wait"), [("flextop._core.Model.from_dict(spec)", 1.0),
                                            ("flextop._core.Model.from_dict(spec)", 4.0),
                                            ("flextop.Simulation(spec)", 9.0)])
def test_ctrl_c_stops_the_build_of_two_hundred_thousand_bodies_within_half_a_second(call, wait):
    """The model of 200,000 hinged bodies takes seconds to read and build (the dict read
    with the GIL held, the model built on a thread of its own): Ctrl-C used to wait for it
    all, and now stops either within a poll (50 ms)."""
    assert interrupted_within(call, wait) < 0.5


def test_a_build_after_an_interrupted_one_is_whole():
    """The interrupted build's thread frees what it made on its own; the next build of the
    same scene is the same model."""
    code = HEARS_CTRL_C + """
import signal, threading, time, flextop
spec = flextop.scenes.robot_arm().to_dict()
threading.Timer(0.05, signal.raise_signal, (signal.SIGINT,)).start()
try:
    while True:
        flextop._core.Model.from_dict(spec)
except KeyboardInterrupt:
    pass
model = flextop._core.Model.from_dict(spec)
print(model.n_dofs, model.n_constraints, len(model.joints()))
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    reference = flextop.Simulation(flextop.scenes.robot_arm()).model
    assert run.stdout.split() == [str(reference.n_dofs), str(reference.n_constraints), str(len(reference.joints()))]
