"""Synthetic logs made by the twin itself with known parameters (plus noise)."""

from pathlib import Path

import numpy as np
import yaml

from sphere_env.calibration.log_csv import write_log_csv
from sphere_env.physics import InitialState, Twin, TwinConfig

SYNTH_CAL = {
    "name": "synthetic",
    "pressure_range_kpa": [3.0, 14.0],
    "nominal_pressure_kpa": 6.0,
    "omega_n": {"model": "linear", "intercept_rad_s": 2.5, "slope_rad_s_per_kpa": 0.08},
    "zeta": {"model": "exponential", "scale": 0.30, "rate_per_kpa": -0.08},
    "contact_volume": {"model": "membrane"},
    "hydroelastic": {"k_d": 0.5, "resolution_hint_m": 0.05},
}


def write_calibration(path: Path, data: dict = SYNTH_CAL) -> Path:
    path.write_text(yaml.safe_dump(data))
    return path


def steer_twin(calibration: Path, pressure_kpa: float) -> Twin:
    """The injected twin on the steer_plane fixture that the synthetic steer logs are made with (the
    fitted steer friction, no drive friction: the drive joint does not turn there)."""
    return Twin(
        TwinConfig(
            fixture="steer_plane",
            shell_model="injected",
            steer_friction="majd_steer",
            drive_friction="none",
            calibration=calibration,
            pressure_kpa=pressure_kpa,
        )
    )


def record(
    twin: Twin,
    initial: InitialState,
    duration_s: float,
    dt_s: float = 0.02,
    channels=("theta", "theta_dot", "phi", "phi_dot"),
    noise_rad: float = 0.0,
    seed: int = 0,
    pressure_kpa: float | None = None,
) -> tuple[np.ndarray, dict]:
    """Run the twin from ``initial`` and sample ``channels`` every ``dt_s`` (+ Gaussian noise on angles)."""
    rng = np.random.default_rng(seed)
    twin.reset(initial, pressure_kpa=pressure_kpa)
    n = int(round(duration_s / dt_s))
    t = np.arange(n + 1) * dt_s
    data = {c: np.empty(n + 1) for c in channels}
    for i in range(n + 1):
        if i:
            # Absolute targets just short of each sample time, as the replay does: summing 0.02 s
            # increments lands some samples 1 ulp past a 5 ms plant-step boundary, others 1 ulp short.
            twin.advance(max(i * dt_s - twin.time_s - 1e-9, 0.0))
        s = twin.state()
        for c in channels:
            data[c][i] = getattr(s, c)
    if noise_rad:
        for c in channels:
            if not c.endswith("_dot"):
                data[c] = data[c] + rng.normal(0.0, noise_rad, n + 1)
    return t, data


def synth_log(path: Path, twin: Twin, initial: InitialState, duration_s: float, **kw) -> Path:
    t, data = record(twin, initial, duration_s, **kw)
    return write_log_csv(path, t, data)


def write_manifest(path: Path, trials: list[dict]) -> Path:
    path.write_text(yaml.safe_dump({"data_root": ".", "trials": trials}))
    return path
