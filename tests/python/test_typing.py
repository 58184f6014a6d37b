"""The README's examples pass mypy; a design given as a string does not, and the typed entry
points return the precise result type."""

import re
import subprocess
import sys

import pytest

import flextop

from conftest import ROOT

pytest.importorskip("mypy")


def mypy(tmp_path, code: str) -> subprocess.CompletedProcess:
    """mypy on ``code``, its cache under ``tmp_path``: a second check in the same test reads
    flextop's and numpy's analysis from the first and analyses the changed file alone."""
    path = tmp_path / "example.py"
    path.write_text(code)
    return subprocess.run([sys.executable, "-m", "mypy", "--follow-imports=silent", "--cache-dir", str(tmp_path / "mypy_cache"),
                           str(path)], capture_output=True, text=True, timeout=600, cwd=tmp_path)


def test_the_readme_examples_pass_mypy_and_a_string_design_does_not(tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    good = mypy(tmp_path, "\n".join(blocks))
    assert good.returncode == 0, good.stdout
    bad = mypy(tmp_path, "import flextop\nflextop.Simulation(flextop.scenes.robot_arm()).run('0.4')\n")
    assert bad.returncode == 1 and 'incompatible type "str"' in bad.stdout


def test_typed_entry_points(arm):
    assert isinstance(arm.simulate(0.4, h=0.05, t_end=0.2), flextop.Results)
    truss = flextop.Simulation(flextop.scenes.static_truss())
    assert isinstance(truss.equilibrium(0.4), flextop.StaticResults)
    with pytest.raises(flextop.SettingsError, match="static: use equilibrium"):
        truss.simulate(0.4)
    with pytest.raises(flextop.SettingsError, match="dynamic: use simulate"):
        arm.equilibrium(0.4)
    with pytest.raises(flextop.DesignError, match="real numbers"):
        arm.run("0.4")  # type: ignore[arg-type]
