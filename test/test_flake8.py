"""Style and static errors (pycodestyle + pyflakes) over the whole source tree.

The ament_flake8 wheel would add import-order and quote plugins; plain flake8 with the
ament line length (99, setup.cfg) keeps the check fast and dependency-light.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


@pytest.mark.linter
def test_flake8_clean() -> None:
    dirs = ['cam_design', 'cam_metrology', 'benchmarks', 'test', 'bags', 'setup.py']
    proc = subprocess.run([sys.executable, '-m', 'flake8', *dirs], cwd=REPO,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
