"""The fault grid: the ramp task under the faults a real robot meets, one fault at a time.

Each fault is a set of events (:mod:`sphere_env.tasks.events`, the env's ``randomization``) and,
where it needs one, an env kwarg, applied on top of the nominal evaluation grid (every shell model
× 3, 8.5 and 14 kPa × evaluation seeds 0, 1, 2, deterministic controllers, nothing else
randomized). Each fault states its range and where the range comes from (``why``); the learning
study's README (``evaluation/results/learning/README.md``) prints them beside every controller's
success under each fault.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

SHELLS = ("point", "injected", "hydroelastic")
PRESSURES_KPA = (3.0, 8.5, 14.0)
SEEDS = (0, 1, 2)


@dataclass(frozen=True)
class Fault:
    """One fault: the events it adds (an env ``randomization`` mapping), env kwargs it needs, and
    the pressures it runs at instead of the grid's (``None``: the grid's)."""

    name: str
    title: str
    why: str
    randomization: Mapping[str, Any]
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    pressures_kpa: tuple[float, ...] | None = None


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
        ),
        Fault(
            "pressure_beyond_range",
            "1.5, 16 and 17.5 kPa (calibrated: 3-14)",
            "a shell pumped by hand without a gauge, up to 3.5 kPa (a third of the calibrated span) outside the range "
            "the shell laws were fitted on; the laws are extrapolated (pressure_extrapolation_kpa)",
            {},
            {"pressure_extrapolation_kpa": 3.5},
            (1.5, 16.0, 17.5),
        ),
        Fault(
            "sensor_noise",
            "observation noise at the default sigma",
            "0.005 rad on angles, 0.05 rad/s on rates: at least 4x the largest high-frequency residual of the shared "
            "logs' encoder and IMU channels and 20-40x their median (evaluation/results/log_noise.json), a vibrating "
            "mount or a cheaper IMU than the logged robot's",
            {"observation_noise_scale": 1.0},
        ),
        Fault(
            "latency_1",
            "actions one control step late (20 ms)",
            "a slow bus or a busy onboard computer; the logs are sampled every 10 ms",
            {"action_latency_steps": 1},
        ),
        Fault(
            "latency_2",
            "actions two control steps late (40 ms)",
            "as latency_1, twice as late",
            {"action_latency_steps": 2},
        ),
        Fault(
            "torque_saturation",
            "motors saturate at 60 % of the limit",
            "12 N m steer, 13.2 N m drive: a sagging battery or thermal derating",
            {"motor_torque_scale": 0.6},
        ),
        Fault(
            "friction_high",
            "joint friction x 1.5",
            "gearhead friction moves by tens of percent with temperature and wear, and Table I's own fits of one joint "
            "differ by more (steer: viscous c = 0.104 against Majd-Simaan f_w = 0.20 N m s/rad)",
            {"steer_friction_scale": 1.5, "drive_friction_scale": 1.5},
        ),
        Fault(
            "friction_low",
            "joint friction x 0.5",
            "as friction_high, the other way",
            {"steer_friction_scale": 0.5, "drive_friction_scale": 0.5},
        ),
        Fault(
            "payload",
            "4 kg payload on the pendulum",
            "10 % of the robot's 41.35 kg: a battery or sensor pack the calibration never saw",
            {"payload_mass_kg": 4.0},
        ),
    )
}


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
    extra = {} if randomization is None else {"randomization": dict(randomization)}
    return [
        dict(
            controller=controller,
            spec=spec,
            env_id=env_id,
            shell_model=m,
            friction="majd",
            pressure_kpa=p,
            seed=s,
            env_kwargs=dict(env_kwargs),
            **extra,
        )
        for m in shells
        for p in pressures_kpa
        for s in seeds
    ]


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
    f = FAULTS[fault] if isinstance(fault, str) else fault
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
