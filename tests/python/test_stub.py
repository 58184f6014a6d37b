"""The stub ``python/flextop/_core.pyi`` matches the native extension: mypy's stubtest passes on
``flextop._core`` (and fails, naming the function, on a stub with a drifted signature), and
every dict the extension returns has exactly the keys, and values of the types, of the
``TypedDict`` its stub declares."""

import ast
import os
import subprocess
import sys

import numpy as np
import pytest

import flextop
from flextop import _core

from conftest import ROOT

pytest.importorskip("mypy")

STUB = ROOT / "python" / "flextop" / "_core.pyi"

ARRAYS = {"_F": np.float64}
"""The stub's array aliases and their dtypes."""

PLAIN = {"int": int, "float": float, "str": str, "bool": bool}


def stubtest(tmp_path, text: str) -> tuple[subprocess.CompletedProcess, str]:
    """``python -m mypy.stubtest flextop._core`` of the stub ``text`` against the installed
    extension, and the stub's path. The stub sits in a package ``flextop`` of its own under
    ``tmp_path`` with an empty ``__init__.pyi``, first on ``MYPYPATH`` so ahead of the
    installed package: mypy then analyses the stub (and numpy's) without the whole of
    ``flextop`` (9 s, not 23 s), and stubtest checks only ``flextop._core`` either way."""
    package = tmp_path / "stubs" / "flextop"
    package.mkdir(parents=True)
    (package / "__init__.pyi").write_text("")
    (package / "_core.pyi").write_text(text)
    env = {**os.environ, "MYPYPATH": str(package.parent)}
    out = subprocess.run([sys.executable, "-m", "mypy.stubtest", "flextop._core"], capture_output=True, text=True,
                         timeout=300, cwd=tmp_path, env=env)
    return out, str(package / "_core.pyi")


def test_stubtest_passes_on_the_stub(tmp_path):
    out, _ = stubtest(tmp_path, STUB.read_text())
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Success: no issues found in 1 module" in out.stdout


def test_stubtest_fails_on_a_drifted_signature(tmp_path):
    text = STUB.read_text()
    drifted = text.replace(",\n                           path: tuple[_F, _F, _F, _F] | None = None) -> SensitivityData",
                           ") -> SensitivityData")
    assert drifted != text
    out, path = stubtest(tmp_path, drifted)
    assert out.returncode == 1, out.stdout + out.stderr
    # the copy was read (its path is named), and the one drift is the only finding
    assert f"in file {path}" in out.stdout, out.stdout
    assert 'flextop._core.run_with_sensitivities is inconsistent, stub does not have parameter "path"' in out.stdout
    assert "Found 1 error" in out.stdout, out.stdout


# -- the dicts' contract ----------------------------------------------------------------

def parse_stub() -> tuple[dict[str, dict[str, ast.expr]], dict[str, ast.expr]]:
    """The stub's TypedDicts (name → key → annotation) and the functions and methods
    (``name``, ``Class.name``) whose return annotation names one (→ the annotation)."""
    tree = ast.parse(STUB.read_text())
    typed = {node.name: {s.target.id: s.annotation for s in node.body if isinstance(s, ast.AnnAssign)
                         and isinstance(s.target, ast.Name)}
             for node in tree.body if isinstance(node, ast.ClassDef)
             and any(isinstance(b, ast.Name) and b.id == "TypedDict" for b in node.bases)}
    functions = [(f.name, f) for f in tree.body if isinstance(f, ast.FunctionDef)]
    functions += [(f"{c.name}.{f.name}", f) for c in tree.body if isinstance(c, ast.ClassDef)
                  for f in c.body if isinstance(f, ast.FunctionDef)]
    returning = {name: f.returns for name, f in functions if f.returns is not None
                 and any(isinstance(n, ast.Name) and n.id in typed for n in ast.walk(f.returns))}
    return typed, returning


TYPED, RETURNING = parse_stub()


def check(value, annotation: ast.expr, where: str) -> None:
    """Asserts that ``value`` is of the stub's ``annotation``: a TypedDict with exactly its
    keys (each value checked in turn), a float64 array, a plain type, a list, a tuple, a
    union with ``None``."""
    shown = ast.unparse(annotation)
    if isinstance(annotation, ast.BinOp) and isinstance(annotation.op, ast.BitOr):
        for side in (annotation.left, annotation.right):
            try:
                return check(value, side, where)
            except AssertionError:
                pass
        raise AssertionError(f"{where}: {value!r} is not {shown}")
    if isinstance(annotation, ast.Constant) and annotation.value is None:
        assert value is None, f"{where}: {value!r} is not None"
    elif isinstance(annotation, ast.Name) and annotation.id in TYPED:
        keys = TYPED[annotation.id]
        assert isinstance(value, dict), f"{where}: {type(value).__name__}, not a dict ({shown})"
        assert set(value) == set(keys), (f"{where}: the keys drifted from {shown}: only at runtime "
                                         f"{sorted(set(value) - set(keys))}, only in the stub {sorted(set(keys) - set(value))}")
        for key, inner in keys.items():
            check(value[key], inner, f"{where}[{key!r}]")
    elif isinstance(annotation, ast.Name) and annotation.id in ARRAYS:
        assert isinstance(value, np.ndarray) and value.dtype == ARRAYS[annotation.id], f"{where}: {value!r} is not {shown}"
    elif isinstance(annotation, ast.Name) and annotation.id in PLAIN:
        assert type(value) is PLAIN[annotation.id], f"{where}: {value!r} is not {shown}"
    elif isinstance(annotation, ast.Subscript) and ast.unparse(annotation.value) == "list":
        assert isinstance(value, list), f"{where}: {type(value).__name__}, not {shown}"
        for k, item in enumerate(value):
            check(item, annotation.slice, f"{where}[{k}]")
    elif isinstance(annotation, ast.Subscript) and ast.unparse(annotation.value) == "tuple":
        items = annotation.slice.elts if isinstance(annotation.slice, ast.Tuple) else [annotation.slice]
        assert isinstance(value, tuple) and len(value) == len(items), f"{where}: {value!r} is not {shown}"
        for k, (item, inner) in enumerate(zip(value, items)):
            check(item, inner, f"{where}[{k}]")
    else:
        raise AssertionError(f"{where}: the test cannot check annotation {shown}; teach check() about it")


