"""Trial manifests: which log files (and windows of them) a calibration or validation reads.

A manifest is YAML, loaded through the typed schema :class:`ManifestFile` (unknown keys, wrong
types and out-of-range values refused by name before anything is read)::

    data_root: ../../../shared/data/roboball   # relative to this file, or absolute
    trials:
      - {name: stand_1, group: stand_swing, file: stand_swing/a.csv, fixture: stand,
         pressure_kpa: null, transient_s: 0.0, notes: "..."}
      - {name: push_1, group: free_robot, file: free_robot/run.csv, fixture: free,
         window_s: [32.80, 35.80], time_unit: ns}   # seconds from the file's first sample
      - {name: drive_forward, group: free_robot_driven, file: free_robot/run.csv, fixture: free,
         window_s: [10.0, 16.0], kind: driven}   # replayed with the pendulum tracking θ and α

Every ``file`` resolves against ``data_root`` and must stay inside it (``..``, absolute paths
elsewhere and symlinks out of it are refused without opening anything); a ``mapping`` resolves
against the manifest's folder and must stay inside it or ``data_root``. Files are not opened until
a trial is loaded.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import yaml
from pydantic import Field

from sphere_env import safe_yaml
from sphere_env.calibration.log_csv import load_log
from sphere_env.calibration.logs import TIME_UNITS, ColumnMapping, LogError, RobotLog, check_motion
from sphere_env.models.calibration_schema import PLAUSIBLE_PRESSURE_KPA
from sphere_env.physics.config import FIXTURES
from sphere_env.schemas import Schema, allowed, ordered_pair, validate

_P_LO, _P_HI = PLAUSIBLE_PRESSURE_KPA
#: What a window holds: free motion (replayed from its first state, no torque) or driving (replayed
#: with the pendulum tracking the logged θ and α: :mod:`sphere_env.calibration.driven`).
WINDOW_KINDS = ("free_motion", "driven")


class TrialEntry(Schema):
    """One entry of a manifest's ``trials``."""

    file: str = Field(json_schema_extra=allowed("a log file path, relative to data_root"))
    fixture: Literal[FIXTURES] = Field(json_schema_extra=allowed(str(list(FIXTURES))))  # type: ignore[valid-type]
    name: str | None = None
    group: str = ""
    pressure_kpa: float | None = Field(
        None,
        ge=_P_LO,
        le=_P_HI,
        json_schema_extra=allowed(
            f"a gauge pressure in kPa within [{_P_LO}, {_P_HI}] (an inflatable shell; Pa or "
            "MPa values fall outside), or null"
        ),
    )
    transient_s: float = Field(0.0, ge=0.0, lt=1e4, json_schema_extra=allowed("seconds dropped at the start, [0, 1e4)"))
    notes: str = ""
    mapping: str | None = Field(None, json_schema_extra=allowed("a column mapping YAML, relative to the manifest"))
    ramp_window_s: ordered_pair(None, None, "s", strict=True, words="[start, end] seconds, start < end") | None = None
    window_s: (
        ordered_pair(
            0.0, None, "s", strict=True, words=("[start, end] in seconds from the log's first sample, 0 <= start < end")
        )
        | None
    ) = None
    time_unit: Literal[tuple(TIME_UNITS)] | None = Field(  # type: ignore[valid-type]
        None, json_schema_extra=allowed(str(list(TIME_UNITS)))
    )
    kind: Literal[WINDOW_KINDS] = Field(  # type: ignore[valid-type]
        "free_motion", json_schema_extra=allowed(str(list(WINDOW_KINDS)))
    )


class ManifestFile(Schema):
    """A manifest YAML."""

    data_root: str = "."
    trials: list[TrialEntry] = Field(min_length=1, json_schema_extra=allowed("a non-empty list of trials"))


