"""Shared fixtures: the repository's root (the samples), and the command-line binary the
Python results are compared with."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any, Dict, List

import pytest

ROOT = Path(__file__).resolve().parents[2]


def sample(name: str) -> str:
    return str(ROOT / "gcode-samples" / name)


@pytest.fixture(scope="session")
def cli() -> Any:
    """Runs the command line (CONTOURCHECK_BIN, else the workspace's release build) and
    returns its completed process."""
    binary = os.environ.get("CONTOURCHECK_BIN") or str(ROOT / "target" / "release" / "contourcheck")
    if not Path(binary).exists():
        binary = shutil.which("contourcheck") or ""
    if not binary:
        pytest.skip("skipped: the contourcheck binary not present (cargo build --release)")

    def run(args: List[str]) -> subprocess.CompletedProcess:
        done = subprocess.run([binary, *args], capture_output=True, text=True, env={**os.environ, "CI": "1"})
        assert done.returncode in (0, 1), done.stderr
        return done

    return run


def read_json(path: Path) -> Dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))
