"""Free-motion events in a long log: a release or a push followed by free decay.

An event is found in three steps, all on the steer-direction channels φ and θ (the channels a
shell fit uses):

1. **Activity.** a(t) = max(|φ̇|, |θ̇|) [rad/s], from the logged rates or, where a log has none,
   from the position's time derivative; smoothed over :data:`SMOOTH_S`.
2. **Segments.** A segment starts where a(t) rises above :data:`ACTIVE_RAD_S` after at least
   :data:`QUIET_BEFORE_S` of rest (a hold or standstill; a(t) below :data:`REST_RAD_S`). Its start
   is the last resting sample (unsmoothed rates below :data:`REST_RAD_S`) before the rise: the
   moment the hold ends. It ends at the last sample above :data:`ACTIVE_RAD_S` before a(t) stays
   below :data:`REST_RAD_S` for :data:`QUIET_AFTER_S` (or at the end of the log).
3. **Free decay.** A segment is kept when it swings back and forth and dies out: the moving
   channel's rate changes sign at least :data:`MIN_SWINGS` times and its last third moves less
   than its first third; and the drive joint turns by less than :data:`MAX_DRIVE_TURN_RAD` (when
   the drive turns the motor is driving, and its torque is not logged, so that part cannot be
   replayed). A commanded steer ramp moves θ one way and does not swing; driving turns the drive.

Whatever started the motion may still act on the robot while its first swing builds up: a push
is a hand moving the robot from standstill, and a release lets go of a held pendulum gradually
(on the free robot's release the pendulum leaves the hold far more slowly than gravity and the
steer friction fitted on the stand allow, and the shell does not roll for 0.3 s; a twin fitted on
that first swing still misses θ by 0.20 rad). For every event ``free_start_s`` is therefore the
first turning point of the moving channel (its rate changes sign), by which time the robot swings
on its own. Manifest entries start their windows there.

Thresholds are constants of this module, chosen on physical grounds, not tuned per log. Swings
worth fitting move at 0.1–1.5 rad/s (:data:`ACTIVE_RAD_S`). "At rest" is not "not moving": a robot
that has settled on its soft shell, or is ending a decay, still rocks on the floor by a few hundredths
of a radian (up to ~0.03 rad peak to peak in the free-robot logs), and a held pendulum sways in the
hand by as much. Rest is therefore rocking smaller than :data:`REST_SWING_RAD` peak to peak; a
rocking of amplitude A at angular frequency ω peaks at a rate A ω, and the fastest steer-direction
mode of this robot is the pendulum's own swing with the shell held (5.6 rad/s on the stand; on free
ground every rocking mode is slower), so :data:`REST_RAD_S` = (REST_SWING_RAD / 2) × that frequency
bounds the rate of any rest wobble. A rest threshold at sensor noise (~1e-3 rad/s) would see no
rest between pushes a few seconds apart, whose decays have not quite died out.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import yaml

from sphere_env import safe_yaml
from sphere_env.calibration.logs import MIN_MOTION_RAD, LogError, RobotLog
from sphere_env.files import write_text_atomic
from sphere_env.reporting import markdown_table

SMOOTH_S = 0.1  # moving-average length of the activity signal [s]
REST_SWING_RAD = 0.03  # peak-to-peak rocking still counted as rest [rad] (module docstring)
FASTEST_MODE_RAD_S = 5.6  # the pendulum's small-swing frequency with the shell held (stand_swing) [rad/s]
REST_RAD_S = 0.5 * REST_SWING_RAD * FASTEST_MODE_RAD_S  # below: at rest or held (0.084) [rad/s]
ACTIVE_RAD_S = 0.15  # above: moving [rad/s]
QUIET_BEFORE_S = 0.5  # rest needed before a release or push [s]
QUIET_AFTER_S = 0.5  # rest that ends an event [s]
MIN_SWINGS = 2  # sign changes of the moving channel's rate (one swing out and back)
MAX_DRIVE_TURN_RAD = 0.1  # drive-joint turn above which a segment is driven, not free [rad]
REPORT_CHANNELS = ("theta", "phi", "drive_angle", "pendulum_pitch", "heading")
RATE_OF = {"theta": "theta_dot", "phi": "phi_dot"}


@dataclass(frozen=True)
class Event:
    """One free-motion event: ``start_s``/``end_s`` in seconds from the log's first sample, the
    channels that moved (by more than :data:`MIN_MOTION_RAD` peak to peak, with their ranges [rad])."""

    start_s: float
    end_s: float
    moved: dict[str, float]
    kind: str  # "release" (held away from rest, then let go) or "push" (from standstill)
    free_start_s: float  # where free motion surely runs: the first turning point of the moving channel

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def as_dict(self) -> dict[str, Any]:
        return {
            "start_s": round(self.start_s, 3),
            "end_s": round(self.end_s, 3),
            "kind": self.kind,
            "free_start_s": round(self.free_start_s, 3),
            "moved_rad": {k: round(v, 4) for k, v in self.moved.items()},
        }


def _rate(log: RobotLog, chan: str) -> np.ndarray:
    rate = RATE_OF[chan]
    return np.asarray(log[rate] if log.has(rate) else np.gradient(log[chan], log.t_s), float)


def _smooth(t: np.ndarray, x: np.ndarray, window_s: float) -> np.ndarray:
    n = max(int(round(window_s / max(float(np.median(np.diff(t))), 1e-6))), 1)
    return np.convolve(x, np.ones(n) / n, mode="same")


def find_events(log: RobotLog) -> list[Event]:
    """The free-motion events of ``log`` (module docstring), in time order."""
    chans = [c for c in RATE_OF if log.has(c)]
    if not chans or len(log.t_s) < 10:
        raise LogError(f"log {log.path!r}: needs φ or θ and at least 10 samples to find events")
    t = log.t_s
    rates = {c: _rate(log, c) for c in chans}
    raw = np.max(np.abs(np.vstack([rates[c] for c in chans])), axis=0)
    act = _smooth(t, raw, SMOOTH_S)
    rest = act < REST_RAD_S
    events: list[Event] = []
    i, n = 0, len(t)
    while i < n:
        if act[i] <= ACTIVE_RAD_S:
            i += 1
            continue
        # Rest before: walk back to the last resting sample, then check it lasted QUIET_BEFORE_S.
        j = i
        while j > 0 and not rest[j]:
            j -= 1
        k = j
        while k > 0 and rest[k - 1]:
            k -= 1
        # End: first time a(t) stays below REST for QUIET_AFTER_S.
        e = i
        quiet_since = None
        while e < n:
            if rest[e]:
                quiet_since = e if quiet_since is None else quiet_since
                if t[e] - t[quiet_since] >= QUIET_AFTER_S:
                    break
            else:
                quiet_since = None
            e += 1
        # The event ends at its last sample moving faster than ACTIVE before that rest.
        stop = min(quiet_since if quiet_since is not None else n - 1, n - 1)
        end = stop
        while end > i and act[end] <= ACTIVE_RAD_S:
            end -= 1
        if rest[j] and t[j] - t[k] >= QUIET_BEFORE_S:
            # The smoothing spreads the onset by half its window: step forward to the last
            # sample whose unsmoothed rates are still at rest (the moment the hold ends).
            while j + 1 < n and raw[j + 1] < REST_RAD_S:
                j += 1
            ev = _classify(log, rates, j, end)
            if ev is not None:
                events.append(ev)
        i = max(e, i + 1)
    return events


def _classify(log: RobotLog, rates: dict[str, np.ndarray], s: int, e: int) -> Event | None:
    """An :class:`Event` for samples s..e if they are a free decay, else None."""
    if e - s < 5:
        return None
    sl = slice(s, e + 1)
    if log.has("drive_angle") and float(np.ptp(log["drive_angle"][sl])) > MAX_DRIVE_TURN_RAD:
        return None  # the drive turned: the motor was driving
    moved = {c: float(np.ptp(log[c][sl])) for c in REPORT_CHANNELS if log.has(c)}
    moved = {c: v for c, v in moved.items() if v > MIN_MOTION_RAD}
    steer = [c for c in rates if c in moved]
    if not steer:
        return None
    main = max(steer, key=lambda c: moved[c])
    r = rates[main][sl]
    big = np.abs(r) > ACTIVE_RAD_S
    signs = np.sign(r[big])
    swings = int(np.count_nonzero(np.diff(signs) != 0))
    x = log[main][sl] - log[main][e]
    third = max((e - s) // 3, 1)
    decays = float(np.ptp(x[-third:])) < float(np.ptp(x[:third]))
    if swings < MIN_SWINGS or not decays:
        return None
    start_t = float(log.t_s[s]) + log.t0_s
    end_t = float(log.t_s[e]) + log.t0_s
    held = abs(float(log[main][s] - log[main][e])) > 0.5 * moved[main]
    idx = np.flatnonzero(big)
    turn = idx[np.flatnonzero(np.diff(signs) != 0)[0] + 1]  # first fast sample after the first sign change
    # step back to the turning point itself: the last sample before it with the old sign
    k = int(turn)
    while k > 0 and np.sign(r[k - 1]) == np.sign(r[turn]):
        k -= 1
    free_t = float(log.t_s[s + k]) + log.t0_s
    return Event(start_t, end_t, moved, "release" if held else "push", free_t)


def manifest_entries(
    log: RobotLog, events: Sequence[Event], file: str, group: str, duration_s: float | None = None
) -> list[dict[str, Any]]:
    """Manifest entries (``fixture: free``) for ``events``, each window from the event's
    ``free_start_s``; ``duration_s`` caps each window's length."""
    out = []
    stem = Path(file).stem.replace("-", "_")
    for ev in events:
        end = ev.end_s if duration_s is None else min(ev.end_s, ev.free_start_s + duration_s)
        out.append(
            {
                "name": f"{stem}_{ev.kind}_{ev.start_s:.2f}s".replace(".", "_"),
                "group": group,
                "fixture": "free",
                "file": file,
                "pressure_kpa": None,
                "window_s": [round(ev.free_start_s, 2), round(end, 2)],
                "notes": f"{ev.kind} found by `events`: moved "
                + ", ".join(f"{c} {v:.3f} rad" for c, v in ev.moved.items()),
            }
        )
    return out


