"""Fills the generated blocks of the documentation pages from the committed results files.

A page marks each passage of measured numbers as a block::

    <!-- generated: NAME -->
    | a table, or a list |
    <!-- /generated -->

or inline, inside a sentence: ``... took <!-- generated: NAME -->6.1 min<!-- /generated --> ...``.
NAME selects a renderer (``base.RENDERERS``, filled by the modules of this package, one per page or
pair of pages), which writes the block from the results files under ``evaluation/results``: their
JSON, or a study's Markdown table where the study wrote no JSON; the parameter lists
(``registry``) are written from the parameter registry instead. Nothing is simulated or timed, and the text outside the blocks is left as it is (prose;
aims and settings, no measured numbers).

    python -m evaluation.experiments.docs            # rewrite the pages whose blocks changed (make docs)
    python -m evaluation.experiments.docs --check    # name the out-of-date blocks, exit 1, write nothing
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from sphere_env.evaluation.experiments.docs import (
    calibration,
    demo,
    drive,
    drive_envs,
    learning,
    physics,
    registry,
    speed,
    speed_floor,
    training,
)
from sphere_env.evaluation.experiments.docs.base import RENDERERS, DocsError, Results
from sphere_env.files import write_text_atomic

ROOT = Path(__file__).resolve().parents[3]
#: The pages with generated blocks, relative to the repository root.
PAGES = (
    "README.md",
    "docs/results/speed.md",
    "docs/results/training_speed.md",
    "docs/results/learning.md",
    "docs/results/randomization.md",
    "docs/physics.md",
    "docs/calibration.md",
    "docs/envs.md",
)
#: The modules whose renderers fill them (importing one registers its renderers by block name).
BLOCK_MODULES = (demo, speed, speed_floor, training, physics, calibration, drive, drive_envs, registry, learning)
BLOCK = re.compile(r"<!-- generated: (?P<name>[^\s>]+) -->(?P<body>.*?)<!-- /generated -->", re.S)
OPEN, CLOSE = "<!-- generated:", "<!-- /generated -->"


def render_text(text: str, results: Results, page: str = "page") -> str:
    """``text`` with every generated block rendered anew. A block on lines of its own stays on lines of
    its own; an inline block stays inline. Unknown names and unclosed blocks are refused by name."""
    if text.count(OPEN) != text.count(CLOSE) or text.count(OPEN) != len(BLOCK.findall(text)):
        raise DocsError(f"{page}: every '{OPEN} NAME -->' needs its own '{CLOSE}'")

    def fill(m: re.Match) -> str:
        name = m["name"]
        if name not in RENDERERS:
            raise DocsError(f"{page}: unknown generated block {name!r} (known: {', '.join(sorted(RENDERERS))})")
        try:
            out = RENDERERS[name](results).strip("\n")
        except (KeyError, IndexError, TypeError, ZeroDivisionError) as e:
            raise DocsError(f"{page}: block {name!r}: the results lack {e!r}") from e
        body = f"\n{out}\n" if m["body"].startswith("\n") else out
        return f"{OPEN} {name} -->{body}{CLOSE}"

    return BLOCK.sub(fill, text)


def blocks(text: str) -> list[tuple[str, str]]:
    """(name, body) of every generated block of ``text``, in order."""
    return [(m["name"], m["body"]) for m in BLOCK.finditer(text)]


def render_pages(results: Results, root: Path = ROOT, pages: Iterable[str] = PAGES) -> dict[str, tuple[str, str]]:
    """page -> (committed text, regenerated text)."""
    out = {}
    for page in pages:
        try:
            text = (root / page).read_text()
        except OSError as e:
            raise DocsError(f"cannot read page {root / page}: {e}") from e
        out[page] = (text, render_text(text, results, page))
    return out


def stale_blocks(rendered: Mapping[str, tuple[str, str]]) -> list[str]:
    """'page: block NAME' for every block whose committed text differs from its regenerated text."""
    stale = []
    for page, (old, new) in rendered.items():
        stale += [f"{page}: block {a[0]}" for a, b in zip(blocks(old), blocks(new)) if a != b]
    return stale


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true", help="name the out-of-date blocks and exit 1; write nothing")
    args = parser.parse_args(argv)
    try:
        rendered = render_pages(Results())
    except DocsError as e:
        raise SystemExit(f"docs: {e}") from None
    stale = stale_blocks(rendered)
    for line in stale:
        print(("out of date: " if args.check else "regenerated: ") + line)
    if not args.check:
        for page, (old, new) in rendered.items():
            if new != old:
                write_text_atomic(ROOT / page, new)
    return 1 if args.check and stale else 0
