import numpy as np
import pytest

from sphere_env.physics import Twin, TwinConfig


def record(twin: Twin, duration_s: float, chunk_s: float = 0.02, field: str = "phi", torque=(0.0, 0.0)):
    """Advance ``twin`` in chunks and return (t, values of ``field``)."""
    ts, ys = [], []
    for _ in range(int(round(duration_s / chunk_s))):
        twin.advance(chunk_s, torque)
        s = twin.state()
        ts.append(s.time_s)
        ys.append(getattr(s, field))
    return np.array(ts), np.array(ys)


@pytest.fixture
def make_twin():
    def _make(**kwargs):
        return Twin(TwinConfig(**kwargs))

    return _make