def write_manifest_entries(path: str | Path, entries: Sequence[dict[str, Any]], data_root: str | Path) -> Path:
    """Add ``entries`` to the manifest at ``path`` (created with ``data_root`` if missing).

    Refuses, writing nothing, a name that is already in the manifest, and a manifest that holds
    comments (a hand-written one: rewriting it would drop them). Written atomically: a temp file in
    the same folder, then renamed over ``path``.
    """
    path = Path(path)
    if path.exists():
        try:
            data = safe_yaml.load_file(path) or {}
            line = _comment_line(path.read_text())
        except yaml.YAMLError as err:
            raise LogError(f"manifest {str(path)!r}: cannot read: {err}") from err
        if not isinstance(data, dict) or not isinstance(data.get("trials", []), list):
            raise LogError(f"manifest {str(path)!r}: field 'trials' must be a list")
        if line is not None:
            raise LogError(
                f"manifest {str(path)!r}: holds comments (line {line}), which rewriting it would drop; nothing "
                "written: give --write-manifest a new file and copy its trials over"
            )
    else:
        data = {"data_root": str(data_root), "trials": []}
    trials = list(data.get("trials") or [])
    names = {str(t.get("name")) for t in trials if isinstance(t, dict)}
    for e in entries:
        if e["name"] in names:
            raise LogError(f"manifest {str(path)!r}: field 'name' = {e['name']!r} is already a trial; nothing written")
    data["trials"] = trials + list(entries)
    return write_text_atomic(path, yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=110))


