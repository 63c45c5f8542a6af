"""Robot log loading: CSV -> project state names and SI units, plus trial manifests.

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
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd
import yaml

from sphere_env import safe_yaml
from sphere_env.calibration.channels import (
    ANGLE_CHANNELS,
    ROBOBALL_CHANNELS,
    ROBOBALL_COLUMNS,
    ROBOBALL_SIGNS,
    ROBOBALL_TIME,
    STATE_CHANNELS,
)
from sphere_env.schemas import shown

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
RATE_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0}

MAX_RATE_RAD_S = 500.0  # no joint of this robot turns faster (the drive motor is ~30 rad/s)
#: Largest plausible |value| per channel, in rad or rad/s, so that a log in degrees, deg/s or
#: encoder counts is refused instead of fitted. Only quantities physics bounds absolutely: the IMU's
#: lean φ and pitch α against gravity cannot pass a quarter and a half turn, and the rates. Rates:
#: the RoboBall logs stay below 3.4 rad/s (θ̇) and 1.6 rad/s (φ̇, q̇_d, ω_d); the limits leave a wide
#: margin but are below what a few tens of rad/s written in deg/s becomes. Encoders may carry any
#: offset (a multi-turn drive count reads ≈ 264 rad on a robot that booted long ago), so their
#: absolute values are never checked: see :data:`SPAN_LIMITS` and :data:`MULTI_TURN`.
CHANNEL_LIMITS: dict[str, float] = {
    "phi": math.pi / 2,
    "pendulum_pitch": math.pi,
    "theta_dot": 30.0,
    "phi_dot": 30.0,
    "pendulum_pitch_rate": 30.0,
    "heading_rate": 30.0,
    "drive_rate": 60.0,
    "omega_d": 60.0,
}
#: Largest plausible peak-to-peak of an offset encoder [rad]: the steer joint θ moves within
#: [−1.57, 1.0] rad (``docs/design.md`` §1), 2.57 rad, whatever zero its encoder has.
SPAN_LIMITS: dict[str, float] = {"theta": 3.0}
#: Multi-turn angles, checked by their jumps between samples (at most their rate limit × the sample
#: period, plus 0.05 rad) and stored from 0 at the log's (or window's) first sample: the drive
#: encoder's zero is arbitrary and the twin starts every run at q_d = 0, ψ = 0. The heading is an
#: IMU yaw wrapping at ±π: it is unwrapped first.
MULTI_TURN: dict[str, str] = {"drive_angle": "drive_rate", "heading": "heading_rate"}
JUMP_SLACK_RAD = 0.05
#: Longest gap between two samples, in median sample periods (the shared logs: at most 4.3).
MAX_GAP_SAMPLES = 10.0
#: Angle -> rate channel pairs whose ratio (rate against the angle's time derivative) is checked.
RATE_OF = {"theta": "theta_dot", "phi": "phi_dot", "drive_angle": "drive_rate", "pendulum_pitch": "pendulum_pitch_rate"}
#: Least-squares gain of a rate on its angle's derivative outside this range means the angle and the
#: rate are in different units (deg vs rad gives 57.3 or 1/57.3); judged only where the two agree in
#: shape (correlation >= 0.9). The RoboBall logs give 0.79-0.95.
RATE_GAIN_RANGE = (0.2, 5.0)
#: Plausible median sample period after unit conversion [s]: 5 kHz to 1 Hz (the RoboBall logs are
#: 50-100 Hz). A µs time column read as ns gives 1e-5 s, an ns column read as µs 10 s.
DT_RANGE_S = (2e-4, 1.0)


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
            raise _fail(self.path, f"field {where!r} = [{start_s}, {end_s}]: start must be before end (seconds)")
        if start_s < 0 or end_s > dur + 1e-9:
            raise _fail(
                self.path,
                f"field {where!r} = [{start_s}, {end_s}] s lies outside the log, which spans "
                f"[0, {dur:.3f}] s from its first sample",
            )
        keep = (self.t_s >= start_s - 1e-9) & (self.t_s <= end_s + 1e-9)
        if keep.sum() < 3:
            raise _fail(
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


def _fail(path: str, msg: str) -> LogError:
    return LogError(f"log {path!r}: {msg}")


def load_log(
    path: str | Path,
    mapping: ColumnMapping | str | Path | None = None,
    required: tuple[str, ...] = (),
    max_nan_run: int = 2,
    name: str | None = None,
) -> RobotLog:
    """Read one CSV log into a :class:`RobotLog` (SI units, project names).

    :param mapping: a :class:`ColumnMapping`, a mapping YAML path, or ``None`` for RoboBall names.
    :param required: channels that must be present, in addition to the mapping's own.
    :param max_nan_run: isolated gaps of up to this many NaN samples are linearly interpolated;
        longer NaN runs are refused (0 refuses any NaN).
    """
    p = str(path)
    if mapping is None:
        mapping = ColumnMapping.roboball()
    elif not isinstance(mapping, ColumnMapping):
        mapping = ColumnMapping.load(mapping)
    try:
        if os.path.getsize(p) == 0:
            raise _fail(p, "file is empty (no header, no rows)")
        df = pd.read_csv(p, skipinitialspace=True)
    except LogError:
        raise
    except FileNotFoundError as err:
        raise _fail(p, "file not found") from err
    except pd.errors.EmptyDataError as err:
        raise _fail(p, "file is empty (no header, no rows)") from err
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as err:
        raise _fail(p, f"cannot parse as CSV: {err}") from err
    if len(df) == 0:
        raise _fail(p, f"file is empty: header {list(df.columns)} but no data rows")
    header = _header(p)  # pandas renames a repeated name ("x", "x.1"): the file's own names
    seen: set[str] = set()
    for i, column in enumerate(header):
        if column in seen:
            raise _fail(
                p, f"header, column {i + 1}: the name {shown(column)} is given twice; column names must be unique"
            )
        seen.add(column)
    df.columns = [str(c).strip() for c in df.columns]

    tcol, tunit = mapping.time
    if tcol not in df.columns:
        raise _fail(
            p, f"time column {tcol!r} missing; found columns {shown(list(df.columns))} (mapping {mapping.source})"
        )

    def numeric(col: str, time: bool = False) -> np.ndarray:
        vals = pd.to_numeric(df[col], errors="coerce")
        bad = vals.isna() & df[col].notna()
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise _fail(p, f"line {i + 2}, column {shown(col)}: value {shown(df[col].iloc[i])} is not a number")
        x = vals.to_numpy(dtype=float)
        infinite = np.isinf(x)
        if infinite.any() and not time:  # a missing sample is NaN (interpolated when short); inf is none
            i = int(np.flatnonzero(infinite)[0])
            raise _fail(p, f"line {i + 2}, column {shown(col)}: value {x[i]} is not finite")
        return x

    t_raw = numeric(tcol, time=True)  # its own checks name a missing or infinite time
    if np.isnan(t_raw).any():
        i = int(np.flatnonzero(np.isnan(t_raw))[0])
        raise _fail(p, f"line {i + 2}, column {tcol!r}: time is missing (NaN)")
    if not np.isfinite(t_raw).all():
        i = int(np.flatnonzero(~np.isfinite(t_raw))[0])
        raise _fail(p, f"line {i + 2}, column {tcol!r}: time {float(t_raw[i])} is not finite")
    dt = np.diff(t_raw)
    if (dt == 0).any():
        i = int(np.flatnonzero(dt == 0)[0]) + 1
        raise _fail(p, f"line {i + 2}, column {tcol!r}: duplicate time {float(t_raw[i])} (same as line {i + 1})")
    if (dt < 0).any():
        i = int(np.flatnonzero(dt < 0)[0]) + 1
        raise _fail(
            p,
            f"line {i + 2}, column {tcol!r}: time {float(t_raw[i])} is before line {i + 1} ({float(t_raw[i - 1])}); "
            "time must increase",
        )
    t = (t_raw - t_raw[0]) * TIME_UNITS[tunit]
    if len(t) >= 2:
        med = float(np.median(np.diff(t)))
        if not DT_RANGE_S[0] <= med <= DT_RANGE_S[1]:
            raise _fail(
                p,
                f"column {tcol!r}: median sample period {med:.3g} s with unit {tunit!r} is implausible "
                f"(allowed {DT_RANGE_S} s); is the time unit right?",
            )
        gaps = np.diff(t) > MAX_GAP_SAMPLES * med
        if gaps.any():
            i = int(np.flatnonzero(gaps)[0])
            raise _fail(
                p,
                f"line {i + 3}, column {tcol!r}: a gap of {t[i + 1] - t[i]:.4g} s at t = {t[i]:.3f} s "
                f"from the first sample; allowed: at most {MAX_GAP_SAMPLES:g} sample periods "
                f"({MAX_GAP_SAMPLES * med:.3g} s): cut the log into windows either side of it",
            )

    channels: dict[str, np.ndarray] = {}
    columns: dict[str, str] = {}
    for chan, candidates in mapping.channels.items():
        for col, unit in candidates:
            if col in df.columns:
                x = numeric(col)
                scale = ANGLE_UNITS[unit] if chan in ANGLE_CHANNELS else RATE_UNITS[unit]
                channels[chan] = _fill_nans(p, col, x, max_nan_run) * (scale * mapping.signs.get(chan, 1.0))
                if chan in MULTI_TURN:
                    channels[chan] = _relative_turns(p, col, unit, chan, t, channels[chan])
                    columns[chan] = col
                    break
                span = np.maximum.accumulate(channels[chan]) - np.minimum.accumulate(channels[chan])
                if chan in SPAN_LIMITS and span[-1] > SPAN_LIMITS[chan]:
                    i = int(np.flatnonzero(span > SPAN_LIMITS[chan])[0])
                    raise _fail(
                        p,
                        f"line {i + 2}, column {col!r}: {chan} spans {span[i]:.4g} rad up to here (read "
                        f"with unit {unit!r}); allowed: at most {SPAN_LIMITS[chan]:g} rad, the joint's range "
                        "whatever its encoder's zero; is the column in degrees or counts?",
                    )
                limit = CHANNEL_LIMITS.get(chan, MAX_RATE_RAD_S if chan not in ANGLE_CHANNELS else math.inf)
                big = np.abs(channels[chan]) > limit
                if big.any():
                    i = int(np.flatnonzero(big)[0])
                    si = "rad" if chan in ANGLE_CHANNELS else "rad/s"
                    raise _fail(
                        p,
                        f"line {i + 2}, column {col!r}: {chan} = {channels[chan][i]:.4g} {si} "
                        f"(read with unit {unit!r}) is beyond what this robot can do: allowed |{chan}| <= "
                        f"{limit:.4g} {si}; is the column in {'degrees' if si == 'rad' else 'deg/s'} or counts?",
                    )
                columns[chan] = col
                break
    _check_rate_units(p, t, channels, columns)
    derived: dict[str, str] = {}
    if "omega_d" not in channels and "drive_rate" in channels and "pendulum_pitch_rate" in channels:
        # ω_d = α̇ − q̇_d, as the twin reads it (module docstring).
        channels["omega_d"] = channels["pendulum_pitch_rate"] - channels["drive_rate"]
        derived["omega_d"] = "pendulum_pitch_rate - drive_rate"
    need = tuple(dict.fromkeys(mapping.required + tuple(required)))
    for chan in need:
        if chan not in channels:
            cols = [c for c, _ in mapping.channels.get(chan, ())]
            raise _fail(p, f"column for {chan!r} missing (looked for {cols}); found columns {shown(list(df.columns))}")
    if not channels:
        raise _fail(p, f"no known channel columns; found {list(df.columns)} (mapping {mapping.source})")
    return RobotLog(name or Path(p).stem, p, t, channels, derived=derived)


def _header(path: str) -> list[str]:
    """The column names of a CSV file's first line, stripped (a name longer than the csv module's
    field limit, 131 072 characters, is refused by name)."""
    import csv

    try:
        with open(path, newline="", encoding="utf-8", errors="replace") as f:
            return [name.strip() for name in next(csv.reader(f), [])]
    except csv.Error as err:
        raise _fail(path, f"header: {err}") from None


def _check_rate_units(path: str, t: np.ndarray, channels: Mapping[str, np.ndarray], columns: Mapping[str, str]) -> None:
    """Refuse a log whose rate column disagrees with its angle column's derivative by a unit factor
    (one in degrees, the other in radians; or a wrong time unit)."""
    for angle, rate in RATE_OF.items():
        if angle not in channels or rate not in channels or len(t) < 5 or np.ptp(channels[angle]) < 0.05:
            continue
        g = np.gradient(channels[angle], t)
        r = channels[rate]
        if np.std(g) == 0 or np.std(r) == 0 or np.corrcoef(g, r)[0, 1] < 0.9:
            continue
        gain = float(np.dot(r, g) / np.dot(g, g))
        if not RATE_GAIN_RANGE[0] <= gain <= RATE_GAIN_RANGE[1]:
            raise _fail(
                path,
                f"columns {columns[rate]!r} and {columns[angle]!r}: {rate} is {gain:.3g} x the "
                f"time derivative of {angle} (allowed {RATE_GAIN_RANGE[0]}-{RATE_GAIN_RANGE[1]}); the two "
                "columns are in different units (57.3: deg/s against rad; 1000: a time unit off)",
            )


def _relative_turns(path: str, col: str, unit: str, chan: str, t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A multi-turn angle (:data:`MULTI_TURN`) from 0 at the first sample, refused when it jumps
    faster than its rate limit between two samples (degrees or counts read as radians)."""
    if chan == "heading":
        x = np.unwrap(x)
    if len(x) >= 2:
        limit = CHANNEL_LIMITS[MULTI_TURN[chan]]
        jump = np.abs(np.diff(x)) > limit * np.diff(t) + JUMP_SLACK_RAD
        if jump.any():
            i = int(np.flatnonzero(jump)[0])
            raise _fail(
                path,
                f"line {i + 3}, column {col!r}: {chan} jumps by {x[i + 1] - x[i]:.4g} rad in "
                f"{t[i + 1] - t[i]:.3g} s (read with unit {unit!r}); allowed: at most {limit:g} rad/s "
                "between samples; is the column in degrees or counts?",
            )
    return x - x[0]


