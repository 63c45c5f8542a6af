"""Input checks shared by configs, environments and randomization specs.

Every failure is a ``ValueError`` that names the field, the value and what is allowed.
"""

from __future__ import annotations

import math
from typing import Any


def finite_number(field: str, value: Any, allowed: str = "a finite number") -> float:
    """``value`` as a float; refuses booleans, non-numbers and NaN/inf."""
    if isinstance(value, bool):
        raise ValueError(f"{field}: value {value!r} is not a number; allowed: {allowed}")
    try:
        val = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: value {value!r} is not a number; allowed: {allowed}") from None
    if not math.isfinite(val):
        raise ValueError(f"{field}: value {value!r} is not finite; allowed: {allowed}")
    return val
