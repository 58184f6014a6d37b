"""Every Python example of the README runs, in order, in one namespace."""

import re

from conftest import ROOT


def test_readme_examples_run():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 3
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    assert namespace["dfdx"].shape == (3, 148)
    assert namespace["result"].fun_scaled < 0.01, "the optimization example reduces the scaled tip deflection"
