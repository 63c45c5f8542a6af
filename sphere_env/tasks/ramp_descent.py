"""``RampDescent``: the paper's ramp experiment (§IV) as a control task."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from sphere_env.checks import ordered_pair, positive
from sphere_env.tasks.observation import wrap_angle
from sphere_env.tasks.rewards import RampRewardWeights, make_weights, ramp_descent_terms
from sphere_env.tasks.task import Scene, Task, finite_option
from sphere_env.tasks.termination import ramp_status


class RampDescentTask(Task):
    """Descend a ramp along the fall line while tracking a commanded drive speed ω_ref.

    The robot starts at rest at the top of a ramp (16° by default, as in the paper) heading
    downhill (+x_W, ψ = 0); the ramp ends in a flat run-out. Both pendulum motors are driven.
    Gravity alone accelerates the robot, and the pendulum cannot hold it on this slope: the
    downhill gravity moment about the contact, m g R sin α ≈ 34 N m, exceeds the pendulum's
    ≈21.9 N m. The policy shapes the descent instead. Measured on the twin at nominal pressure
    (4 m ramp, default calibration), the mean ω_d over the descent is ≈3.9–4.9 rad/s when braking
    hard with the pendulum, ≈5.3–6.2 with zero torque and ≈7.3–8.2 when pushing, depending on the
    shell model; ω_ref is drawn per episode from ``omega_ref_range_rad_s`` = (4, 8) rad/s, the
    span a controller can make the robot hold on average.

    **Action space** ``Box(-1, 1, (2,), float32)``, clipped; NaN/inf raise ``ValueError``.

    ===  ======  =========================================================================
    idx  name    meaning
    ===  ======  =========================================================================
    0    steer   steer motor torque / ``steer_torque_limit_nm`` (default 20 N m); +1 leans the
                 pendulum toward +θ, which turns the robot left (ψ increases)
    1    drive   drive motor torque / ``drive_torque_limit_nm`` (default 22 N m); **+1 drives
                 forward** (the URDF drive axis is −y, so the joint torque is −a·limit)
    ===  ======  =========================================================================

    **Observation space** ``Box(-inf, inf, (13,), float32)`` (14 with ``observe_pressure``):

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
    11   omega_ref      rad/s   command: target drive velocity
    12   heading_error  rad     command: wrap(0 − ψ), heading error to the fall line (shell_yaw)
    13   pressure_kpa   kPa     privileged, only with ``observe_pressure=True``
    ===  =============  ======  ================================================================

    Measured components 0–10 get Gaussian noise of ``observation_noise_scale`` × the defaults in
    :data:`sphere_env.tasks.observation.DEFAULT_NOISE_STD` (off by default).

    **Reward** = Σ terms, each reported as ``info["reward_<term>"]``
    (:class:`~sphere_env.tasks.rewards.RampRewardWeights`; per-step terms scale with the control
    period): ``speed`` (+ tolerance of ω_d − ω_ref), ``lateral`` (− |y| off the fall line),
    ``heading`` (− (1 − cos ψ)), ``ctrl`` (− Σa²), ``success`` (+ on reaching the run-out),
    ``off_ramp`` (− on leaving the lane).

    **Episode end.** ``terminated`` on reaching the run-out (``is_success=True``) or leaving the
    lane |y| > ``lane_half_width_m``. ``truncated`` by the registration's time limit (400 steps =
    8 s at 50 Hz) or a physics failure (``info["truncation_reason"]``).
    ``info["motor_torque_nm"]`` holds the applied [τ_steer, τ_drive] at the joints [N m].

    **kwargs** of ``gym.make("sphere_env/RampDescent-v1", ...)``: those of
    :class:`~sphere_env.envs.SphereEnv` (``shell_model``, ``friction_model``, ``calibration``,
    ``control_frequency_hz`` [Hz], ``time_step_s`` [s], ``steer_torque_limit_nm``/
    ``drive_torque_limit_nm`` [N m], ``randomization``, ``observe_pressure``,
    ``observation_noise_scale``, ``render_mode``, ``meshcat``, ``record_replay``, ``render_size``
    [px]) with ``incline_deg`` [deg] default 16 (paper) and ``ramp_length_m`` [m] default 4, plus
    this task's:

    :param lane_half_width_m: lateral half-width of the ramp lane [m], default 1.
    :param omega_ref_range_rad_s: (low, high) of the per-episode ω_ref [rad/s].
    :param reward_weights: mapping overriding :class:`RampRewardWeights` fields.

    ``reset(options=...)`` also accepts ``omega_ref`` [rad/s] within [0, 30].

    **Version history**

    * v1: the shipped shell calibration, whose steer-direction law (rest angle, amplitude term) is
      fitted on the real ``steer_free`` trials; the hydroelastic shell carries the same restoring
      couple.
    * v0: superseded; the earlier linear steer law about φ = 0, hydroelastic without the couple
      (default ``calibration`` = ``assets/calibration/v0_linear.yaml``). Same task otherwise.
    """

    name = "RampDescent"
    ramp = True
    reward_terms = ("speed", "lateral", "heading", "ctrl", "success", "off_ramp")
    command_names = ("omega_ref", "heading_error")
    command_options = ("omega_ref",)
    command_option_bounds = {"omega_ref": (0.0, 30.0)}  # the bounds of omega_ref_range_rad_s

    def __init__(
        self,
        lane_half_width_m: float = 1.0,
        omega_ref_range_rad_s: tuple[float, float] = (4.0, 8.0),
        reward_weights: Mapping[str, float] | None = None,
    ):
        self.lane_half_width_m = positive("lane_half_width_m", lane_half_width_m, 9.0)
        self.omega_ref_range_rad_s = ordered_pair("omega_ref_range_rad_s", omega_ref_range_rad_s, 0.0, 30.0)
        self.reward_weights = make_weights(RampRewardWeights, reward_weights)
        self.omega_ref = 0.0
        self.ramp_end_x_m = float("inf")
        self.control_period_s = 0.0

    def reset(self, state: Any, rng: np.random.Generator, options: Mapping[str, Any], scene: Scene) -> None:
        lo, hi = self.omega_ref_range_rad_s
        self.omega_ref = float(rng.uniform(lo, hi))
        if "omega_ref" in options:
            self.omega_ref = finite_option(options, "omega_ref")
        self.ramp_end_x_m = scene.ramp_end_x_m
        self.control_period_s = scene.control_period_s

    def command(self, state: Any) -> list[float]:
        return [self.omega_ref, wrap_angle(-state.heading)]

    def step(self, state: Any, action: tuple[float, float], rng: np.random.Generator):
        reached, off = ramp_status(state.position_m, self.ramp_end_x_m, self.lane_half_width_m)
        terms = ramp_descent_terms(
            self.reward_weights, self.control_period_s, state.omega_d, self.omega_ref,
            float(state.position_m[1]), state.heading, action, reached, off,
        )
        return terms, reached or off, reached

    def info(self) -> dict[str, Any]:
        return {"omega_ref": self.omega_ref}