@pytest.fixture(scope="module")
def models():
    """A short run of the arm (bars, driven joints, design variables) and the static truss."""
    arm = flextop.Simulation(flextop.scenes.robot_arm(t_end=0.1, h=0.05)).model
    truss = flextop.Simulation(flextop.scenes.static_truss()).model
    return arm, truss


def evaluate_responses(arm: _core.Model):
    x = np.full(arm.n_design, 0.5)
    run = _core.simulate(arm, x)
    return _core.evaluate_responses(arm, x, run["q"], run["lam"], list(run["time"]), 0.0, ["tip_deflection", "stress"],
                                    qdot=run["qdot"], settings={"mass": "consistent"})


def bar_shares(arm: _core.Model):
    fine = flextop.Simulation(flextop.scenes.robot_arm(t_end=0.1, h=0.05)).levels[2].model
    x, steps = np.full(arm.n_design, 0.5), [0.05, 0.05]
    run = _core.simulate(fine, x, steps=steps)
    return _core.bar_shares(arm, fine, x, ["tip_deflection"], {}, steps, run["q"], run["qdot"], run["qddot"], run["lam"])


def spatial(split: int = 2) -> _core.SpatialModel:
    """A cantilever of two elements (or ``split``) with a point mass at its tip, under gravity."""
    scene = flextop.SpatialScene("rod", gravity=(0.0, 0.0, -9.81))
    scene.section("steel", E=2e11, rho=7800.0, nu=0.3, diameter=0.01)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("end", (1.0, 0.0, 0.0))
    scene.beam("rod", "root", "end", section="steel", split=split)
    scene.point_mass("tip", "end", 0.1)
    scene.weld("clamp", "root")
    scene.simulation(t_end=0.01, h=0.005)
    return _core.SpatialModel.from_dict(scene.to_dict())


CALLS = {
    "Model.bars": lambda arm, truss: arm.bars(),
    "Model.elements": lambda arm, truss: arm.elements(),
    "Model.cells": lambda arm, truss: _core.Model.from_dict({"name": "plate", "members": [{"name": "p", "nx": 2, "ny": 1, "length": 1.0, "height": 0.1, "thickness": 0.01, "E": 1e9, "nu": 0.3, "rho": 1e3}], "joints": [{"kind": "pin", "name": "a", "node": "p[0,0]"}, {"kind": "pin", "name": "b", "node": "p[0,1]"}]}).cells(),
    "Model.joints": lambda arm, truss: arm.joints(),
    "Model.mechanism": lambda arm, truss: arm.mechanism(),
    "simulate": lambda arm, truss: _core.simulate(arm, np.full(arm.n_design, 0.5)),
    "solve_static": lambda arm, truss: _core.solve_static(truss, np.full(truss.n_design, 0.5)),
    "run_with_sensitivities": lambda arm, truss: _core.run_with_sensitivities(
        arm, np.full(arm.n_design, 0.5), ["tip_deflection", "stress"]),
    "evaluate_responses": lambda arm, truss: evaluate_responses(arm),
    "linearize": lambda arm, truss: _core.linearize(arm),
    "natural_modes": lambda arm, truss: _core.natural_modes(truss, 2, np.full(truss.n_design, 0.5)),
    "bar_shares": lambda arm, truss: bar_shares(arm),
    "time_errors": lambda arm, truss: _core.time_errors(arm, np.full(arm.n_design, 0.5), ["tip_deflection"], {}, [0.05, 0.05]),
    "SpatialModel.simulate": lambda arm, truss: spatial().simulate({"t_end": 0.01}),
    "SpatialModel.solve_static": lambda arm, truss: spatial().solve_static(),
    "SpatialModel.natural_modes": lambda arm, truss: spatial().natural_modes(
        list(spatial().solve_static()["q"]), list(spatial().solve_static()["lam"])),
    "SpatialModel.sensitivities": lambda arm, truss: spatial().sensitivities(["z:tip"], ["E:rod", "mass:tip"]),
    "SpatialModel.time_errors": lambda arm, truss: spatial().time_errors(["z:tip", "strain_energy"]),
    "SpatialModel.beam_shares": lambda arm, truss: spatial().beam_shares(spatial(4), ["z:end"], ["z:end"]),
}
"""A call on a small scene of every function and method of the stub that returns a dict."""


def test_every_dict_returning_function_is_called():
    assert set(RETURNING) == set(CALLS)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_returned_dicts_have_the_stubs_keys_and_types(models, name):
    value = CALLS[name](*models)
    if isinstance(value, list):
        assert value, f"{name}: an empty list checks nothing"
    check(value, RETURNING[name], name)
