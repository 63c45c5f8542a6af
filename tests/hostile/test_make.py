"""`make test` as a user without root runs it: it installs no system package (a dry run of the
target and of everything it depends on names no package manager)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("target", ["test", "test-fast"])
def test_make_test_installs_no_system_package(target):
    if shutil.which("make") is None:
        pytest.skip("make not found")
    # -B: every rule as if out of date, so the install steps are listed too
    dry = subprocess.run(["make", "-n", "-B", target], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert dry.returncode == 0, dry.stderr
    assert "pytest" in dry.stdout
    for tool in ("apt-get", "apt ", "dnf", "yum", "sudo"):
        assert tool not in dry.stdout, f"`make {target}` runs {tool}"
