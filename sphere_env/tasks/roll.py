"""``Roll``: rolling control on flat ground (speed and heading tracking)."""

from __future__ import annotations

import math
from typing import Any, Literal, Mapping

import numpy as np
from pydantic import Field, field_validator

from sphere_env.schemas import Schema, allowed, number, ordered_pair, validate
from sphere_env.tasks.observation import wrap_angle
from sphere_env.tasks.rewards import RollRewardWeights, load_weights, roll_terms
from sphere_env.tasks.task import Scene, Task

COMMAND_MODES = ("heading", "yaw_rate")


class RollKwargs(Schema):
    """The keyword arguments of :class:`RollTask` (documented there), loaded before the task is
    built; ``reward_weights`` is read as :class:`RollRewardWeights` with the overrides applied."""

    omega_ref_range_rad_s: ordered_pair(-30.0, 30.0, "rad/s") = (0.5, 2.5)
    heading_range_rad: number(ge=0.0, le=math.pi, words="[0, π] rad") = math.pi / 2
    yaw_rate_range_rad_s: ordered_pair(-5.0, 5.0, "rad/s") = (-0.5, 0.5)
    command_mode: Literal[COMMAND_MODES] = "heading"  # type: ignore[valid-type]
    command_resample_s: number(gt=0.0) | None = None
    reward_weights: Any = Field(
        None, validate_default=True, json_schema_extra=allowed("a mapping term -> weight, or None")
    )

    @field_validator("reward_weights")
    @classmethod
    def _weights(cls, overrides: Any) -> RollRewardWeights:
        return load_weights(RollRewardWeights, overrides)


