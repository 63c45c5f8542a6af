"""``RampDescent``: the paper's ramp experiment (§IV) as a control task."""

from __future__ import annotations

import math
from typing import Any, Literal, Mapping

import numpy as np
from pydantic import Field, field_validator, model_validator

from sphere_env.schemas import Schema, allowed, number, ordered_pair, validate
from sphere_env.tasks.observation import wrap_angle
from sphere_env.tasks.rewards import RampRewardWeights, RampRewardWeightsPerRamp, load_weights, ramp_descent_terms
from sphere_env.tasks.task import Scene, Task
from sphere_env.tasks.termination import ramp_status

#: Bound of the observed speed-error integral ∫(ω_ref − ω_d) dt [rad] (anti-windup). It lies above the
#: tuned PD's own integral bound (about 1.7 rad, where its lift reference saturates), so the policy sees
#: every value the PD's integral term can act on.
SPEED_ERROR_INTEGRAL_LIMIT_RAD = 3.0


class RampDescentKwargs(Schema):
    """The keyword arguments of :class:`RampDescentTask` (documented there), loaded before the task
    is built. ``reward_weights`` is read as the weights of ``step_reward_per``
    (:class:`RampRewardWeights` or :class:`RampRewardWeightsPerRamp`) with the overrides applied."""

    lane_half_width_m: number(gt=0.0, le=9.0) = 1.0
    omega_ref_range_rad_s: ordered_pair(0.0, 30.0, "rad/s") = (2.0, 4.5)
    omega_ref_change_min_rad_s: number(gt=0.0, le=30.0) | None = 1.0
    settle_time_s: number(ge=0.0, le=60.0) = 1.5
    tracking_tolerance_rad_s: number(gt=0.0, le=30.0) | None = 0.5
    extended_observation: bool = True
    observe_tracking_state: bool = False
    step_reward_per: Literal["time", "distance"] = "time"
    # after step_reward_per, whose weights it overrides
    reward_weights: Any = Field(
        None, validate_default=True, json_schema_extra=allowed("a mapping term -> weight, or None")
    )

    @field_validator("reward_weights")
    @classmethod
    def _weights(cls, overrides: Any, info) -> RampRewardWeights:
        per_ramp = info.data.get("step_reward_per") == "distance"
        return load_weights(RampRewardWeightsPerRamp if per_ramp else RampRewardWeights, overrides)

    @model_validator(mode="after")
    def _change_fits_the_range(self) -> "RampDescentKwargs":
        lo, hi = self.omega_ref_range_rad_s
        change = self.omega_ref_change_min_rad_s
        if change is not None and change > hi - lo:
            raise ValueError(
                f"field 'omega_ref_change_min_rad_s' = {change!r} exceeds the width {hi - lo:g} rad/s of "
                f"omega_ref_range_rad_s {self.omega_ref_range_rad_s}; allowed: (0, {hi - lo:g}]"
            )
        return self


