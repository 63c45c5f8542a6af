"""What every renderer of generated documentation blocks shares: the results files, the registry of
renderers by block name, number formats and the Markdown table."""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import yaml

from sphere_env import safe_yaml
from sphere_env.evaluation.experiments import RESULTS
from sphere_env.reporting import markdown_table
from sphere_env.resources import asset_path

MINUS = "\u2212"


class DocsError(ValueError):
    """A page that cannot be rendered: unknown block name, unclosed block or unreadable results."""


class Results:
    """The committed results files of one folder, each read once."""

    def __init__(self, folder: str | Path = RESULTS) -> None:
        self.folder = Path(folder)
        self._read: dict[str, Any] = {}

    def json(self, name: str) -> Any:
        if name not in self._read:
            path = self.folder / name
            try:
                self._read[name] = json.loads(path.read_text())
            except (OSError, ValueError) as e:
                raise DocsError(f"cannot read results file {path}: {e}") from e
        return self._read[name]

    def text(self, name: str) -> str:
        """A results page as text."""
        if name not in self._read:
            path = self.folder / name
            try:
                self._read[name] = path.read_text()
            except OSError as e:
                raise DocsError(f"cannot read results file {path}: {e}") from e
        return self._read[name]

    def calibration(self, name: str) -> dict[str, Any]:
        """A shipped calibration file (``assets/calibration/<name>.yaml``) as a mapping: the fits it records."""
        key = f"calibration:{name}"
        if key not in self._read:
            path = asset_path("calibration", f"{name}.yaml")
            try:
                self._read[key] = safe_yaml.load_file(path)
            except (OSError, yaml.YAMLError) as e:
                raise DocsError(f"cannot read calibration file {path}: {e}") from e
        return self._read[key]

    def md_table(self, name: str) -> list[dict[str, str]]:
        """The first Markdown table of a results page: one dict (header -> cell) per row."""
        path = self.folder / name
        try:
            lines = [ln.strip() for ln in path.read_text().splitlines()]
        except OSError as e:
            raise DocsError(f"cannot read results file {path}: {e}") from e
        start = next((i for i, ln in enumerate(lines) if ln.startswith("|")), None)
        if start is None:
            raise DocsError(f"{path}: no Markdown table")
        cells = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[start:] if ln.startswith("|")]
        rows = []
        for row in cells[2:]:
            if len(row) != len(cells[0]):
                break
            rows.append(dict(zip(cells[0], row)))
        return rows


RENDERERS: dict[str, Callable[[Results], str]] = {}


def renders(name: str) -> Callable[[Callable[[Results], str]], Callable[[Results], str]]:
    def register(fn: Callable[[Results], str]) -> Callable[[Results], str]:
        RENDERERS[name] = fn
        return fn

    return register


def fixed(x: float, d: int = 1) -> str:
    """``d`` decimals, negative numbers with the minus sign."""
    return f"{x:.{d}f}".replace("-", MINUS)


def fixed2(x: float) -> str:
    return fixed(x, 2)


def signed(x: float, d: int = 1) -> str:
    """With its sign, + or − (the minus sign, not a hyphen)."""
    return f"{x:+.{d}f}".replace("-", MINUS)


def whole(x: float) -> str:
    """Whole number with thousands separators."""
    return f"{x:,.0f}"


def percent(rate: float) -> str:
    return f"{100 * rate:.0f} %"


def span(values: Iterable[float], fmt: Callable[[float], str]) -> str:
    vals = sorted(values)
    lo, hi = fmt(vals[0]), fmt(vals[-1])
    return lo if lo == hi else f"{lo}–{hi}"


def cpu(name: str) -> str:
    return " ".join(re.sub(r"\((R|TM)\)|\bProcessor\b|\bCPU\b.*", " ", name).split())


def table(headers: Sequence[str], rows: Sequence[Sequence[str]], align: Sequence[str] | None = None) -> str:
    """The project's one Markdown table helper (:func:`sphere_env.reporting.markdown_table`) over
    rows of ready-written cells; ``align``: "left", "right" or "center" per column (default left)."""
    return markdown_table(rows, list(headers), "".join(a[0] for a in align) if align else "")


def slash(values: Iterable[Any], fmt: Callable[[Any], str] = str) -> str:
    return " / ".join(fmt(v) for v in values)


def kpa(p: float) -> str:
    return f"{p:g}"


def ratios(rows: Iterable[dict], key: str) -> str:
    return slash(rows, lambda r: f"{r[key]:.0f}%")


def train_row(t: dict, shell: str, layout: str, cores: int) -> dict:
    for r in t["train"]["rows"]:
        if r["shell_model"] == shell and r["layout"] == layout and r["cores"] == cores:
            return r
    raise KeyError(f"benchmark_train.json: {shell} {layout} on {cores} cores")
