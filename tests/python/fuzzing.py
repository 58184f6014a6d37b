"""Fuzzing flextop: hypothesis strategies for bad and extreme input (scene dicts, planar and spatial, TOML
text, designs, settings, response names), and a worker process that runs each case, so
that a crash or a hang is a finding rather than the end of the run.

A case is a JSON-able dict ``{"scene": ..., "toml": ..., "x": ..., "settings": ...,
"responses": ...}``; the worker answers ``"ok"`` (finite results), ``"flextop"`` (a
``FlextopError`` subclass, or ``TypeError`` for a scene that is neither a dict nor a path),
or a finding: ``"foreign <type>: <message>"`` or ``"non-finite <what>"``. The parent adds
``"crash <code>"`` and ``"hang"`` (no answer within the timeout). The domain keeps runs
short (``h ≥ 1e-3`` of ``t_end ≤ 0.2`` s, small scenes, ``rtol ≥ 1e-3`` when accepted), so
a timeout means a hang, not legitimate work. Used by ``tests/python/test_fuzz.py`` (about a minute) and
``benches/fuzz.py`` (a campaign of any length).
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from typing import Any

from hypothesis import strategies as st

import flextop

TIMEOUT = 20.0
"""Seconds a case may take before it counts as a hang."""

NASTY = [None, True, -1, 0, 1, 2**31, 2**63 - 1, 2**64, -(2**63), 1e-300, 5e-324, -0.0, 1e300, float("inf"), float("-inf"),
         float("nan"), "", "x", "0.4", "link1[0,0]", [], {}, [1.0], [0.0, 0.0], [1.0, 2.0, 3.0], [[1.0, 2.0]], {"kind": "pin"}]
"""Values put anywhere in a scene or its settings."""

RESPONSES = ["tip_deflection", "compliance", "volume", "volume:link1", "compliance:link2", "displacement:link2[4,1]:1,0",
             "integrated_displacement:link1[4,2]:0,1", "tip_deflection:link2[4,1]", "bogus", "", "volume:nope",
             "displacement:link2[4,1]:nan,0", "compliance:", ":"]


def _small_arm() -> dict:
    spec = flextop.scenes.robot_arm().to_dict()
    spec["simulation"].update(t_end=0.2, h=0.02)
    return spec


def _small_beam() -> dict:
    spec = flextop.scenes.spun_beam(bars=3).to_dict()
    spec["simulation"].update(t_end=0.1, h=0.01)
    return spec


def _small_crank() -> dict:
    spec = flextop.scenes.spatial_slider_crank().to_dict()
    spec["simulation"].update(t_end=0.05, h=0.005)
    return spec


def _small_rod() -> dict:
    """A spatial rod of four beams clamped at one end, a point mass and a follower load at the
    other, swinging under gravity."""
    scene = flextop.SpatialScene("rod", gravity=(0.0, 0.0, -9.81))
    scene.section("steel", E=2.1e11, rho=7850.0, nu=0.3, shape="tube", outer=0.02, inner=0.016, rayleigh=(0.1, 1e-5))
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (1.0, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="steel", split=4)
    scene.point_mass("bob", "end", 0.5)
    scene.revolute("hinge", "root", axis=(0.0, 1.0, 0.0))
    scene.spring("s", "end", (1.0, 0.0, 1.0), k=100.0, c=1.0)
    scene.load("push", "end", force=(0.0, 1.0, 0.0), follower=True)
    scene.simulation(t_end=0.05, h=0.005)
    return scene.to_dict()


BASES = {"arm": _small_arm, "truss": lambda: flextop.scenes.static_truss().to_dict(), "beam": _small_beam,
         "spatial_crank": _small_crank, "spatial_rod": _small_rod}

SPATIAL_RESPONSES = ["x:slider", "z:end", "strain_energy", "torque_squared:crank", "y:rod[2]", "bogus", "z:nope", ":",
                     "compliance", "reaction:crank", "torque:crank:p=4", "buckling:q=0", "reaction:nope:p=1",
                     "torque:", "buckling:ks=5"]
"""Response names for spatial scenes (a planar case's k-th name becomes the k-th of these)."""

SPATIAL_PARAMETERS = ["mass:rod", "mass:bob", "E:rod", "rho:rod", "k:s", "c:s", "Izz:crank", "k:nope", "E:", "torque:m"]
"""Parameter names for spatial scenes."""


def _paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path to an entry of a nested dict/list."""
    out = [prefix] if prefix else []
    if isinstance(value, dict):
        for k, v in value.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(value, list):
        for k, v in enumerate(value):
            out += _paths(v, prefix + (k,))
    return out


def _set(spec: Any, path: tuple, value: Any, delete: bool) -> None:
    for key in path[:-1]:
        spec = spec[key]
    if delete and isinstance(spec, dict):
        del spec[path[-1]]
    else:
        spec[path[-1]] = value


@st.composite
def scenes(draw) -> dict:
    """A built-in scene with a few entries replaced, deleted or added."""
    spec = BASES[draw(st.sampled_from(sorted(BASES)))]()
    for _ in range(draw(st.integers(0, 3))):
        paths = _paths(spec)
        path = draw(st.sampled_from(paths))
        mode = draw(st.sampled_from(["replace", "scale", "delete", "add"]))
        if mode == "add":
            path = path[:-1] + (draw(st.sampled_from(["extra", "split", "drive", "omit", "x_min", "mass", "fixed"])),)
            parent = spec
            for key in path[:-1]:
                parent = parent[key]
            if not isinstance(parent, dict):
                continue
        value = copy.deepcopy(draw(st.sampled_from(NASTY)))
        if mode == "scale":
            value = draw(st.floats(allow_nan=True, allow_infinity=True))
        _set(spec, path, value, mode == "delete")
    return spec


@st.composite
def toml_texts(draw) -> str:
    """An example file with a few characters replaced, deleted or inserted."""
    text = list(flextop.scenes.example_toml(draw(st.sampled_from(sorted(flextop.scenes.EXAMPLES)))))
    for _ in range(draw(st.integers(1, 4))):
        k = draw(st.integers(0, len(text) - 1))
        char = draw(st.sampled_from(list("[]{}=\".,0-9e\n\x00é#'") + ["\ufeff", "\udcff"]))
        mode = draw(st.sampled_from(["replace", "delete", "insert"]))
        if mode == "replace":
            text[k] = char
        elif mode == "delete":
            del text[k]
        else:
            text.insert(k, char)
    return "".join(text)


designs = st.one_of(
    st.none(), st.sampled_from(NASTY).map(copy.deepcopy), st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.floats(min_value=0.0, max_value=1.5), max_size=200),
    st.lists(st.sampled_from([0.01, 0.5, 1.0, float("nan"), 2.0, "0.5", None]), min_size=1, max_size=160),
)
"""Designs: absent, scalars, vectors of any length, mixed types."""

settings = st.fixed_dictionaries({}, optional={
    "h": st.one_of(st.floats(min_value=1e-3, max_value=100.0), st.sampled_from([0.0, -0.01, float("nan"), float("inf"), "0.01", None])),
    "t_end": st.one_of(st.floats(min_value=1e-3, max_value=0.2), st.sampled_from([0.0, -1.0, float("nan"), 2.0, "1", None])),
    "rho_inf": st.one_of(st.floats(min_value=-0.5, max_value=1.5), st.sampled_from([float("nan"), "0.8"])),
    "max_iter": st.one_of(st.integers(-2, 50), st.sampled_from([2**40, 1.5, "3"])),
    "load_steps": st.one_of(st.integers(-2, 200), st.sampled_from([10**12, 2**63, "5"])),
    "tol": st.one_of(st.floats(min_value=-1.0, max_value=2.0), st.sampled_from([float("nan"), 0.0])),
    "mass": st.sampled_from(["consistent", "lumped", "diagonal", 3]),
    "method": st.sampled_from(["direct", "adjoint", "auto", "bogus"]),
    "rtol": st.one_of(st.floats(min_value=1e-3, max_value=2.0), st.sampled_from([float("nan"), 0.0, -1e-2, 1e-300, 1e-7, 3e-2])),
})
"""Run settings, in range and out of it (steps kept at 1 ms or more)."""

responses = st.lists(st.sampled_from(RESPONSES), min_size=0, max_size=3)


def cases() -> st.SearchStrategy:
    """Whole cases: a scene (dict or TOML text), a design, settings and responses."""
    return st.fixed_dictionaries({
        "scene": st.one_of(scenes(), st.sampled_from([None, 3, "missing.toml", [1, 2]])),
        "x": designs, "settings": settings, "responses": responses,
        "gradients": st.booleans(),
    }, optional={"toml": toml_texts()})


# -- the worker ------------------------------------------------------------------------


def _finite(value: Any) -> bool:
    import numpy as np

    try:
        return bool(np.all(np.isfinite(np.asarray(value, dtype=float))))
    except (TypeError, ValueError):
        return True


def run_case(case: dict, tmp: str) -> str:
    """Runs one case in this process and classifies the outcome."""
    import numpy as np

    settings = dict(case["settings"])
    rtol = settings.pop("rtol", None)
    if "toml" in case:
        # An example file runs its own t_end (half a second of the four-bar): a tolerance on
        # it is minutes of legitimate refinement (the four-bar at rtol 0.0625 ends in a
        # ToleranceError after about 290 s), not a hang this bounded run could tell apart.
        rtol = None
    method = settings.pop("method", "auto")
    try:
        scene = case["scene"]
        if "toml" in case:
            path = f"{tmp}/case.toml"
            with open(path, "w", encoding="utf-8", errors="surrogatepass") as f:
                f.write(case["toml"])
            scene = path
        if _spatial(case, scene):
            return _spatial_case(case, scene, settings, method)
        sim = flextop.Simulation(scene)
        if case["responses"] and case["gradients"]:
            out = sim.run_with_sensitivities(case["x"], case["responses"], method=method, rtol=rtol, **settings)
            checks = {"values": out.values, "gradients": out.gradients}
        else:
            res = sim.run(case["x"], rtol=rtol, responses=case["responses"] or None, **settings)
            checks = {"q": res.q, **{name: res.response(name) for name in case["responses"]}}
    except flextop.FlextopError:
        return "flextop"
    except TypeError as error:
        if not isinstance(case["scene"], (dict, str)) and "toml" not in case:
            return "flextop"  # a scene that is neither a dict nor a path: TypeError is the contract
        return f"foreign TypeError: {error}"
    except Exception as error:  # noqa: BLE001 — classifying is the point
        return f"foreign {type(error).__name__}: {error}"
    bad = [name for name, value in checks.items() if not _finite(value)]
    return f"non-finite {', '.join(bad)}" if bad else "ok"


def _spatial(case: dict, scene: Any) -> bool:
    if "toml" in case:
        return "dimension = 3" in case["toml"]
    return isinstance(scene, dict) and scene.get("dimension") == 3


def _spatial_case(case: dict, scene: Any, settings: dict, method: str) -> str:
    """A spatial scene's case: its run, or responses and gradients by the spatial names the
    planar ones map to."""
    k = len(case["responses"])
    responses = [SPATIAL_RESPONSES[RESPONSES.index(r) % len(SPATIAL_RESPONSES)] for r in case["responses"]]
    parameters = [SPATIAL_PARAMETERS[(i * 7 + k) % len(SPATIAL_PARAMETERS)] for i in range(k)]
    try:
        sim = flextop.SpatialSimulation(scene)
        x = case["x"][0] if isinstance(case["x"], list) and case["x"] else case["x"]  # one density for all
        if responses and case["gradients"]:
            out = sim.run_with_sensitivities(x, responses, parameters, method=method, **settings)
            checks = {"values": out.values, "gradients": out.gradient, "dfdx": out.dfdx}
        else:
            res = sim.run(x, **settings)
            checks = {"q": res.q}
    except flextop.FlextopError:
        return "flextop"
    except Exception as error:  # noqa: BLE001 — classifying is the point
        return f"foreign {type(error).__name__}: {error}"
    bad = [name for name, value in checks.items() if not _finite(value)]
    return f"non-finite {', '.join(bad)}" if bad else "ok"


def worker() -> None:
    """Reads cases as JSON lines on stdin, answers one line each on stdout."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        for line in sys.stdin:
            print(json.dumps(run_case(json.loads(line), tmp)), flush=True)


class Worker:
    """A worker subprocess, restarted after a crash or a hang."""

    def __init__(self) -> None:
        self.process: subprocess.Popen | None = None

    def _start(self) -> subprocess.Popen:
        code = "import sys; sys.path.insert(0, %r); import fuzzing; fuzzing.worker()" % __file__.rsplit("/", 1)[0]
        return subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True)

    def run(self, case: dict, timeout: float = TIMEOUT) -> str:
        import selectors

        if self.process is None or self.process.poll() is not None:
            self.process = self._start()
        self.process.stdin.write(json.dumps(case, allow_nan=True) + "\n")
        self.process.stdin.flush()
        selector = selectors.DefaultSelector()
        selector.register(self.process.stdout, selectors.EVENT_READ)
        if not selector.select(timeout):
            self.close()
            return "hang"
        line = self.process.stdout.readline()
        if not line:
            code = self.process.wait()
            self.process = None
            return f"crash {code}"
        return json.loads(line)

    def close(self) -> None:
        if self.process is not None:
            self.process.kill()
            self.process.wait()
            self.process = None


def finding(outcome: str) -> bool:
    """Whether an outcome breaks the promise (anything but ``ok`` and ``flextop``)."""
    return outcome not in ("ok", "flextop")


def describe(case: dict) -> str:
    return json.dumps(case, allow_nan=True)[:2000]