class RollTask(Task):
    """Roll on flat ground at a commanded forward drive speed and heading (or yaw rate).

    Steering comes from leaning the pendulum on the steer joint, as on the real robot: the lean
    tilts the pipe (φ) and the rolling shell turns. Commands are drawn per episode and, with
    ``command_resample_s``, again every that many seconds.

    **Action space** ``Box(-1, 1, (2,), float32)``, clipped; NaN/inf raise ``ValueError``:
    0 = steer torque / ``steer_torque_limit_nm`` (20 N m; +1 turns left, ψ increasing),
    1 = drive torque / ``drive_torque_limit_nm`` (22 N m; **+1 drives forward**).

    **Observation space** ``Box(-inf, inf, (13,), float32)`` (14 with ``observe_pressure``):
    indices 0–10 as in :class:`~sphere_env.tasks.RampDescentTask` (θ [rad], θ̇ [rad/s], drive
    angle [rad, wrapped], drive rate [rad/s], φ [rad], φ̇ [rad/s], ω_d [rad/s], ψ̇ [rad/s],
    gravity direction in the pipe frame [-] ×3), then

    ===  ==================  ======  =====================================================
    11   omega_ref           rad/s   command: target drive velocity
    12   heading_error       rad     ``command_mode="heading"``: wrap(ψ_ref − ψ)
         (yaw_rate_ref)      rad/s   ``command_mode="yaw_rate"``: commanded ψ̇_ref
    13   pressure_kpa        kPa     privileged, only with ``observe_pressure=True``
    ===  ==================  ======  =====================================================

    The default ω_ref range (0.5, 2.5) rad/s (0.15–0.76 m/s) is everyday speed, below the speeds
    at which the soft shells settle at full drive torque (``docs/envs.md``).

    **Reward** = Σ terms (``info["reward_<term>"]``, :class:`RollRewardWeights`): ``speed``
    (+ tolerance of ω_d − ω_ref), ``heading`` (+ tolerance of the heading or yaw-rate error),
    ``ctrl`` (− Σa²). Per-step terms scale with the control period.

    ``info["is_success"]`` is True while both errors are within one tolerance width
    (|ω_d − ω_ref| ≤ 0.5 rad/s, heading error ≤ 0.3 rad or yaw-rate error ≤ 0.3 rad/s), so SB3's
    ``EvalCallback`` reports the fraction of episodes that end tracking the command.

    **Episode end.** Never terminates on its own; ``truncated`` by the registration's time limit
    (500 steps = 10 s at 50 Hz) or a physics failure (``info["truncation_reason"]``).

    :param omega_ref_range_rad_s: (low, high) of ω_ref [rad/s], default (0.5, 2.5).
    :param heading_range_rad: ψ_ref ~ U[−r, r] relative to the start heading [rad], default π/2.
    :param yaw_rate_range_rad_s: (low, high) of ψ̇_ref [rad/s] in yaw-rate mode, default (−0.5, 0.5).
    :param command_mode: ``"heading"`` (default) or ``"yaw_rate"``.
    :param command_resample_s: resample the command every this many seconds [s]; None = never.
    :param reward_weights: mapping overriding :class:`RollRewardWeights` fields.

    ``reset(options=...)`` also accepts ``omega_ref`` [rad/s] within [−30, 30] and ``heading_ref``
    [rad] within [−2π, 2π] or ``yaw_rate_ref`` [rad/s] within [−5, 5]. ``gym.make("sphere_env/Roll-v1", ...)`` takes these kwargs and those
    of :class:`~sphere_env.envs.SphereEnv` (flat ground: ``ramp_length_m`` must stay None).

    The versions (v0, v1) and what changed between them: ``docs/envs.md``.
    """

    name = "Roll"
    ramp = False
    reward_terms = ("speed", "heading", "ctrl")
    #: ω_ref and ψ̇_ref within the bounds of their ranges; ψ_ref within ±2π (a sampled ψ_ref is
    #: the start heading in (−π, π] plus at most ±π).
    command_option_bounds = {
        "omega_ref": (-30.0, 30.0),
        "heading_ref": (-2 * math.pi, 2 * math.pi),
        "yaw_rate_ref": (-5.0, 5.0),
    }

    def __init__(self, **kwargs: Any):
        kw = validate(RollKwargs, kwargs, "Roll kwargs")
        command_mode = self.command_mode = kw.command_mode
        self.command_names = ("omega_ref", "heading_error" if command_mode == "heading" else "yaw_rate_ref")
        self.command_options = ("omega_ref", "heading_ref" if command_mode == "heading" else "yaw_rate_ref")
        self.omega_ref_range_rad_s = kw.omega_ref_range_rad_s
        self.heading_range_rad = kw.heading_range_rad
        self.yaw_rate_range_rad_s = kw.yaw_rate_range_rad_s
        self.command_resample_s = kw.command_resample_s
        self.reward_weights = kw.reward_weights
        self.omega_ref = self.heading_ref = self.yaw_rate_ref = 0.0
        self.control_period_s = 0.0
        self._heading0 = 0.0
        self._next_resample: float | None = None

    def _sample_command(self, rng: np.random.Generator) -> None:
        self.omega_ref = float(rng.uniform(*self.omega_ref_range_rad_s))
        if self.command_mode == "heading":
            self.heading_ref = float(rng.uniform(-self.heading_range_rad, self.heading_range_rad)) + self._heading0
        else:
            self.yaw_rate_ref = float(rng.uniform(*self.yaw_rate_range_rad_s))

    def reset(self, state: Any, rng: np.random.Generator, options: Mapping[str, Any], scene: Scene) -> None:
        self.control_period_s = scene.control_period_s
        self._heading0 = state.heading
        self.heading_ref = self.yaw_rate_ref = 0.0
        self._sample_command(rng)
        for key in ("omega_ref", "heading_ref", "yaw_rate_ref"):
            if key in options:
                setattr(self, key, options[key])
        self._next_resample = self.command_resample_s

    def command(self, state: Any) -> list[float]:
        if self.command_mode == "heading":
            return [self.omega_ref, wrap_angle(self.heading_ref - state.heading)]
        return [self.omega_ref, self.yaw_rate_ref]

    def step(self, state: Any, action: tuple[float, float], rng: np.random.Generator):
        if self._next_resample is not None and state.time_s >= self._next_resample - 1e-9:
            self._sample_command(rng)
            self._next_resample += self.command_resample_s
        if self.command_mode == "heading":
            err, yaw_mode = wrap_angle(self.heading_ref - state.heading), False
        else:
            err, yaw_mode = state.heading_rate - self.yaw_rate_ref, True
        terms = roll_terms(
            self.reward_weights, self.control_period_s, state.omega_d, self.omega_ref, err, action, yaw_mode
        )
        w = self.reward_weights
        tracking = abs(state.omega_d - self.omega_ref) <= w.speed_width and abs(err) <= (
            w.yaw_rate_width if yaw_mode else w.heading_width
        )
        return terms, False, tracking

    def info(self) -> dict[str, Any]:
        if self.command_mode == "heading":
            return {"omega_ref": self.omega_ref, "heading_ref": self.heading_ref}
        return {"omega_ref": self.omega_ref, "yaw_rate_ref": self.yaw_rate_ref}