class RampDescentTask(Task):
    """Descend a ramp along the fall line at a commanded drive speed ω_ref that changes midway.

    The robot starts at rest at the top of a ramp heading downhill (+x_W, ψ = 0); the ramp ends in
    a flat run-out. Both pendulum motors are driven. ω_ref holds over the upper half of the ramp and
    changes by at least ``omega_ref_change_min_rad_s`` for the lower half, so the controller must
    brake or push on command and keep the robot in its lane; an episode **succeeds** when the robot
    reaches the run-out inside the lane *and* its on-ramp speed-tracking RMS error, over the samples
    more than ``settle_time_s`` after the start and after the change, is at most
    ``tracking_tolerance_rad_s``.

    ω_ref is drawn from ``omega_ref_range_rad_s`` around the speeds at which the soft shells coast,
    so each episode asks for braking and pushing; what the twin allows on the ramp, and why v0/v1
    keep the paper's 16° ramp, is in ``docs/envs.md``.

    **Action space** ``Box(-1, 1, (2,), float32)``, clipped; NaN/inf raise ``ValueError``.

    ===  ======  =========================================================================
    idx  name    meaning
    ===  ======  =========================================================================
    0    steer   steer motor torque / ``steer_torque_limit_nm`` (default 20 N m); +1 leans the
                 pendulum toward +θ, which turns the robot left (ψ increases)
    1    drive   drive motor torque / ``drive_torque_limit_nm`` (default 22 N m); **+1 drives
                 forward** (the URDF drive axis is −y, so the joint torque is −a·limit)
    ===  ======  =========================================================================

    **Observation space** ``Box(-inf, inf, (16,), float32)`` (17 with ``observe_pressure``; v0/v1:
    13/14, without ``lateral_error`` and the pendulum pitch):

    ===  =============  ======  ================================================================
    idx  name           unit    meaning (real-robot channel)
    ===  =============  ======  ================================================================
    0    theta          rad     steer joint angle θ (roll_joint)
    1    theta_dot      rad/s   θ̇
    2    drive_angle    rad     drive joint angle q_d (−drive_shaft), wrapped to [-π, π)
    3    drive_rate     rad/s   drive joint rate
    4    phi            rad     pipe angle φ against the ground (pipe_roll)
    5    phi_dot        rad/s   φ̇
    6    omega_d        rad/s   drive velocity ω_d, + forward (≈ drive_shaft.velocity rolling)
    7    heading_rate   rad/s   ψ̇ (IMU gyro / shell_yaw rate)
    8-10 gravity_xyz    -       unit gravity direction in the pipe frame (IMU)
    11   omega_ref      rad/s   command: target drive velocity now (changes at mid-ramp)
    12   heading_error  rad     command: wrap(0 − ψ), heading error to the fall line (shell_yaw)
    13   lateral_error  m       command: −y, offset from the lane's centre line (the fall line
                                through the start) back to it; a path tracker's cross-track error
    14   pendulum_pitch rad     pendulum pitch α against the vertical, + lifted backward (IMU on
                                the pendulum, pitch_joint); a policy needs it to know where gravity
                                pulls the pendulum, which 2, 4 and 8-10 give only in combination
    15   ..._rate       rad/s   α̇ (pitch_joint.velocity)
    16   pressure_kpa   kPa     privileged, only with ``observe_pressure=True``
    ===  =============  ======  ================================================================

    With ``observe_tracking_state=True`` two components follow ``lateral_error`` (the pendulum pitch
    and pressure move up by two; 18 components, 19 with the pressure): ``speed_error_integral``
    [rad] = ∫(ω_ref − ω_d) dt since the episode start, clipped to ±3 rad, and ``omega_d_rate``
    [rad/s²] = (ω_d − ω_d of the previous step) / control period (0 after a reset), both from the
    twin's ω_d (no observation noise): the state a PI-D speed loop keeps (``docs/envs.md``).

    The measured components (0–10) and the pendulum pitch and its rate get Gaussian noise of
    ``observation_noise_scale`` × the defaults in
    :data:`sphere_env.tasks.observation.DEFAULT_NOISE_STD` (off by default).

    **Reward** = Σ terms, each reported as ``info["reward_<term>"]``
    (:class:`~sphere_env.tasks.rewards.RampRewardWeights`; per-step terms scale with the control
    period): ``speed`` (+ tolerance of ω_d − ω_ref), ``speed_linear`` (+ linear tolerance of ω_d − ω_ref, weight 0
    unless set), ``lateral`` (− |y| off the fall line),
    ``heading`` (− (1 − cos ψ)), ``ctrl`` (− Σa²), ``success`` (+ on success, paid at the run-out),
    ``off_ramp`` (− on leaving the lane).

    **Episode end.** ``terminated`` on reaching the run-out or leaving the lane
    |y| > ``lane_half_width_m``. ``truncated`` by the registration's time limit (600 steps = 12 s at
    50 Hz) or a physics failure (``info["truncation_reason"]``). ``info`` carries ``omega_ref``
    (now), ``omega_ref_start``/``omega_ref_after`` (the two commands), ``reached_runout``,
    ``tracking_rmse_rad_s`` (over the ``tracking_samples`` judged samples so far; 0 before the
    first) and ``is_success``; ``info["motor_torque_nm"]`` holds the applied [τ_steer, τ_drive] [N m].

    **kwargs** of ``gym.make("sphere_env/RampDescent-v2", ...)``: those of
    :class:`~sphere_env.envs.SphereEnv` (``shell_model``, ``friction_model``, ``calibration``,
    ``control_frequency_hz`` [Hz], ``time_step_s`` [s], ``steer_torque_limit_nm``/
    ``drive_torque_limit_nm`` [N m], ``randomization``, ``observe_pressure``,
    ``observation_noise_scale``, ``render_mode``, ``meshcat``, ``record_replay``, ``render_size``
    [px]) with ``incline_deg`` [deg] default 8 and ``ramp_length_m`` [m] default 6, plus this task's:

    :param lane_half_width_m: lateral half-width of the ramp lane [m], default 1.
    :param omega_ref_range_rad_s: (low, high) of both commands [rad/s].
    :param omega_ref_change_min_rad_s: the lower-half command differs from the upper-half one by at
        least this [rad/s], drawn uniformly from the part of the range that allows it; ``None``
        keeps one command for the whole ramp.
    :param settle_time_s: samples this long after the start and after the change are not judged [s].
    :param tracking_tolerance_rad_s: largest tracking RMS error of a success [rad/s]; ``None``:
        success is reaching the run-out in the lane (v0/v1).
    :param extended_observation: observe the lane's cross-track error (index 13) and the pendulum
        pitch α and its rate (14, 15), as v2 does.
    :param observe_tracking_state: observe the speed-error integral and ω̇_d after the command (see
        above); default False. The shipped PPO configuration trains with it.
    :param reward_weights: mapping overriding :class:`RampRewardWeights` fields (per second), or
        :class:`~sphere_env.tasks.rewards.RampRewardWeightsPerRamp` fields with
        ``step_reward_per="distance"`` (per ramp length).
    :param step_reward_per: ``"time"`` (v2): the per-step terms are paid per second;
        ``"distance"`` (v3): paid per downhill progress on the ramp as a fraction of its length
        (Δx / ramp length), so that the speed term's return peaks at ω_d = ω_ref
        (``docs/envs.md``, version history).

    ``reset(options=...)`` also accepts ``omega_ref`` and ``omega_ref_after`` [rad/s] within
    [0, 30] (the latter only with a change).

    The versions (v0 to v3) and what changed between them: ``docs/envs.md``.
    """

    name = "RampDescent"
    ramp = True
    reward_terms = ("speed", "speed_linear", "lateral", "heading", "ctrl", "success", "off_ramp")
    command_names = ("omega_ref", "heading_error")  # v0/v1; v2 adds "lateral_error"
    # ω_ref bounds [rad/s]: those of omega_ref_range_rad_s
    command_option_bounds = {"omega_ref": (0.0, 30.0), "omega_ref_after": (0.0, 30.0)}

    def __init__(self, **kwargs: Any):
        kw = validate(RampDescentKwargs, kwargs, "RampDescent kwargs")
        self.lane_half_width_m = kw.lane_half_width_m
        self.omega_ref_range_rad_s = kw.omega_ref_range_rad_s
        self.omega_ref_change_min_rad_s = kw.omega_ref_change_min_rad_s
        self.settle_time_s = kw.settle_time_s
        self.tracking_tolerance_rad_s = kw.tracking_tolerance_rad_s
        self.reward_weights = kw.reward_weights
        self.step_reward_per = kw.step_reward_per
        extended_observation, observe_tracking_state = kw.extended_observation, kw.observe_tracking_state
        self._x_prev_m = 0.0
        self.command_options = (
            ("omega_ref",) if self.omega_ref_change_min_rad_s is None else ("omega_ref", "omega_ref_after")
        )
        self.extra_names = ("pendulum_pitch", "pendulum_pitch_rate") if extended_observation else ()
        self._observe_lateral = extended_observation
        self._observe_tracking = observe_tracking_state
        self.command_names = (
            ("omega_ref", "heading_error", "lateral_error") if extended_observation else ("omega_ref", "heading_error")
        ) + (("speed_error_integral", "omega_d_rate") if observe_tracking_state else ())
        self.omega_ref = self.omega_ref_start = self.omega_ref_after = 0.0
        self.ramp_end_x_m = float("inf")
        self.control_period_s = 0.0
        self._change_x_m = float("inf")
        self._changed = False
        self._since_change_s = 0.0
        self._sq_err_sum = 0.0
        self._n_judged = 0
        self._reached = False
        self._speed_error_integral_rad = 0.0  # ∫(ω_ref − ω_d) dt, clipped to ±SPEED_ERROR_INTEGRAL_LIMIT_RAD
        self._omega_d_prev = 0.0
        self._omega_d_rate = 0.0  # ω̇_d over the last control period [rad/s²]

    def _draw_after(self, start: float, rng: np.random.Generator) -> float:
        """The lower-half command: uniform over the range minus (start − d, start + d)."""
        lo, hi = self.omega_ref_range_rad_s
        d = self.omega_ref_change_min_rad_s
        below = max(0.0, start - d - lo)  # length of [lo, start − d]
        above = max(0.0, hi - (start + d))  # length of [start + d, hi]
        u = float(rng.uniform(0.0, below + above))
        if below + above == 0.0:  # start in the middle of a range exactly 2d wide
            return lo if start - lo >= hi - start else hi
        return lo + u if u < below else start + d + (u - below)

    def reset(self, state: Any, rng: np.random.Generator, options: Mapping[str, Any], scene: Scene) -> None:
        lo, hi = self.omega_ref_range_rad_s
        self.omega_ref_start = float(rng.uniform(lo, hi))
        if "omega_ref" in options:
            self.omega_ref_start = options["omega_ref"]
        if self.omega_ref_change_min_rad_s is None:
            self.omega_ref_after = self.omega_ref_start
            self._change_x_m = float("inf")
        else:
            self.omega_ref_after = self._draw_after(self.omega_ref_start, rng)
            if "omega_ref_after" in options:
                self.omega_ref_after = options["omega_ref_after"]
            # the change happens halfway down the ramp (x_W is horizontal; the ramp starts at x = 0)
            self._change_x_m = 0.5 * scene.ramp_end_x_m
        self.omega_ref = self.omega_ref_start
        self.ramp_end_x_m = scene.ramp_end_x_m
        self.control_period_s = scene.control_period_s
        self._changed = False
        self._since_change_s = 0.0
        self._sq_err_sum = 0.0
        self._n_judged = 0
        self._reached = False
        self._speed_error_integral_rad = 0.0
        self._omega_d_prev = float(state.omega_d)
        self._omega_d_rate = 0.0
        self._x_prev_m = min(float(state.position_m[0]), self.ramp_end_x_m)

    def command(self, state: Any) -> list[float]:
        out = [self.omega_ref, wrap_angle(-state.heading)]
        if self._observe_lateral:
            out.append(-float(state.position_m[1]))
        if self._observe_tracking:
            out += [self._speed_error_integral_rad, self._omega_d_rate]
        return out

    def tracking_rmse_rad_s(self) -> float:
        """RMS of ω_d − ω_ref over the judged on-ramp samples so far [rad/s]; NaN before the first."""
        return math.sqrt(self._sq_err_sum / self._n_judged) if self._n_judged else math.nan

    def step(self, state: Any, action: tuple[float, float], rng: np.random.Generator):
        reached, off = ramp_status(state.position_m, self.ramp_end_x_m, self.lane_half_width_m)
        # Judge the sample against the command that was in force during the step, then switch.
        self._since_change_s += self.control_period_s
        if not reached and self._since_change_s > self.settle_time_s + 1e-9:
            e = state.omega_d - self.omega_ref
            self._sq_err_sum += e * e
            self._n_judged += 1
        scale = self.control_period_s  # per-step terms per second, or per ramp length
        if self.step_reward_per == "distance":
            x = min(float(state.position_m[0]), self.ramp_end_x_m)  # progress on the ramp only
            scale = (x - self._x_prev_m) / self.ramp_end_x_m
            self._x_prev_m = x
        terms = ramp_descent_terms(
            self.reward_weights,
            scale,
            state.omega_d,
            self.omega_ref,
            float(state.position_m[1]),
            state.heading,
            action,
            False,
            off,
        )
        if self.tracking_tolerance_rad_s is None:
            success = reached
        else:
            success = (
                reached
                and not off
                and self._n_judged > 0
                and (self.tracking_rmse_rad_s() <= self.tracking_tolerance_rad_s)
            )
        if success:
            terms["success"] = self.reward_weights.success
        if not self._changed and float(state.position_m[0]) >= self._change_x_m:
            self._changed = True
            self.omega_ref = self.omega_ref_after
            self._since_change_s = 0.0
        self._reached = reached
        if self._observe_tracking:
            # the speed loop's state as a PI-D controller keeps it, against the command now in force
            omega_d = float(state.omega_d)
            self._omega_d_rate = (omega_d - self._omega_d_prev) / self.control_period_s
            self._omega_d_prev = omega_d
            lim = SPEED_ERROR_INTEGRAL_LIMIT_RAD
            integral = self._speed_error_integral_rad + (self.omega_ref - omega_d) * self.control_period_s
            self._speed_error_integral_rad = -lim if integral < -lim else (lim if integral > lim else integral)
        return terms, reached or off, success

    def info(self) -> dict[str, Any]:
        return {
            "omega_ref": self.omega_ref,
            "omega_ref_start": self.omega_ref_start,
            "omega_ref_after": self.omega_ref_after,
            "reached_runout": self._reached,
            # 0.0 until the first judged sample (info values stay comparable: no NaN)
            "tracking_rmse_rad_s": self.tracking_rmse_rad_s() if self._n_judged else 0.0,
            "tracking_samples": self._n_judged,
        }
