"""Minimal math backends so one law can be evaluated with numpy or built as a Drake expression."""

from __future__ import annotations

import numpy as np


class NumpyMath:
    """Elementwise numpy functions (the default backend)."""

    exp = staticmethod(np.exp)
    abs = staticmethod(np.abs)
    tanh = staticmethod(np.tanh)
    sign = staticmethod(np.sign)


NUMPY = NumpyMath()
