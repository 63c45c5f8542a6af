"""Replay a logged trial in the twin: same fixture, logged initial state, samples at log times."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sphere_env.analysis.metrics import pme_percent, rmse  # noqa: F401  (re-exported for callers)
from sphere_env.calibration.logs import RobotLog
from sphere_env.physics.twin import InitialState, Twin

SIM_CHANNELS = ("theta", "theta_dot", "phi", "phi_dot", "omega_d", "drive_angle", "drive_rate")


def initial_rate(t: np.ndarray, x: np.ndarray, window_s: float = 0.1) -> float:
    """Rate [unit/s] at t[0] from a quadratic least-squares fit over the first ``window_s`` seconds.

    The logs do not always carry velocities (steer_free has none); a quadratic over ~5 samples
    is robust to the 50 Hz jitter and captures the release acceleration.
    """
    k = max(int(np.searchsorted(t, t[0] + window_s)) + 1, 3)
    k = min(k, len(t))
    coeff = np.polyfit(t[:k] - t[0], x[:k], deg=min(2, k - 1))
    return float(coeff[-2])


def initial_state_from_log(log: RobotLog, theta_offset_rad: float = 0.0, radius_m: float = 0.305) -> InitialState:
    """The logged initial state for the log's fixture.

    ``theta_offset_rad``: encoder zero offset, θ_log = θ_model + offset (see friction fit).
    Rates come from the log's velocity channels when present, else from :func:`initial_rate`.
    """
    t = log.t
    kw: dict = {}
    if log.has("theta"):
        kw["theta"] = float(log["theta"][0]) - theta_offset_rad
        kw["theta_dot"] = float(log["theta_dot"][0]) if log.has("theta_dot") else initial_rate(t, log["theta"])
    if log.has("phi"):
        kw["roll"] = float(log["phi"][0])
        phi_dot = float(log["phi_dot"][0]) if log.has("phi_dot") else initial_rate(t, log["phi"])
        if log.fixture in ("steer_plane", "free", "locked_steer"):
            # Rolling about x_W without slip: v_centre = ω × (R ẑ) = (0, −R φ̇, 0).
            kw["angular_velocity_W"] = (phi_dot, 0.0, 0.0)
            kw["velocity_W"] = (0.0, -radius_m * phi_dot, 0.0)
    if log.has("drive_angle") and log.fixture not in ("stand", "steer_plane"):
        kw["drive_angle"] = float(log["drive_angle"][0])
    return InitialState(**kw)


@dataclass
class SimTrace:
    """Simulated channels sampled at the log's times [s]; angles rad, rates rad/s."""

    t: np.ndarray
    channels: dict[str, np.ndarray]
    diverged: bool = False

    def __getitem__(self, name: str) -> np.ndarray:
        return self.channels[name]


def simulate_log(
    twin: Twin,
    log: RobotLog,
    theta_offset_rad: float = 0.0,
    motor_torque=(0.0, 0.0),
    pressure_kpa: float | None = None,
    initial: InitialState | None = None,
) -> SimTrace:
    """Reset ``twin`` to the log's initial state and sample it at every log time.

    The twin must already be built with the log's fixture (build once, reuse in fitting loops).
    Simulated θ is reported in the log's frame: θ_model + ``theta_offset_rad``.
    """
    if log.fixture is not None and twin.config.fixture != log.fixture:
        raise ValueError(
            f"fixture: twin has {twin.config.fixture!r} but log {log.name!r} needs {log.fixture!r}"
        )
    init = initial or initial_state_from_log(log, theta_offset_rad, twin.robot.radius_m)
    s = twin.reset(init, pressure_kpa=pressure_kpa)
    n = len(log.t)
    out = {k: np.empty(n) for k in SIM_CHANNELS}
    diverged = False

    def put(i: int, st) -> None:
        for k in SIM_CHANNELS:
            out[k][i] = getattr(st, k)

    put(0, s)
    for i in range(1, n):
        if diverged:
            for k in SIM_CHANNELS:
                out[k][i] = out[k][i - 1]
            continue
        try:
            # Advance to the absolute log time (no drift from summed increments); the 1 ns margin
            # keeps a sample that falls on a plant-step boundary on the same side as a live run.
            twin.advance(max(float(log.t[i]) - twin.context.get_time() - 1e-9, 0.0), motor_torque)
            put(i, twin.state())
        except RuntimeError:  # a solver failure at absurd parameters: keep a flat, bad trace
            diverged = True
            for k in SIM_CHANNELS:
                out[k][i] = out[k][i - 1]
    out["theta"] = out["theta"] + theta_offset_rad
    return SimTrace(log.t.copy(), out, diverged)
