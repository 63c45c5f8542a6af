"""What produced a result: package versions, Python and the git commit (for run folders and reports),
and the machine it ran on."""

from __future__ import annotations

import os
import platform
import subprocess
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

PACKAGES = ("sphere_env", "drake", "torch", "stable_baselines3", "gymnasium", "numpy")


def software_versions() -> dict[str, str]:
    """Versions of the packages a result depends on, plus ``python`` and ``git_commit``."""
    out = {"python": platform.python_version()}
    for pkg in PACKAGES:
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = "absent"
    try:
        out["git_commit"] = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            cwd=Path(__file__).parent,
            check=False,
        ).stdout.strip()
    except OSError:
        out["git_commit"] = ""
    return out


def machine_info() -> dict:
    """The CPU, its core count, Python, the git commit and the package versions."""
    cpu = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    sw = software_versions()
    return {"cpu": cpu, "cores": os.cpu_count(), "python": sw.pop("python"), "commit": sw.pop("git_commit"), **sw}
