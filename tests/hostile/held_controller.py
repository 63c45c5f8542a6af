"""A controller (``module:function`` form) that holds its episode until the test lets it go: zero
torque, and from its second action on it waits for the file named by ``$SPHERE_ENV_TEST_RELEASE``
to exist. A sweep's check calls each controller once, so only the episodes wait."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np


class HeldController:
    def __init__(self):
        self.calls = 0

    def __call__(self, obs, info):
        self.calls += 1
        release = Path(os.environ["SPHERE_ENV_TEST_RELEASE"])
        deadline = time.monotonic() + 120
        while self.calls > 1 and not release.exists():
            if time.monotonic() > deadline:
                raise TimeoutError(f"{release} was never created")
            time.sleep(0.02)
        return np.zeros(2)