@dataclass(frozen=True)
class TrialSpec:
    """One manifest entry. ``pressure_kpa`` None = not recorded; ``transient_s`` [s] is dropped
    (counted from the window start when ``window_s`` is given). ``window_s`` = [start, end] in
    seconds from the file's first sample; several entries may cut windows from one file.
    ``time_unit`` overrides the mapping's time unit (the RoboBall mapping reads ns)."""

    name: str
    file: Path
    fixture: str
    group: str = ""
    pressure_kpa: float | None = None
    transient_s: float = 0.0
    notes: str = ""
    mapping: Path | None = None
    ramp_window_s: tuple[float, float] | None = None
    window_s: tuple[float, float] | None = None
    time_unit: str | None = None
    kind: str = "free_motion"

    def load(self, required: tuple[str, ...] = ()) -> RobotLog:
        mapping: ColumnMapping | Path | None = self.mapping
        if self.time_unit is not None:
            base = ColumnMapping.roboball() if mapping is None else ColumnMapping.load(mapping)
            mapping = replace(base, time=(base.time[0], self.time_unit))
        log = load_log(self.file, mapping, required=required, name=self.name)
        if self.window_s is not None:
            log = log.window(*self.window_s, where=f"trial {self.name!r}: window_s")
            if self.kind == "free_motion":
                check_motion(log, f"trial {self.name!r}: window_s")
        if self.transient_s > 0:
            log = log.after(self.transient_s)
        log.fixture, log.pressure_kpa, log.notes = self.fixture, self.pressure_kpa, self.notes
        log.meta = {
            "group": self.group,
            "transient_s": self.transient_s,
            "ramp_window_s": self.ramp_window_s,
            "window_s": self.window_s,
            "kind": self.kind,
        }
        if self.kind == "driven":
            from sphere_env.calibration.driven import check_driven

            check_driven(log, f"trial {self.name!r} (kind driven)")
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


def _inside(path: Path, *roots: Path) -> bool:
    real = Path(os.path.realpath(path))
    return any(real.is_relative_to(os.path.realpath(r)) for r in roots)


def load_manifest(path: str | Path, data_root: str | Path | None = None) -> Manifest:
    """Read a trial manifest YAML (module docstring). ``data_root`` given here overrides the
    file's (e.g. CLI ``--data-root``). A window is checked when its trial is loaded: it must lie
    inside the log, hold at least 3 samples and show free motion (φ or θ moving by
    :data:`~sphere_env.calibration.logs.MIN_MOTION_RAD` peak to peak)."""
    p = str(path)
    try:
        data = safe_yaml.load_file(Path(path))
    except (OSError, yaml.YAMLError) as err:
        raise LogError(f"manifest {p!r}: cannot read: {err}") from err
    spec = validate(ManifestFile, data, f"manifest {p!r}", LogError)
    base = Path(path).resolve().parent
    root = Path(data_root) if data_root is not None else Path(spec.data_root)
    if not root.is_absolute():
        root = (base / root) if data_root is None else root.resolve()
    root = Path(os.path.normpath(root))
    trials, seen = [], set()
    for i, entry in enumerate(spec.trials):
        where = f"manifest {p!r}: trials[{i}]"
        name = entry.name if entry.name is not None else Path(entry.file).stem
        if name in seen:
            raise LogError(f"{where}: duplicate trial name {name!r}")
        seen.add(name)
        f = Path(entry.file)
        f = f if f.is_absolute() else root / f
        if not _inside(f, root):
            raise LogError(
                f"{where}: field 'file' = {entry.file!r} resolves outside data_root {str(root)!r}; "
                "allowed: a path inside data_root (nothing outside it is read)"
            )
        mapping = None
        if entry.mapping is not None:
            mapping = Path(entry.mapping) if Path(entry.mapping).is_absolute() else base / entry.mapping
            if not _inside(mapping, base, root):
                raise LogError(
                    f"{where}: field 'mapping' = {entry.mapping!r} resolves outside the manifest's "
                    "folder and data_root; allowed: a path inside either"
                )
        trials.append(
            TrialSpec(
                name=name,
                file=f,
                fixture=entry.fixture,
                group=entry.group,
                pressure_kpa=entry.pressure_kpa,
                transient_s=entry.transient_s,
                notes=entry.notes,
                mapping=mapping,
                ramp_window_s=None if entry.ramp_window_s is None else tuple(entry.ramp_window_s),
                window_s=None if entry.window_s is None else tuple(entry.window_s),
                time_unit=entry.time_unit,
                kind=entry.kind,
            )
        )
    return Manifest(p, root, tuple(trials))
