"""Small helpers shared by the benchmark and study scripts: machine info and Markdown tables."""

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



def markdown_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """``columns`` = [(key, header, format)]; format like '{:.1f}'."""
    head = "| " + " | ".join(h for _, h, _ in columns) + " |"
    sep = "| " + " | ".join("---" for _ in columns) + " |"
    lines = [head, sep]
    for row in rows:
        cells = []
        for key, _, fmt in columns:
            val = row.get(key, "")
            cells.append(fmt.format(val) if val not in ("", None) and fmt else str(val))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
