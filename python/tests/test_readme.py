"""The README's first Python example runs as written, from the checkout's root."""

from __future__ import annotations

import os
import re

from conftest import ROOT


def test_the_readme_python_example_runs(capsys):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```python\n(.*?)```", text, re.S)
    assert block, "README.md has no ```python block"
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        exec(compile(block.group(1), "README.md", "exec"), {})
    finally:
        os.chdir(here)
    assert capsys.readouterr().out.strip(), "the example prints what it found"
