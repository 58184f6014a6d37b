"""The lowest Python that pyproject.toml declares (``requires-python``) really runs flextop:
a fresh virtual environment of that interpreter, with the declared dependencies from the
package index and this checkout's package (with its built extension) on PYTHONPATH,
imports flextop, loads a TOML scene and simulates it."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from flextop.scenes.builder import tomllib

from conftest import EXAMPLES, ROOT

PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]

SNIPPET = """
import sys
import flextop
from flextop.scenes.builder import tomllib
assert sys.version_info[:2] == {version}, sys.version
assert tomllib.__name__ == {parser!r}, tomllib.__name__
sim = flextop.Simulation(flextop.Scene.from_toml({scene!r}))
print(sim.n_design, sim.run(0.4).response("compliance"))
"""


def declared_minimum() -> tuple[int, int]:
    found = re.fullmatch(r"\s*>=\s*(\d+)\.(\d+)\s*", PROJECT["requires-python"])
    assert found, f"requires-python = {PROJECT['requires-python']!r} is not of the form '>=X.Y'"
    return int(found[1]), int(found[2])


def interpreter(version: tuple[int, int]) -> str | None:
    """An interpreter of ``version``: ``pythonX.Y`` on PATH, else one installed by pyenv."""
    name = "python{}.{}".format(*version)
    pyenv = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv"))
    candidates = [name, *map(str, sorted(pyenv.glob(f"versions/{version[0]}.{version[1]}.*/bin/{name}"), reverse=True))]
    for candidate in candidates:
        try:
            out = subprocess.run([candidate, "-c", "import sys; print(*sys.version_info[:2])"], capture_output=True,
                                 text=True, timeout=60)
        except (OSError, subprocess.TimeoutExpired):
            continue
        if out.returncode == 0 and tuple(map(int, out.stdout.split())) == version:
            return candidate
    return None


def test_lowest_declared_python_imports_flextop_and_simulates_a_toml_scene(tmp_path):
    version = declared_minimum()
    python = interpreter(version)
    if python is None:
        pytest.fail(f"no Python {version[0]}.{version[1]} (the declared minimum) found: neither "
                    f"python{version[0]}.{version[1]} on PATH nor one under $PYENV_ROOT/versions")
    package = ROOT / "python"
    if not list((package / "flextop").glob("_core*.so")) + list((package / "flextop").glob("_core*.pyd")):
        pytest.fail(f"no built extension in {package / 'flextop'}: run `pip install -e .` first")

    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    venv = tmp_path / "venv"
    subprocess.run([python, "-m", "venv", venv], check=True, capture_output=True, timeout=120, env=env)
    venv_python = venv / ("Scripts/python.exe" if sys.platform == "win32" else "bin/python")
    pip = subprocess.run([venv_python, "-m", "pip", "install", "--quiet", "--only-binary=:all:", "--no-compile",
                          "--disable-pip-version-check", *PROJECT["dependencies"]],
                         capture_output=True, text=True, timeout=600, env=env)
    assert pip.returncode == 0, pip.stdout + pip.stderr

    parser = "tomllib" if version >= (3, 11) else "tomli"
    code = SNIPPET.format(version=version, parser=parser, scene=str(EXAMPLES / "static_truss.toml"))
    run = subprocess.run([venv_python, "-c", code], capture_output=True, text=True, timeout=300,
                         env={**env, "PYTHONPATH": str(package)}, cwd=tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    n_design, compliance = run.stdout.split()
    assert int(n_design) == 74 and float(compliance) > 0
