"""The RoboBall log channels: project state names, the RoboBall CSV columns each is read from (with
their aliases from the one alias table), the columns' signs against the twin and the time unit
(:mod:`sphere_env.calibration.logs` reads logs with them; ``docs/design.md`` §3 gives frames and signs)."""

from __future__ import annotations

from sphere_env.tasks.sensors import CHANNEL_ALIASES

STATE_CHANNELS = (
    "theta",
    "theta_dot",
    "phi",
    "phi_dot",
    "omega_d",
    "drive_angle",
    "drive_rate",
    "pendulum_pitch",
    "pendulum_pitch_rate",
    "heading",
    "heading_rate",
)
ANGLE_CHANNELS = ("theta", "phi", "drive_angle", "pendulum_pitch", "heading")


def _with_aliases(*columns: str) -> tuple[str, ...]:
    """The RoboBall columns of a channel followed by their aliases (:data:`CHANNEL_ALIASES`)."""
    out = list(columns)
    for col in columns:
        base, dot, field = col.partition(".")
        for name, alias in CHANNEL_ALIASES.items():
            for a, b in ((name, alias), (alias, name)):
                if base == a and f"{b}{dot}{field}" not in out:
                    out.append(f"{b}{dot}{field}")
    return tuple(out)


# RoboBall log names -> project names, first match wins (module docstring); each column's alias
# comes from the one alias table, CHANNEL_ALIASES (pipe_roll/ball_roll, shell_yaw/ball_yaw).
ROBOBALL_CHANNELS: dict[str, tuple[str, ...]] = {
    "theta": ("roll_joint.position",),
    "theta_dot": ("roll_joint.velocity",),
    "phi": _with_aliases("ball_roll.position") + _with_aliases("pipe_roll"),
    "phi_dot": _with_aliases("ball_roll.velocity"),
    "drive_angle": ("drive_shaft.position",),
    "drive_rate": ("drive_shaft.velocity",),
    "pendulum_pitch": ("pitch_joint.position",),
    "pendulum_pitch_rate": ("pitch_joint.velocity",),
    "heading": _with_aliases("shell_yaw.position") + _with_aliases("shell_yaw"),
    "heading_rate": _with_aliases("shell_yaw.velocity"),
    "omega_d": ("omega_d",),
}
#: RoboBall timestamps are integer nanoseconds from an arbitrary origin: the free_robot log spans
#: 4.66e10 units over 4665 rows (46.6 s at a median 9.97 ms, i.e. 100 Hz), the steer_free and
#: stand_swing logs 2e7 units per row (50 Hz). Any other unit is refused by the sample-period check.
ROBOBALL_TIME = ("timestamp", "ns")
#: Sign of each project channel against its RoboBall column (module docstring): the drive encoder
#: counts opposite to the twin's drive joint.
ROBOBALL_SIGNS = {"drive_angle": -1.0, "drive_rate": -1.0}
#: Project names -> RoboBall CSV columns (for writing synthetic logs).
ROBOBALL_COLUMNS = {name: cols[0] for name, cols in ROBOBALL_CHANNELS.items()}
