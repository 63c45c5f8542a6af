"""Robot logs: the column mappings (CSV -> project state names and SI units) and the loaded trial.

A log is a CSV with one time column and named channels. The RoboBall channel names (the real
robot's logs) are understood out of the box; any other naming is given by a small YAML column
mapping::

    time: {column: t, unit: s}              # s | ms | us | ns
    channels:
      theta: {column: pendulum_deg, unit: deg}   # angles: rad | deg; rates: rad/s | deg/s | rpm
      phi:   {column: tilt, unit: rad}
      drive_rate: {column: motor_vel, unit: rad/s, sign: -1}   # sign: -1 for a reversed encoder

RoboBall channels -> project state names (signs and frames: ``docs/design.md``):

===========================================  =====================================================
``timestamp``                                time, **nanoseconds** from an arbitrary origin
``roll_joint.position`` / ``.velocity``      ``theta``, ``theta_dot``: steer joint θ
``ball_roll`` / ``pipe_roll``                ``phi``, ``phi_dot``: pipe angle φ against the ground
``drive_shaft.position`` / ``.velocity``     ``drive_angle``, ``drive_rate``: drive joint q_d, the
                                             drive motor's encoder (shell against pendulum),
                                             **negated**: the encoder counts the other way round
``pitch_joint.position`` / ``.velocity``     ``pendulum_pitch``, ``pendulum_pitch_rate``: α, the
                                             pendulum's pitch against gravity (robot IMU)
``shell_yaw`` / ``ball_yaw``                 ``heading``, ``heading_rate``: ψ
===========================================  =====================================================

The drive encoder counts opposite to the twin's drive joint (whose axis is −ŷ_PC): in steady
rolling ``drive_shaft.velocity`` ≈ +ω_d (the data's own documentation) while the twin's q̇_d ≈ −ω_d.
The loader negates ``drive_shaft`` so that ``drive_angle`` and ``drive_rate`` mean exactly the
twin's q_d and q̇_d (``ROBOBALL_SIGNS``); a user mapping says the same with ``sign: -1``.

``omega_d`` (ω_d, the shell's angular velocity about the driveshaft) is not a raw RoboBall
channel. When a log has both ``drive_rate`` and ``pendulum_pitch_rate`` and no ``omega_d`` column,
it is derived as in the twin, ω_d = α̇ − q̇_d (shell against world = pendulum against world + shell
against pendulum, the drive axis being −ŷ_PC), and the log's ``derived`` records it. The data
agree with these signs: while driving, the pendulum leans against the drive (the pendulum is carried
ahead of the contact point: α and q̇_d share their sign in 90 % of the driving samples of
``free_robot``, as in the twin). Everything is converted to rad, rad/s and s from the first sample.

Every problem with an input raises :class:`LogError` (a ``ValueError``) naming the file, the CSV
line (1 = header) and/or column, and what is wrong. Loading never writes anything.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from sphere_env import safe_yaml
from sphere_env.calibration.channels import (
    ANGLE_CHANNELS,
    ROBOBALL_CHANNELS,
    ROBOBALL_SIGNS,
    ROBOBALL_TIME,
    STATE_CHANNELS,
)

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
RATE_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0}
#: Multi-turn angles, checked by their jumps between samples (at most their rate limit × the sample
#: period, plus 0.05 rad) and stored from 0 at the log's (or window's) first sample: the drive
#: encoder's zero is arbitrary and the twin starts every run at q_d = 0, ψ = 0. The heading is an
#: IMU yaw wrapping at ±π: it is unwrapped first.
MULTI_TURN: dict[str, str] = {"drive_angle": "drive_rate", "heading": "heading_rate"}


class LogError(ValueError):
    """A log, mapping or manifest that cannot be used; the message names file, line/column, problem."""


@dataclass(frozen=True)
class ColumnMapping:
    """Which CSV column holds time and each state channel, and in which unit.

    :param time: (column, unit) of the time column; unit in :data:`TIME_UNITS`.
    :param channels: project channel name -> list of candidate (column, unit); the first column
        present in the file is used.
    :param required: channels that must be present (else :class:`LogError`).
    :param signs: project channel -> ±1, the sign of the channel against its column.
    """

    time: tuple[str, str]
    channels: Mapping[str, tuple[tuple[str, str], ...]]
    required: tuple[str, ...] = ()
    source: str = "<roboball>"
    signs: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def roboball(cls, required: tuple[str, ...] = ()) -> "ColumnMapping":
        """The RoboBall log names (ns timestamps, rad, rad/s)."""
        chans = {
            name: tuple((col, "rad/s" if name not in ANGLE_CHANNELS else "rad") for col in cols)
            for name, cols in ROBOBALL_CHANNELS.items()
        }
        return cls(time=ROBOBALL_TIME, channels=chans, required=required, signs=dict(ROBOBALL_SIGNS))

    @classmethod
    def load(cls, path: str | Path) -> "ColumnMapping":
        """Read a user mapping YAML (see module docstring)."""
        p = str(path)
        try:
            data = safe_yaml.load_file(Path(path))
        except (OSError, yaml.YAMLError) as err:
            raise LogError(f"column mapping {p!r}: cannot read: {err}") from err
        if not isinstance(data, Mapping) or "time" not in data or "channels" not in data:
            raise LogError(f"column mapping {p!r}: needs 'time' and 'channels' sections")
        t = data["time"]
        if not isinstance(t, Mapping) or "column" not in t:
            raise LogError(f"column mapping {p!r}: field 'time' needs 'column' (and 'unit')")
        tunit = t.get("unit", "s")
        if tunit not in TIME_UNITS:
            raise LogError(f"column mapping {p!r}: field 'time.unit' = {tunit!r}; allowed: {list(TIME_UNITS)}")
        chans: dict[str, tuple[tuple[str, str], ...]] = {}
        signs: dict[str, float] = {}
        if not isinstance(data["channels"], Mapping) or not data["channels"]:
            raise LogError(f"column mapping {p!r}: field 'channels' must be a non-empty mapping")
        for name, spec in data["channels"].items():
            if name not in STATE_CHANNELS:
                raise LogError(f"column mapping {p!r}: channel {name!r} unknown; allowed: {list(STATE_CHANNELS)}")
            if isinstance(spec, str):
                spec = {"column": spec}
            if not isinstance(spec, Mapping) or "column" not in spec:
                raise LogError(f"column mapping {p!r}: field 'channels.{name}' needs 'column'")
            allowed = ANGLE_UNITS if name in ANGLE_CHANNELS else RATE_UNITS
            unit = spec.get("unit", "rad" if name in ANGLE_CHANNELS else "rad/s")
            if unit not in allowed:
                raise LogError(
                    f"column mapping {p!r}: field 'channels.{name}.unit' = {unit!r}; allowed: {list(allowed)}"
                )
            sign = spec.get("sign", 1)
            if isinstance(sign, bool) or sign not in (1, -1):
                raise LogError(f"column mapping {p!r}: field 'channels.{name}.sign' = {sign!r}; allowed: [1, -1]")
            chans[name] = ((str(spec["column"]), unit),)
            signs[name] = float(sign)
        return cls(time=(str(t["column"]), tunit), channels=chans, required=tuple(chans), source=p, signs=signs)


@dataclass
class RobotLog:
    """One trial in project units: time ``t_s`` [s] from the first kept sample, channels by state name.

    Angles in rad, rates in rad/s. ``meta`` carries the manifest entry (fixture, pressure_kpa, notes).
    ``derived`` names the channels computed from others (channel -> formula), e.g. ``omega_d``.
    ``window_s`` is the manifest window [start, end] in seconds from the file's first sample (None:
    the whole file); ``t_s`` then starts at 0 at the first sample inside the window.
    """

    name: str
    path: str
    t_s: np.ndarray
    channels: dict[str, np.ndarray]
    fixture: str | None = None
    pressure_kpa: float | None = None
    notes: str = ""
    meta: dict[str, Any] = field(default_factory=dict)
    derived: dict[str, str] = field(default_factory=dict)
    window_s: tuple[float, float] | None = None
    t0_s: float = 0.0  # time of the first kept sample [s from the file's first sample]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.channels[name]

    def has(self, name: str) -> bool:
        return name in self.channels

    def after(self, transient_s: float) -> "RobotLog":
        """Drop samples before ``transient_s`` [s]; time restarts at 0."""
        keep = self.t_s >= transient_s - 1e-12
        if keep.sum() < 3:
            raise LogError(f"log {self.path!r}: transient {transient_s} s leaves fewer than 3 samples")
        t = self.t_s[keep]
        return RobotLog(
            self.name,
            self.path,
            t - t[0],
            {k: v[keep] for k, v in self.channels.items()},
            self.fixture,
            self.pressure_kpa,
            self.notes,
            dict(self.meta),
            dict(self.derived),
            self.window_s,
            self.t0_s + float(t[0]),
        )

    def window(self, start_s: float, end_s: float, where: str = "window_s") -> "RobotLog":
        """The samples with ``start_s <= t <= end_s`` [s from this log's first sample]; time restarts at 0.

        Refuses (naming file, ``where`` and the problem) a reversed window, one that starts before
        the first or ends after the last sample, or one holding fewer than 3 samples.
        """
        dur = float(self.t_s[-1])
        if not (math.isfinite(start_s) and math.isfinite(end_s)) or start_s >= end_s:
            raise log_error(self.path, f"field {where!r} = [{start_s}, {end_s}]: start must be before end (seconds)")
        if start_s < 0 or end_s > dur + 1e-9:
            raise log_error(
                self.path,
                f"field {where!r} = [{start_s}, {end_s}] s lies outside the log, which spans "
                f"[0, {dur:.3f}] s from its first sample",
            )
        keep = (self.t_s >= start_s - 1e-9) & (self.t_s <= end_s + 1e-9)
        if keep.sum() < 3:
            raise log_error(
                self.path, f"field {where!r} = [{start_s}, {end_s}] s holds {int(keep.sum())} samples; need >= 3"
            )
        t = self.t_s[keep]
        # multi-turn angles restart from 0 at the window's start, as the twin's q_d and ψ do
        chans = {k: v[keep] - (v[keep][0] if k in MULTI_TURN else 0.0) for k, v in self.channels.items()}
        return RobotLog(
            self.name,
            self.path,
            t - t[0],
            chans,
            self.fixture,
            self.pressure_kpa,
            self.notes,
            dict(self.meta),
            dict(self.derived),
            (self.t0_s + float(start_s), self.t0_s + float(end_s)),
            self.t0_s + float(t[0]),
        )


#: The contract's name for a loaded trial.
LogTrial = RobotLog


def log_error(path: str, msg: str) -> LogError:
    """The :class:`LogError` of ``msg`` about the log at ``path``."""
    return LogError(f"log {path!r}: {msg}")


# ---- manifests -------------------------------------------------------------------------------------
#: A window must show at least this much motion [rad, peak to peak of φ or θ] to be fitted: the
#: RoboBall encoders and IMU rest within ~1e-3 rad, a release or push moves φ by 0.1–0.8 rad.
MIN_MOTION_RAD = 0.02
MOTION_CHANNELS = ("phi", "theta")


def check_motion(log: RobotLog, where: str = "window_s", min_motion_rad: float = MIN_MOTION_RAD) -> None:
    """Refuse a log (window) in which neither φ nor θ moves by ``min_motion_rad`` peak to peak."""
    moved = {c: float(np.ptp(log[c])) for c in MOTION_CHANNELS if log.has(c)}
    if not moved:
        raise log_error(log.path, f"field {where!r} = {list(log.window_s or ())}: no φ or θ channel to fit")
    if max(moved.values()) < min_motion_rad:
        desc = ", ".join(f"{c} {v:.4f} rad" for c, v in moved.items())
        raise log_error(
            log.path,
            f"field {where!r} = {list(log.window_s or ())} s has no free motion to fit: "
            f"peak-to-peak {desc}, below {min_motion_rad} rad",
        )
