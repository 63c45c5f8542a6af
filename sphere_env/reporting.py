"""Markdown tables of the reports and results files, written through one helper over ``tabulate``.

:func:`markdown_table` takes rows and columns. A column is ``(key, header, format)``: the cell is
``row[key]`` (an empty cell when a mapping row lacks the key) written by the format, a
``str.format`` pattern such as ``"{:.1f}"`` (applied to every value but ``""`` and ``None``), a
callable value -> text (:func:`number`, a lambda) or ``""`` for ``str(value)``. A column given as a
plain header string is the row's item at that column's position, written with ``str``.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, Callable, Iterable, Mapping, Sequence, Union

from tabulate import tabulate

#: How a column writes its values: a ``str.format`` pattern, a callable, or ``""`` (``str``).
Format = Union[str, Callable[[Any], str]]
#: A column: (row key, header, format), or a header alone (the row's item at its position).
Column = Union[tuple[Any, str, Format], str]
_ALIGN = {"l": "left", "r": "right", "c": "center"}


def number(x: Any, digits: int = 3) -> str:
    """``x`` with ``digits`` decimals; an em dash for ``None``, a non-number or a non-finite value."""
    if not isinstance(x, numbers.Real) or not math.isfinite(x):
        return "—"
    return f"{x:.{digits}f}"


def _cell(row: Mapping[Any, Any] | Sequence[Any], key: Any, fmt: Format) -> str:
    value = row.get(key, "") if isinstance(row, Mapping) else row[key]
    if callable(fmt):
        return fmt(value)
    return fmt.format(value) if fmt and value not in ("", None) else str(value)


def markdown_table(
    rows: Iterable[Mapping[Any, Any] | Sequence[Any]], columns: Sequence[Column], align: str = ""
) -> str:
    """A Markdown (pipe) table with one line per row of ``rows`` (mappings or sequences) and one
    column per entry of ``columns`` (module docstring). ``align``: one letter per column,
    ``l``eft, ``r``ight or ``c``entre (default: every column left)."""
    if align and len(align) != len(columns):
        raise ValueError(f"align {align!r}: one letter per column ({len(columns)} columns)")
    cols = [(j, col, "") if isinstance(col, str) else col for j, col in enumerate(columns)]
    cells = [[_cell(row, key, fmt) for key, _, fmt in cols] for row in rows]
    return tabulate(
        cells,
        headers=[header for _, header, _ in cols],
        tablefmt="pipe",
        disable_numparse=True,
        colalign=[_ALIGN[a] for a in align or "l" * len(cols)],
    )


__all__ = ["Column", "Format", "markdown_table", "number"]
