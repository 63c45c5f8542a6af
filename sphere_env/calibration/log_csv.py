"""RoboBall-format CSV logs: :func:`load_log` reads one into a :class:`~sphere_env.calibration.logs.RobotLog`
(project names, SI units), refusing what is implausible for this robot; :func:`write_log_csv` writes
one. The column mappings, the channels and their signs: :mod:`sphere_env.calibration.logs`.

Every problem with an input raises :class:`~sphere_env.calibration.logs.LogError` (a ``ValueError``)
naming the file, the CSV line (1 = header) and/or column, and what is wrong.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from sphere_env.calibration.channels import ANGLE_CHANNELS, ROBOBALL_COLUMNS, ROBOBALL_SIGNS
from sphere_env.calibration.logs import (
    ANGLE_UNITS,
    MULTI_TURN,
    RATE_UNITS,
    TIME_UNITS,
    ColumnMapping,
    LogError,
    RobotLog,
    log_error,
)
from sphere_env.schemas import shown

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
    df = _read_frame(p)
    tcol, tunit = mapping.time
    if tcol not in df.columns:
        raise log_error(
            p, f"time column {tcol!r} missing; found columns {shown(list(df.columns))} (mapping {mapping.source})"
        )

    t = _time_s(p, df, tcol, tunit)
    channels, columns = _channels(p, df, mapping, t, max_nan_run)
    _check_rate_units(p, t, channels, columns)
    derived: dict[str, str] = {}
    if "omega_d" not in channels and "drive_rate" in channels and "pendulum_pitch_rate" in channels:
        # ω_d = α̇ − q̇_d, as the twin reads it (the docstring of sphere_env.calibration.logs).
        channels["omega_d"] = channels["pendulum_pitch_rate"] - channels["drive_rate"]
        derived["omega_d"] = "pendulum_pitch_rate - drive_rate"
    need = tuple(dict.fromkeys(mapping.required + tuple(required)))
    for chan in need:
        if chan not in channels:
            cols = [c for c, _ in mapping.channels.get(chan, ())]
            raise log_error(
                p, f"column for {chan!r} missing (looked for {cols}); found columns {shown(list(df.columns))}"
            )
    if not channels:
        raise log_error(p, f"no known channel columns; found {list(df.columns)} (mapping {mapping.source})")
    return RobotLog(name or Path(p).stem, p, t, channels, derived=derived)


def _read_frame(p: str) -> pd.DataFrame:
    """The CSV at ``p`` as a frame with stripped column names; refuses an empty or unparsable
    file and a header that names a column twice."""
    try:
        if os.path.getsize(p) == 0:
            raise log_error(p, "file is empty (no header, no rows)")
        df = pd.read_csv(p, skipinitialspace=True)
    except LogError:
        raise
    except FileNotFoundError as err:
        raise log_error(p, "file not found") from err
    except pd.errors.EmptyDataError as err:
        raise log_error(p, "file is empty (no header, no rows)") from err
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as err:
        raise log_error(p, f"cannot parse as CSV: {err}") from err
    if len(df) == 0:
        raise log_error(p, f"file is empty: header {list(df.columns)} but no data rows")
    header = _header(p)  # pandas renames a repeated name ("x", "x.1"): the file's own names
    seen: set[str] = set()
    for i, column in enumerate(header):
        if column in seen:
            raise log_error(
                p, f"header, column {i + 1}: the name {shown(column)} is given twice; column names must be unique"
            )
        seen.add(column)
    df.columns = [str(c).strip() for c in df.columns]
    return df


def _numeric(p: str, df: pd.DataFrame, col: str, time: bool = False) -> np.ndarray:
    """Column ``col`` as floats; refuses text, and an infinite value outside the time column."""
    vals = pd.to_numeric(df[col], errors="coerce")
    bad = vals.isna() & df[col].notna()
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise log_error(p, f"line {i + 2}, column {shown(col)}: value {shown(df[col].iloc[i])} is not a number")
    x = vals.to_numpy(dtype=float)
    infinite = np.isinf(x)
    if infinite.any() and not time:  # a missing sample is NaN (interpolated when short); inf is none
        i = int(np.flatnonzero(infinite)[0])
        raise log_error(p, f"line {i + 2}, column {shown(col)}: value {x[i]} is not finite")
    return x


def _time_s(p: str, df: pd.DataFrame, tcol: str, tunit: str) -> np.ndarray:
    """Time [s] from the first sample; refuses a missing, repeated or decreasing time, an
    implausible sample period and a gap of more than :data:`MAX_GAP_SAMPLES` periods."""
    t_raw = _numeric(p, df, tcol, time=True)  # its own checks name a missing or infinite time
    if np.isnan(t_raw).any():
        i = int(np.flatnonzero(np.isnan(t_raw))[0])
        raise log_error(p, f"line {i + 2}, column {tcol!r}: time is missing (NaN)")
    if not np.isfinite(t_raw).all():
        i = int(np.flatnonzero(~np.isfinite(t_raw))[0])
        raise log_error(p, f"line {i + 2}, column {tcol!r}: time {float(t_raw[i])} is not finite")
    dt = np.diff(t_raw)
    if (dt == 0).any():
        i = int(np.flatnonzero(dt == 0)[0]) + 1
        raise log_error(p, f"line {i + 2}, column {tcol!r}: duplicate time {float(t_raw[i])} (same as line {i + 1})")
    if (dt < 0).any():
        i = int(np.flatnonzero(dt < 0)[0]) + 1
        raise log_error(
            p,
            f"line {i + 2}, column {tcol!r}: time {float(t_raw[i])} is before line {i + 1} ({float(t_raw[i - 1])}); "
            "time must increase",
        )
    t = (t_raw - t_raw[0]) * TIME_UNITS[tunit]
    if len(t) >= 2:
        med = float(np.median(np.diff(t)))
        if not DT_RANGE_S[0] <= med <= DT_RANGE_S[1]:
            raise log_error(
                p,
                f"column {tcol!r}: median sample period {med:.3g} s with unit {tunit!r} is implausible "
                f"(allowed {DT_RANGE_S} s); is the time unit right?",
            )
        gaps = np.diff(t) > MAX_GAP_SAMPLES * med
        if gaps.any():
            i = int(np.flatnonzero(gaps)[0])
            raise log_error(
                p,
                f"line {i + 3}, column {tcol!r}: a gap of {t[i + 1] - t[i]:.4g} s at t = {t[i]:.3f} s "
                f"from the first sample; allowed: at most {MAX_GAP_SAMPLES:g} sample periods "
                f"({MAX_GAP_SAMPLES * med:.3g} s): cut the log into windows either side of it",
            )
    return t


def _channels(
    p: str, df: pd.DataFrame, mapping: ColumnMapping, t: np.ndarray, max_nan_run: int
) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """(channel -> values in SI units, channel -> its column) of the mapped columns found in
    ``df``; refuses a value beyond what this robot can do (:data:`CHANNEL_LIMITS`,
    :data:`SPAN_LIMITS`, :data:`MULTI_TURN`)."""
    channels: dict[str, np.ndarray] = {}
    columns: dict[str, str] = {}
    for chan, candidates in mapping.channels.items():
        for col, unit in candidates:
            if col in df.columns:
                x = _numeric(p, df, col)
                scale = ANGLE_UNITS[unit] if chan in ANGLE_CHANNELS else RATE_UNITS[unit]
                channels[chan] = _fill_nans(p, col, x, max_nan_run) * (scale * mapping.signs.get(chan, 1.0))
                if chan in MULTI_TURN:
                    channels[chan] = _relative_turns(p, col, unit, chan, t, channels[chan])
                    columns[chan] = col
                    break
                span = np.maximum.accumulate(channels[chan]) - np.minimum.accumulate(channels[chan])
                if chan in SPAN_LIMITS and span[-1] > SPAN_LIMITS[chan]:
                    i = int(np.flatnonzero(span > SPAN_LIMITS[chan])[0])
                    raise log_error(
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
                    raise log_error(
                        p,
                        f"line {i + 2}, column {col!r}: {chan} = {channels[chan][i]:.4g} {si} "
                        f"(read with unit {unit!r}) is beyond what this robot can do: allowed |{chan}| <= "
                        f"{limit:.4g} {si}; is the column in {'degrees' if si == 'rad' else 'deg/s'} or counts?",
                    )
                columns[chan] = col
                break
    return channels, columns


def _header(path: str) -> list[str]:
    """The column names of a CSV file's first line, stripped (a name longer than the csv module's
    field limit, 131 072 characters, is refused by name)."""
    import csv

    try:
        with open(path, newline="", encoding="utf-8", errors="replace") as f:
            return [name.strip() for name in next(csv.reader(f), [])]
    except csv.Error as err:
        raise log_error(path, f"header: {err}") from None


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
            raise log_error(
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
            raise log_error(
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
            raise log_error(
                path,
                f"lines {s + 2}-{e + 1}, column {col!r}: NaN run {where} "
                f"(at most {max_run} interior NaN samples are interpolated)",
            )
    idx = np.arange(len(x))
    out = x.copy()
    out[nan] = np.interp(idx[nan], idx[~nan], x[~nan])
    return out


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
