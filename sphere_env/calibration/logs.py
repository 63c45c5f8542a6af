"""Robot log loading: CSV -> project state names and SI units, plus trial manifests.

A log is a CSV with one time column and named channels. The RoboBall channel names of
``../shared/data/roboball/README.md`` are understood out of the box; any other naming is given
by a small YAML column mapping::

    time: {column: t, unit: s}              # s | ms | us | ns
    channels:
      theta: {column: pendulum_deg, unit: deg}   # angles: rad | deg; rates: rad/s | deg/s | rpm
      phi:   {column: tilt, unit: rad}

Project state names (DESIGN.md §1): ``theta`` (θ, steer joint), ``theta_dot``, ``phi`` (φ, pipe
angle), ``phi_dot``, ``omega_d`` (ω_d, drive velocity), ``drive_angle`` (pitch joint),
``drive_rate``, ``heading`` (ψ). Everything is converted to rad, rad/s and s from the first sample.

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

from sphere_env.physics.twin import FIXTURES

STATE_CHANNELS = ("theta", "theta_dot", "phi", "phi_dot", "omega_d", "drive_angle", "drive_rate", "heading")
ANGLE_CHANNELS = ("theta", "phi", "drive_angle", "heading")

# RoboBall log names -> project names, first match wins (README of the real logs).
ROBOBALL_CHANNELS: dict[str, tuple[str, ...]] = {
    "theta": ("roll_joint.position",),
    "theta_dot": ("roll_joint.velocity",),
    "phi": ("ball_roll.position", "pipe_roll.position", "pipe_roll", "ball_roll"),
    "phi_dot": ("ball_roll.velocity", "pipe_roll.velocity"),
    "omega_d": ("drive_shaft.velocity",),
    "drive_angle": ("pitch_joint.position",),
    "drive_rate": ("pitch_joint.velocity",),
    "heading": ("shell_yaw.position", "ball_yaw.position", "shell_yaw", "ball_yaw"),
}
ROBOBALL_TIME = ("timestamp", "ns")

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
RATE_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0}

MAX_ANGLE_RAD = 2.0 * math.pi * 10.0  # |angle| above this cannot be radians (degrees? counts?)
MAX_RATE_RAD_S = 500.0  # no joint of this robot turns faster (the drive motor is ~30 rad/s)
DT_RANGE_S = (1e-5, 5.0)  # plausible median sample period after unit conversion


class LogError(ValueError):
    """A log, mapping or manifest that cannot be used; the message names file, line/column, problem."""


@dataclass(frozen=True)
class ColumnMapping:
    """Which CSV column holds time and each state channel, and in which unit.

    :param time: (column, unit) of the time column; unit in :data:`TIME_UNITS`.
    :param channels: project channel name -> list of candidate (column, unit); the first column
        present in the file is used.
    :param required: channels that must be present (else :class:`LogError`).
    """

    time: tuple[str, str]
    channels: Mapping[str, tuple[tuple[str, str], ...]]
    required: tuple[str, ...] = ()
    source: str = "<roboball>"

    @classmethod
    def roboball(cls, required: tuple[str, ...] = ()) -> "ColumnMapping":
        """The RoboBall log names (ns timestamps, rad, rad/s)."""
        chans = {
            name: tuple((col, "rad/s" if name not in ANGLE_CHANNELS else "rad") for col in cols)
            for name, cols in ROBOBALL_CHANNELS.items()
        }
        return cls(time=ROBOBALL_TIME, channels=chans, required=required)

    @classmethod
    def load(cls, path: str | Path) -> "ColumnMapping":
        """Read a user mapping YAML (see module docstring)."""
        p = str(path)
        try:
            data = yaml.safe_load(Path(path).read_text())
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
            chans[name] = ((str(spec["column"]), unit),)
        return cls(time=(str(t["column"]), tunit), channels=chans, required=tuple(chans), source=p)


@dataclass
class RobotLog:
    """One trial in project units: time ``t`` [s] from the first kept sample, channels by state name.

    Angles in rad, rates in rad/s. ``meta`` carries the manifest entry (fixture, pressure_kpa, notes).
    """

    name: str
    path: str
    t: np.ndarray
    channels: dict[str, np.ndarray]
    fixture: str | None = None
    pressure_kpa: float | None = None
    notes: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.channels[name]

    def has(self, name: str) -> bool:
        return name in self.channels

    def after(self, transient_s: float) -> "RobotLog":
        """Drop samples before ``transient_s`` [s]; time restarts at 0."""
        keep = self.t >= transient_s - 1e-12
        if keep.sum() < 3:
            raise LogError(f"log {self.path!r}: transient {transient_s} s leaves fewer than 3 samples")
        t = self.t[keep]
        return RobotLog(
            self.name, self.path, t - t[0], {k: v[keep] for k, v in self.channels.items()},
            self.fixture, self.pressure_kpa, self.notes, dict(self.meta),
        )


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
    df.columns = [str(c).strip() for c in df.columns]

    tcol, tunit = mapping.time
    if tcol not in df.columns:
        raise _fail(p, f"time column {tcol!r} missing; found columns {list(df.columns)} (mapping {mapping.source})")

    def numeric(col: str) -> np.ndarray:
        vals = pd.to_numeric(df[col], errors="coerce")
        bad = vals.isna() & df[col].notna()
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise _fail(p, f"line {i + 2}, column {col!r}: value {df[col].iloc[i]!r} is not a number")
        return vals.to_numpy(dtype=float)

    t_raw = numeric(tcol)
    if np.isnan(t_raw).any():
        i = int(np.flatnonzero(np.isnan(t_raw))[0])
        raise _fail(p, f"line {i + 2}, column {tcol!r}: time is missing (NaN)")
    dt = np.diff(t_raw)
    if (dt == 0).any():
        i = int(np.flatnonzero(dt == 0)[0]) + 1
        raise _fail(p, f"line {i + 2}, column {tcol!r}: duplicate time {t_raw[i]!r} (same as line {i + 1})")
    if (dt < 0).any():
        i = int(np.flatnonzero(dt < 0)[0]) + 1
        raise _fail(
            p, f"line {i + 2}, column {tcol!r}: time {t_raw[i]!r} is before line {i + 1} ({t_raw[i - 1]!r}); "
            "time must increase"
        )
    t = (t_raw - t_raw[0]) * TIME_UNITS[tunit]
    if len(t) >= 2:
        med = float(np.median(np.diff(t)))
        if not DT_RANGE_S[0] <= med <= DT_RANGE_S[1]:
            raise _fail(
                p, f"column {tcol!r}: median sample period {med:.3g} s with unit {tunit!r} is implausible "
                f"(allowed {DT_RANGE_S} s); is the time unit right?"
            )

    channels: dict[str, np.ndarray] = {}
    for chan, candidates in mapping.channels.items():
        for col, unit in candidates:
            if col in df.columns:
                x = numeric(col)
                scale = ANGLE_UNITS[unit] if chan in ANGLE_CHANNELS else RATE_UNITS[unit]
                channels[chan] = _fill_nans(p, col, x, max_nan_run) * scale
                limit = MAX_ANGLE_RAD if chan in ANGLE_CHANNELS else MAX_RATE_RAD_S
                big = np.abs(channels[chan]) > limit
                if big.any():
                    i = int(np.flatnonzero(big)[0])
                    raise _fail(
                        p, f"line {i + 2}, column {col!r}: {chan} = {channels[chan][i]:.4g} "
                        f"{'rad' if chan in ANGLE_CHANNELS else 'rad/s'} exceeds {limit:.4g} with unit {unit!r}; "
                        "the unit cannot be right"
                    )
                break
    need = tuple(dict.fromkeys(mapping.required + tuple(required)))
    for chan in need:
        if chan not in channels:
            cols = [c for c, _ in mapping.channels.get(chan, ())]
            raise _fail(
                p, f"column for {chan!r} missing (looked for {cols}); found columns {list(df.columns)}"
            )
    if not channels:
        raise _fail(p, f"no known channel columns; found {list(df.columns)} (mapping {mapping.source})")
    return RobotLog(name or Path(p).stem, p, t, channels)


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
                path, f"lines {s + 2}-{e + 1}, column {col!r}: NaN run {where} "
                f"(at most {max_run} interior NaN samples are interpolated)"
            )
    idx = np.arange(len(x))
    out = x.copy()
    out[nan] = np.interp(idx[nan], idx[~nan], x[~nan])
    return out


# ---- manifests -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TrialSpec:
    """One manifest entry. ``pressure_kpa`` None = not recorded; ``transient_s`` [s] is dropped."""

    name: str
    file: Path
    fixture: str
    group: str = ""
    pressure_kpa: float | None = None
    transient_s: float = 0.0
    notes: str = ""
    mapping: Path | None = None
    ramp_window_s: tuple[float, float] | None = None

    def load(self, required: tuple[str, ...] = ()) -> RobotLog:
        log = load_log(self.file, self.mapping, required=required, name=self.name)
        if self.transient_s > 0:
            log = log.after(self.transient_s)
        log.fixture, log.pressure_kpa, log.notes = self.fixture, self.pressure_kpa, self.notes
        log.meta = {"group": self.group, "transient_s": self.transient_s, "ramp_window_s": self.ramp_window_s}
        return log


@dataclass(frozen=True)
class Manifest:
    """A list of trials with the data root they are read from."""

    path: str
    data_root: Path
    trials: tuple[TrialSpec, ...]

    def group(self, name: str) -> list[TrialSpec]:
        out = [t for t in self.trials if t.group == name]
        if not out:
            groups = sorted({t.group for t in self.trials})
            raise LogError(f"manifest {self.path!r}: no trials in group {name!r}; groups: {groups}")
        return out

    def by_name(self, name: str) -> TrialSpec:
        for t in self.trials:
            if t.name == name:
                return t
        raise LogError(f"manifest {self.path!r}: no trial {name!r}; trials: {[t.name for t in self.trials]}")

    def available(self) -> bool:
        return self.data_root.is_dir()


def load_manifest(path: str | Path, data_root: str | Path | None = None) -> Manifest:
    """Read a trial manifest YAML::

        data_root: ../../../shared/data/roboball   # relative to this file, or absolute
        trials:
          - {name: stand_1, group: stand_swing, file: stand_swing/a.csv, fixture: stand,
             pressure_kpa: null, transient_s: 0.0, notes: "..."}

    ``data_root`` given here overrides the file's (e.g. CLI ``--data-root``). Files are not opened
    until a trial is loaded.
    """
    p = str(path)
    try:
        data = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as err:
        raise LogError(f"manifest {p!r}: cannot read: {err}") from err
    if not isinstance(data, Mapping) or not isinstance(data.get("trials"), list) or not data["trials"]:
        raise LogError(f"manifest {p!r}: needs a non-empty 'trials' list")
    base = Path(path).resolve().parent
    root = Path(data_root) if data_root is not None else Path(data.get("data_root", "."))
    if not root.is_absolute():
        root = (base / root) if data_root is None else root.resolve()
    root = Path(os.path.normpath(root))
    trials = []
    seen = set()
    for i, entry in enumerate(data["trials"]):
        where = f"manifest {p!r}: trials[{i}]"
        if not isinstance(entry, Mapping):
            raise LogError(f"{where}: must be a mapping")
        for key in ("file", "fixture"):
            if key not in entry:
                raise LogError(f"{where}: field {key!r} is missing")
        if entry["fixture"] not in FIXTURES:
            raise LogError(f"{where}: field 'fixture' = {entry['fixture']!r}; allowed: {list(FIXTURES)}")
        pk = entry.get("pressure_kpa")
        if pk is not None and (isinstance(pk, bool) or not isinstance(pk, (int, float)) or not math.isfinite(pk) or pk <= 0):
            raise LogError(f"{where}: field 'pressure_kpa' = {pk!r} must be a positive number (kPa gauge) or null")
        tr = entry.get("transient_s", 0.0)
        if isinstance(tr, bool) or not isinstance(tr, (int, float)) or not 0 <= tr < 1e4:
            raise LogError(f"{where}: field 'transient_s' = {tr!r} must be a number >= 0 (s)")
        name = str(entry.get("name", Path(entry["file"]).stem))
        if name in seen:
            raise LogError(f"{where}: duplicate trial name {name!r}")
        seen.add(name)
        mapping = entry.get("mapping")
        rw = entry.get("ramp_window_s")
        if rw is not None and (not isinstance(rw, list) or len(rw) != 2 or not rw[0] < rw[1]):
            raise LogError(f"{where}: field 'ramp_window_s' = {rw!r} must be [start, end] seconds")
        f = Path(entry["file"])
        trials.append(
            TrialSpec(
                name=name,
                file=f if f.is_absolute() else root / f,
                fixture=entry["fixture"],
                group=str(entry.get("group", "")),
                pressure_kpa=None if pk is None else float(pk),
                transient_s=float(tr),
                notes=str(entry.get("notes", "")),
                mapping=None if mapping is None else (base / mapping if not Path(mapping).is_absolute() else Path(mapping)),
                ramp_window_s=None if rw is None else (float(rw[0]), float(rw[1])),
            )
        )
    return Manifest(p, root, tuple(trials))


def write_log_csv(path: str | Path, t_s: np.ndarray, channels: Mapping[str, np.ndarray],
                  t0_ns: int = 1_000_000_000) -> Path:
    """Write channels in the RoboBall CSV format (ns ``timestamp``, ``roll_joint.position`` ...).

    Used to synthesize logs from the twin (tests, examples). Channel names are project names.
    """
    names = {"theta": "roll_joint.position", "theta_dot": "roll_joint.velocity", "phi": "ball_roll.position",
             "phi_dot": "ball_roll.velocity", "omega_d": "drive_shaft.velocity",
             "drive_angle": "pitch_joint.position", "drive_rate": "pitch_joint.velocity",
             "heading": "shell_yaw.position"}
    df = pd.DataFrame({"timestamp": (t0_ns + np.round(np.asarray(t_s) * 1e9)).astype(np.int64)})
    for k, v in channels.items():
        df[names[k]] = np.asarray(v, float)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(path, index=False)
    return path