def _comment_line(text: str) -> int | None:
    """The first line of a YAML text that holds a comment (a ``#`` outside every scalar), or None."""
    import bisect

    spans = [(t.start_mark.index, t.end_mark.index) for t in yaml.scan(text) if isinstance(t, yaml.ScalarToken)]
    starts = [lo for lo, _ in spans]  # in text order
    for pos in (i for i, ch in enumerate(text) if ch == "#"):
        k = bisect.bisect_right(starts, pos) - 1
        if k < 0 or pos >= spans[k][1]:
            return text.count("\n", 0, pos) + 1
    return None


def events_table(events: Sequence[Event]) -> str:
    """A Markdown table of events (times in s from the log's first sample)."""
    rows = [
        {
            "i": i,
            "kind": ev.kind,
            "start": ev.start_s,
            "free": ev.free_start_s,
            "end": ev.end_s,
            "duration": ev.duration_s,
            "moved": ", ".join(f"{c} {v:.3f}" for c, v in ev.moved.items()),
        }
        for i, ev in enumerate(events)
    ]
    return markdown_table(
        rows,
        [
            ("i", "#", "{}"),
            ("kind", "kind", ""),
            ("start", "start [s]", "{:.2f}"),
            ("free", "free from [s]", "{:.2f}"),
            ("end", "end [s]", "{:.2f}"),
            ("duration", "duration [s]", "{:.2f}"),
            ("moved", "moved (peak to peak, rad)", ""),
        ],
        align="rlrrrrl",
    )


__all__ = [
    "Event",
    "events_table",
    "find_events",
    "manifest_entries",
    "write_manifest_entries",
    "MAX_DRIVE_TURN_RAD",
    "MIN_SWINGS",
    "REST_RAD_S",
    "ACTIVE_RAD_S",
]