def _fill_nans(path: str, col: str, x: np.ndarray, max_run: int) -> np.ndarray:
    nan = np.isnan(x)
    if not nan.any():
        return x
    # Find runs of NaN.
    edges = np.diff(np.concatenate([[0], nan.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    for s, e in zip(starts, ends):
        if e - s > max_run or s == 0 or e == len(x):
            where = "at the start" if s == 0 else "at the end" if e == len(x) else f"of {e - s} samples"
            raise _fail(
                path,
                f"lines {s + 2}-{e + 1}, column {col!r}: NaN run {where} "
                f"(at most {max_run} interior NaN samples are interpolated)",
            )
    idx = np.arange(len(x))
    out = x.copy()
    out[nan] = np.interp(idx[nan], idx[~nan], x[~nan])
    return out


# ---- manifests -------------------------------------------------------------------------------------
#: A window must show at least this much motion [rad, peak to peak of φ or θ] to be fitted: the
#: RoboBall encoders and IMU rest within ~1e-3 rad, a release or push moves φ by 0.1–0.8 rad.
MIN_MOTION_RAD = 0.02
#: Gauge pressures [kPa] a trial of an inflatable shell can have been run at: RoboBall runs
#: 3-14 kPa; a fabric/rubber shell does not hold 100 kPa (1 bar) over ambient. A value in Pa
#: (thousands) or MPa (thousandths) falls outside.
PLAUSIBLE_PRESSURE_KPA = (0.5, 100.0)
MOTION_CHANNELS = ("phi", "theta")


def check_motion(log: RobotLog, where: str = "window_s", min_motion_rad: float = MIN_MOTION_RAD) -> None:
    """Refuse a log (window) in which neither φ nor θ moves by ``min_motion_rad`` peak to peak."""
    moved = {c: float(np.ptp(log[c])) for c in MOTION_CHANNELS if log.has(c)}
    if not moved:
        raise _fail(log.path, f"field {where!r} = {list(log.window_s or ())}: no φ or θ channel to fit")
    if max(moved.values()) < min_motion_rad:
        desc = ", ".join(f"{c} {v:.4f} rad" for c, v in moved.items())
        raise _fail(
            log.path,
            f"field {where!r} = {list(log.window_s or ())} s has no free motion to fit: "
            f"peak-to-peak {desc}, below {min_motion_rad} rad",
        )


def write_log_csv(
    path: str | Path, t_s: np.ndarray, channels: Mapping[str, np.ndarray], t0_ns: int = 1_000_000_000
) -> Path:
    """Write channels in the RoboBall CSV format (ns ``timestamp``, ``roll_joint.position`` ...).

    Used to synthesize logs from the twin (tests, examples). Channel names are project names;
    ``omega_d`` goes to a column ``omega_d``, which the RoboBall mapping reads as a measured ω_d.
    """
    names = dict(ROBOBALL_COLUMNS, omega_d="omega_d")  # ω_d has no RoboBall column: written under its own name
    df = pd.DataFrame({"timestamp": (t0_ns + np.round(np.asarray(t_s) * 1e9)).astype(np.int64)})
    for k, v in channels.items():
        df[names[k]] = ROBOBALL_SIGNS.get(k, 1.0) * np.asarray(v, float)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(path, index=False)
    return path
