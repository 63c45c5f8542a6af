"""The number check shared by the parameter registry, randomization specs and wrappers (the
typed schemas of :mod:`sphere_env.schemas` check everything else).

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

