"""The fault grids: the ramp task under the faults a real robot meets, one fault at a time.

Each fault is a set of events (:mod:`sphere_env.tasks.events`, the env's ``randomization``) and,
where it needs one, an env kwarg, applied on top of the nominal evaluation grid (every shell model
× 3, 8.5 and 14 kPa × evaluation seeds 0, 1, 2, deterministic controllers, nothing else
randomized). Each fault states its range and where the range comes from (``why``), and the family
and level it sits at on a graded curve (``family``, ``level``: the x axis of :data:`FAMILIES`).

Two collections, each fault defined once:

* :data:`FAULTS`, the learning study's grid (9 faults): what the committed study results
  (``evaluation/results/learning``) were measured on, printed beside every controller's success
  in the study's README;
* :data:`GRADED_FAULTS`, the graded grid (23 faults, a superset of :data:`FAULTS`): each family
  in steps, so that a curve of success against the level shows where a controller breaks
  (``sphere-env evaluate --faults all``, ``make demo``).

:func:`grid_jobs` and :func:`fault_jobs` make evaluation jobs of a shell × pressure × seed grid,
:func:`episode_jobs` and :func:`fault_episode_jobs` of an explicit list of episodes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

SHELLS = ("point", "injected", "hydroelastic")
PRESSURES_KPA = (3.0, 8.5, 14.0)
SEEDS = (0, 1, 2)
#: An episode of an explicit list: (shell model, pressure [kPa], seed).
Episode = tuple[str, float, int]


@dataclass(frozen=True)
class Family:
    """A fault family: the quantity its faults set, in what unit (``axis``, the x axis of its
    graded curve) and its value when nothing is faulted (``nominal``; ``None``: the family's level
    is the pressure, whose nominal values are the grid's)."""

    axis: str
    nominal: float | None


#: The graded grid's families, in the order curves show them.
FAMILIES: dict[str, Family] = {
    "friction_steer": Family("steer joint friction [× nominal]", 1.0),
    "friction_drive": Family("drive joint friction [× nominal]", 1.0),
    "friction_both": Family("both joints' friction [× nominal]", 1.0),
    "latency": Family("action latency [control steps of 20 ms]", 0.0),
    "payload": Family("payload on the pendulum [kg]", 0.0),
    "pressure": Family("pressure [kPa] (calibrated: 3-14)", None),
    "leak": Family("pressure leak [kPa/s]", 0.0),
    "sensor_noise": Family("observation noise [× default σ]", 0.0),
    "torque_saturation": Family("motor torque limit [× nominal]", 1.0),
}


@dataclass(frozen=True)
class Fault:
    """One fault: the events it adds (an env ``randomization`` mapping), env kwargs it needs, the
    pressures it runs at instead of the grid's (``None``: the grid's), and where it sits on its
    family's graded curve (``family`` of :data:`FAMILIES`, ``level`` in that family's unit;
    ``None`` for the pressure family, whose levels are the pressures)."""

    name: str
    title: str
    why: str
    randomization: Mapping[str, Any]
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    pressures_kpa: tuple[float, ...] | None = None
    family: str = ""
    level: float | None = None


#: The learning study's fault grid: what its committed results were measured on (keep as is).
FAULTS: dict[str, Fault] = {
    f.name: f
    for f in (
        Fault(
            "leak",
            "pressure leak, -0.5 kPa/s",
            "a leaking valve or a puncture; clipped at the calibrated floor of 3 kPa, so a 14 kPa shell is at 3 kPa "
            "after 22 s, about two descents (the training preset full draws leaks up to 0.2 kPa/s); nothing on the "
            "robot measures it, so a policy that observes the pressure reads the value from before the run",
            {"pressure_schedule": {"rate_kpa_per_s": -0.5}},
            {"pressure_reading": "at_reset"},
            family="leak",
            level=0.5,
        ),
        Fault(
            "pressure_beyond_range",
            "1.5, 16 and 17.5 kPa (calibrated: 3-14)",
            "a shell pumped by hand without a gauge, up to 3.5 kPa (a third of the calibrated span) outside the range "
            "the shell laws were fitted on; the laws are extrapolated (pressure_extrapolation_kpa)",
            {},
            {"pressure_extrapolation_kpa": 3.5},
            (1.5, 16.0, 17.5),
            family="pressure",
            level=None,
        ),
        Fault(
            "sensor_noise",
            "observation noise at the default sigma",
            "0.005 rad on angles, 0.05 rad/s on rates: at least 4x the largest high-frequency residual of the shared "
            "logs' encoder and IMU channels and 20-40x their median (evaluation/results/log_noise.json), a vibrating "
            "mount or a cheaper IMU than the logged robot's",
            {"observation_noise_scale": 1.0},
            family="sensor_noise",
            level=1.0,
        ),
        Fault(
            "latency_1",
            "actions one control step late (20 ms)",
            "a slow bus or a busy onboard computer; the logs are sampled every 10 ms",
            {"action_latency_steps": 1},
            family="latency",
            level=1,
        ),
        Fault(
            "latency_2",
            "actions two control steps late (40 ms)",
            "as latency_1, twice as late",
            {"action_latency_steps": 2},
            family="latency",
            level=2,
        ),
        Fault(
            "torque_saturation",
            "motors saturate at 60 % of the limit",
            "12 N m steer, 13.2 N m drive: a sagging battery or thermal derating",
            {"motor_torque_scale": 0.6},
            family="torque_saturation",
            level=0.6,
        ),
        Fault(
            "friction_high",
            "joint friction x 1.5",
            "gearhead friction moves by tens of percent with temperature and wear, and Table I's own fits of one joint "
            "differ by more (steer: viscous c = 0.104 against Majd-Simaan f_w = 0.20 N m s/rad)",
            {"steer_friction_scale": 1.5, "drive_friction_scale": 1.5},
            family="friction_both",
            level=1.5,
        ),
        Fault(
            "friction_low",
            "joint friction x 0.5",
            "as friction_high, the other way",
            {"steer_friction_scale": 0.5, "drive_friction_scale": 0.5},
            family="friction_both",
            level=0.5,
        ),
        Fault(
            "payload",
            "4 kg payload on the pendulum",
            "10 % of the robot's 41.35 kg: a battery or sensor pack the calibration never saw",
            {"payload_mass_kg": 4.0},
            family="payload",
            level=4.0,
        ),
    )
}


#: Joint friction steps of the graded grid (×1 is the nominal grid).
FRICTION_SCALES = (0.5, 0.75, 1.25, 1.5)
_FRICTION_WHY = (
    "gearhead friction moves by tens of percent with temperature and wear, and Table I's own fits of one joint "
    "differ by more (steer: viscous c = 0.104 against Majd-Simaan f_w = 0.20 N m s/rad); ×0.5 to ×1.5 in steps "
    "spans both fits of the steer joint"
)
_JOINTS = {
    "steer": ("steer_friction_scale", "steer joint only: a cold or worn pendulum gearhead while the drive's is not; "),
    "drive": ("drive_friction_scale", "drive joint only: a cold or worn drive gearhead while the steer's is not; "),
    "both": (None, "both joints, as friction_high and friction_low; "),
}


def _friction(joint: str, scale: float) -> Fault:
    """Joint friction × ``scale`` on one joint (``steer``, ``drive``) or both; both at ×0.5 and
    ×1.5 are the study grid's friction_low and friction_high."""
    if joint == "both" and scale in (0.5, 1.5):
        return FAULTS["friction_low" if scale < 1 else "friction_high"]
    param, why = _JOINTS[joint]
    events = {param: scale} if param else {"steer_friction_scale": scale, "drive_friction_scale": scale}
    return Fault(
        f"friction_{joint}_{round(scale * 100)}pct",
        f"{joint} joint friction x {scale:g}" if param else f"joint friction x {scale:g}",
        why + _FRICTION_WHY,
        events,
        family=f"friction_{joint}",
        level=scale,
    )


def _payload(kg: float) -> Fault:
    """A ``kg`` point mass on the pendulum; 4 kg is the study grid's payload."""
    if kg == 4.0:
        return FAULTS["payload"]
    return Fault(
        f"payload_{kg:g}kg",
        f"{kg:g} kg payload on the pendulum",
        f"a sensor or battery pack the calibration never saw, {kg / 41.35:.0%} of the robot's 41.35 kg; "
        "as payload (4 kg), lighter: the steps from 1 to 4 kg",
        {"payload_mass_kg": kg},
        family="payload",
        level=kg,
    )


#: The graded fault grid: joint friction of each joint and of both at ×0.5, ×0.75, ×1.25 and ×1.5,
#: latency 1-3 control steps, payload 1-4 kg, pressures beyond the calibrated range, and the leak,
#: sensor noise and torque saturation of :data:`FAULTS` (every fault of :data:`FAULTS` is one of it,
#: the same record).
GRADED_FAULTS: dict[str, Fault] = {
    f.name: f
    for f in (
        *(_friction(joint, s) for joint in ("steer", "drive", "both") for s in FRICTION_SCALES),
        FAULTS["latency_1"],
        FAULTS["latency_2"],
        Fault(
            "latency_3",
            "actions three control steps late (60 ms)",
            "as latency_1, three times as late: a bus shared with a logging or camera stream",
            {"action_latency_steps": 3},
            family="latency",
            level=3,
        ),
        *(_payload(kg) for kg in (1.0, 2.0, 3.0, 4.0)),
        FAULTS["pressure_beyond_range"],
        FAULTS["leak"],
        FAULTS["sensor_noise"],
        FAULTS["torque_saturation"],
    )
}


def fault_named(name: str) -> Fault:
    """The fault of this name (of :data:`GRADED_FAULTS`, which holds every fault); ValueError
    naming the allowed names otherwise."""
    try:
        return GRADED_FAULTS[name]
    except KeyError:
        raise ValueError(f"unknown fault {name!r}; allowed: {list(GRADED_FAULTS)}") from None


def episode_jobs(
    controller: str,
    spec: str,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    episodes: Sequence[Episode],
    randomization: Mapping[str, Any] | None = None,
    friction: str = "majd",
) -> list[dict[str, Any]]:
    """Explicit episodes ``(shell model, pressure [kPa], seed)`` as
    :func:`sphere_env.evaluation.cells.rollout` jobs, in the given order (a test set with its own
    seed per episode; the grids of :func:`grid_jobs` are one such list)."""
    extra = {} if randomization is None else {"randomization": dict(randomization)}
    return [
        dict(
            controller=controller,
            spec=spec,
            env_id=env_id,
            shell_model=m,
            friction=friction,
            pressure_kpa=float(p),
            seed=int(s),
            env_kwargs=dict(env_kwargs),
            **extra,
        )
        for m, p, s in episodes
    ]


def grid_jobs(
    controller: str,
    spec: str,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    shells: Sequence[str] = SHELLS,
    pressures_kpa: Sequence[float] = PRESSURES_KPA,
    seeds: Sequence[int] = SEEDS,
    randomization: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """The episodes of a shell × pressure × seed grid as :func:`sphere_env.evaluation.cells.rollout`
    jobs: the nominal grid by default, the validation grid with other ``seeds``, a fault's grid with
    its ``randomization`` (events the env applies)."""
    episodes = [(m, p, s) for m in shells for p in pressures_kpa for s in seeds]
    return episode_jobs(controller, spec, env_id, env_kwargs, episodes, randomization)


def fault_episodes(fault: str | Fault, episodes: Sequence[Episode]) -> list[Episode]:
    """``episodes`` as ``fault`` runs them: unchanged, or, for a fault with its own pressures
    (``pressure_beyond_range``), episode k at the fault's pressure k mod n, its shell and seed
    kept."""
    f = fault_named(fault) if isinstance(fault, str) else fault
    if f.pressures_kpa is None:
        return [(m, float(p), int(s)) for m, p, s in episodes]
    ps = f.pressures_kpa
    return [(m, float(ps[k % len(ps)]), int(s)) for k, (m, _, s) in enumerate(episodes)]


def fault_episode_jobs(
    fault: str | Fault,
    controller: str,
    spec: str,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    episodes: Sequence[Episode],
    friction: str = "majd",
) -> list[dict[str, Any]]:
    """Explicit episodes under one fault (:func:`fault_episodes`): its events as the env's
    randomization, its kwargs over ``env_kwargs``."""
    f = fault_named(fault) if isinstance(fault, str) else fault
    return episode_jobs(
        controller,
        spec,
        env_id,
        {**dict(env_kwargs), **dict(f.env_kwargs)},
        fault_episodes(f, episodes),
        f.randomization,
        friction,
    )


def fault_jobs(
    fault: str | Fault,
    controller: str,
    spec: str,
    env_id: str,
    env_kwargs: Mapping[str, Any],
    shells: Sequence[str] = SHELLS,
    seeds: Sequence[int] = SEEDS,
) -> list[dict[str, Any]]:
    """The fault grid's episodes of one fault (its events as the env's randomization, its kwargs over
    ``env_kwargs``, its pressures where it sets its own)."""
    f = fault_named(fault) if isinstance(fault, str) else fault
    return grid_jobs(
        controller,
        spec,
        env_id,
        {**dict(env_kwargs), **dict(f.env_kwargs)},
        shells,
        f.pressures_kpa or PRESSURES_KPA,
        seeds,
        randomization=f.randomization,
    )
