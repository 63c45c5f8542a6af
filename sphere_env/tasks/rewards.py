"""Reward terms: pure functions of plain numbers (dm_control ``rewards.tolerance`` style).

Each task's reward is the sum of named terms; the env reports every term in ``info`` as
``reward_<term>``. Weights are per-task schemas (frozen, finite numbers; widths and margins > 0),
overridable through the env kwarg ``reward_weights`` (a mapping term -> weight) loaded into them.
"""

from __future__ import annotations

import math
from typing import Any, TypeVar

from sphere_env.schemas import Finite, Schema, number, validate

W = TypeVar("W", bound=Schema)

#: A tolerance's width or margin: a finite number > 0.
Width = number(gt=0.0)


def gaussian_tolerance(error: float, width: float) -> float:
    """exp(−½ (error/width)²) ∈ (0, 1]: 1 at zero error, ≈0.61 at one ``width``."""
    z = error / width
    return math.exp(-0.5 * z * z)


def linear_tolerance(error: float, margin: float) -> float:
    """max(0, 1 − |error|/margin) ∈ [0, 1]: 1 at zero error, 0 from ``margin`` on."""
    return max(0.0, 1.0 - abs(error) / margin)


def control_cost(action) -> float:
    """Σ a_i² of the normalized action (a ∈ [-1, 1]²) [-]."""
    return float(sum(a * a for a in action))


class RampRewardWeights(Schema):
    """RampDescent weights. Per-step terms are multiplied by the control period in seconds
    (so returns do not depend on the control frequency), or, when the task pays them per distance
    (``step_reward_per="distance"``, RampDescent-v3), by the step's downhill progress as a fraction
    of the ramp, so that their weights are per ramp instead of per second; events are one-off.

    :param speed: × gaussian_tolerance(ω_d − ω_ref, speed_width) per s.
    :param speed_width: width of the speed tolerance [rad/s] (not a term).
    :param lateral: × |lateral offset from the fall line| [m] per s (penalty, subtracted).
    :param heading: × (1 − cos ψ) per s (penalty: pointing off the fall line).
    :param ctrl: × Σ a² per s (penalty, subtracted).
    :param success: bonus on reaching the flat run-out.
    :param off_ramp: penalty (subtracted) on leaving the ramp sideways.
    :param speed_linear: × max(0, 1 − |ω_d − ω_ref| / speed_linear_margin) per s (default 0: off),
        dm_control's linear tolerance. The gaussian ``speed`` term is flat more than a few widths
        from ω_ref (at 4 rad/s off it pays e⁻⁸ of its weight), so a policy that coasts far too
        fast, or far too slow, feels no pull toward the command; this term's slope is the same at
        every error inside the margin. It is a bonus, never a penalty, so that ending an episode
        early (leaving the lane) never pays more than descending with a large error.
    :param speed_linear_margin: error at which ``speed_linear`` reaches 0 [rad/s] (not a term).
    """

    speed: Finite = 1.0
    speed_width: Width = 1.0
    lateral: Finite = 1.0
    heading: Finite = 0.5
    ctrl: Finite = 0.1
    success: Finite = 2.0
    off_ramp: Finite = 2.0
    speed_linear: Finite = 0.0
    speed_linear_margin: Width = 4.0


class RampRewardWeightsPerRamp(RampRewardWeights):
    """RampDescent weights when the per-step terms are paid per ramp length
    (``step_reward_per="distance"``, RampDescent-v3): the per-second weights × 6 s, about the
    duration of a descent of the 6 m ramp, so the terms keep their per-second proportions; the
    one-off events are unchanged."""

    speed: Finite = 6.0
    lateral: Finite = 6.0
    heading: Finite = 3.0
    ctrl: Finite = 0.6


class RollRewardWeights(Schema):
    """Roll weights; per-step terms × control period [s].

    :param speed: × gaussian_tolerance(ω_d − ω_ref, speed_width) per s.
    :param speed_width: [rad/s] (not a term).
    :param heading: × gaussian_tolerance(heading error, heading_width) per s; in yaw-rate mode the
        error is ψ̇ − ψ̇_ref [rad/s] with width ``yaw_rate_width``.
    :param heading_width: [rad] (not a term).
    :param yaw_rate_width: [rad/s] (not a term).
    :param ctrl: × Σ a² per s (penalty, subtracted).
    """

    speed: Finite = 1.0
    speed_width: Width = 0.5
    heading: Finite = 1.0
    heading_width: Width = 0.3
    yaw_rate_width: Width = 0.3
    ctrl: Finite = 0.1


def load_weights(cls: type[W], overrides: Any) -> W:
    """``cls``'s defaults with ``overrides`` (a mapping term -> weight, or None) applied; a
    ``ValueError`` names an unknown term, a weight that is not a finite number, a width or margin
    that is not > 0 (fields relative to the ``reward_weights`` kwarg)."""
    return cls() if overrides is None else validate(cls, overrides)


def ramp_descent_terms(
    w: RampRewardWeights,
    dt_s: float,
    omega_d: float,
    omega_ref: float,
    lateral_m: float,
    heading_rad: float,
    action,
    reached_runout: bool,
    off_ramp: bool,
) -> dict[str, float]:
    """RampDescent reward terms (their sum is the reward).

    :param omega_d: drive velocity ω_d [rad/s]; :param omega_ref: commanded ω_ref [rad/s].
    :param lateral_m: offset from the fall line through the start [m].
    :param heading_rad: ψ [rad], 0 = downhill.
    """
    return {
        "speed": w.speed * dt_s * gaussian_tolerance(omega_d - omega_ref, w.speed_width),
        "speed_linear": w.speed_linear * dt_s * linear_tolerance(omega_d - omega_ref, w.speed_linear_margin),
        "lateral": -w.lateral * dt_s * abs(lateral_m),
        "heading": -w.heading * dt_s * (1.0 - math.cos(heading_rad)),
        "ctrl": -w.ctrl * dt_s * control_cost(action),
        "success": w.success if reached_runout else 0.0,
        "off_ramp": -w.off_ramp if off_ramp else 0.0,
    }


def roll_terms(
    w: RollRewardWeights,
    dt_s: float,
    omega_d: float,
    omega_ref: float,
    heading_error: float,
    action,
    yaw_rate_mode: bool = False,
) -> dict[str, float]:
    """Roll reward terms. ``heading_error`` is wrap(ψ_ref − ψ) [rad], or ψ̇ − ψ̇_ref [rad/s] in
    yaw-rate mode."""
    width = w.yaw_rate_width if yaw_rate_mode else w.heading_width
    return {
        "speed": w.speed * dt_s * gaussian_tolerance(omega_d - omega_ref, w.speed_width),
        "heading": w.heading * dt_s * gaussian_tolerance(heading_error, width),
        "ctrl": -w.ctrl * dt_s * control_cost(action),
    }
