"""Input checks shared by configs, environments and randomization specs.

Every failure is a ``ValueError`` that names the field, the value and what is allowed.
"""

from __future__ import annotations

import math
import numbers
from typing import Any


def finite_number(field: str, value: Any, allowed: str = "a finite number") -> float:
    """``value`` as a float; refuses booleans, strings (``"0.01"`` is text, not a number) and other
    non-numbers, and NaN/inf. numpy scalars (and 0-d numeric arrays) are numbers."""
    if getattr(value, "ndim", None) == 0 and getattr(getattr(value, "dtype", None), "kind", None) in ("i", "u", "f"):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{field}: value {value!r} is not a number; allowed: {allowed}")
    val = float(value)
    if not math.isfinite(val):
        raise ValueError(f"{field}: value {value!r} is not finite; allowed: {allowed}")
    return val


def positive(field: str, value: Any, upper: float | None = None) -> float:
    """``value`` as a float in (0, ``upper``] (or > 0 without ``upper``)."""
    allowed = f"(0, {upper}]" if upper is not None else "> 0"
    val = finite_number(field, value, allowed)
    if val <= 0 or (upper is not None and val > upper):
        raise ValueError(f"{field}: value {value!r} outside allowed {allowed}")
    return val


def ordered_pair(field: str, value: Any, lo: float, hi: float) -> tuple[float, float]:
    """``value`` as a pair (low, high) with ``lo`` <= low <= high <= ``hi``."""
    try:
        a, b = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: value {value!r} must be a pair (low, high)") from None
    if not (math.isfinite(a) and math.isfinite(b) and lo <= a <= b <= hi):
        raise ValueError(f"{field}: value {value!r} must satisfy {lo} <= low <= high <= {hi}")
    return a, b
