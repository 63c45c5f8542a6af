"""The one Markdown table helper (sphere_env.reporting) of the reports and results files."""

import math

import pytest

from sphere_env.reporting import markdown_table, number


def _cells(table: str) -> list[list[str]]:
    """The table's cells, its separator line as one alignment letter per column."""
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in table.splitlines()]
    rows[1] = ["r" if c.endswith(":") and not c.startswith(":") else "l" if c.startswith(":") else "-" for c in rows[1]]
    return rows


def test_mapping_rows_with_formats_and_missing_keys():
    rows = [{"name": "a", "x": 1.234, "share": 0.5, "rmse": math.nan}, {"name": "b", "x": "", "rmse": None}]
    cols = [("name", "name", ""), ("x", "x [m]", "{:.1f}"), ("share", "share", "{:.0%}"), ("rmse", "RMSE", number)]
    table = markdown_table(rows, cols, align="lrrr")
    assert _cells(table) == [
        ["name", "x [m]", "share", "RMSE"],
        ["l", "r", "r", "r"],
        ["a", "1.2", "50%", "—"],
        ["b", "", "", "—"],
    ]


def test_sequence_rows_under_plain_headers_are_left_aligned_text():
    table = markdown_table([["steer", 0.25], ["drive", "—"]], ["joint", "value"])
    assert _cells(table) == [["joint", "value"], ["l", "l"], ["steer", "0.25"], ["drive", "—"]]
    assert markdown_table([], ["a", "b"]).splitlines()[0] == "| a   | b   |"


def test_number_and_a_wrong_alignment():
    assert (number(0.12345), number(2, 1), number(None), number(math.inf), number("x")) == (
        "0.123",
        "2.0",
        "—",
        "—",
        "—",
    )
    with pytest.raises(ValueError, match="one letter per column"):
        markdown_table([], ["a", "b"], align="l")
