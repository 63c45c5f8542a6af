"""Small helpers shared by the benchmark and study scripts: machine info and the results folder
(their Markdown tables: :func:`sphere_env.reporting.markdown_table`)."""

from __future__ import annotations

import os
import platform
from pathlib import Path

from sphere_env.provenance import software_versions

RESULTS = Path(__file__).resolve().parent / "results"


def machine_info() -> dict:
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
