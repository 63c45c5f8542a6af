"""The steer-direction restoring law of the shell (paper eqs. 7–9) and its forms.

Every form has a rest angle φ_0 (``rest_angle_rad``); Δ = φ − φ_0 (calibration field ``steer_law.form``)::

    linear      τ_s = −K_inject Δ                                   (paper eq. 9 when φ_0 = 0)
    saturating  τ_s = −K_inject Δ − K_a φ_a tanh(Δ / φ_a)           stiffness K_inject + K_a sech²(Δ/φ_a):
                K_a + K_inject at small swings, K_inject at large ones (bounded: no run-away)
    quadratic   τ_s = −K_inject Δ − K_2 Δ |Δ|                       stiffness K_inject + 2 K_2 |Δ|

The law is written once, here, against a math backend (``m``: numpy by default, Drake symbolic in
:mod:`sphere_env.physics.forces`), as the friction laws are.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sphere_env.models.calibration_schema import STEER_LAW_FORMS
from sphere_env.models.mathbackend import NUMPY

PHI_REACH_RAD = 1.2  # largest |φ| the robot reaches on flat ground (pendulum at its stop)

# The law's numbers in the order the physics layer feeds them (one vector, updated in the context
# when pressure or calibration change): K_inject [N m/rad], C_steer, C_drive [N m s/rad], φ_0 [rad],
# A = K_a φ_a [N m], B = 1/φ_a [1/rad], K_2 [N m/rad²].
LAW_GAIN_NAMES = ("K_inject", "C_steer", "C_drive", "rest_angle", "amp_torque", "amp_inv_scale", "quad_stiffness")


def injected_gains(omega_n: float, zeta: float, M_eq: float, K_eq: float) -> tuple[float, float]:
    """K_inject = ω_n² M_eq − K_eq (eq. 7) [N m/rad], C_inject = 2 M_eq ω_n ζ (eq. 8) [N m s/rad]."""
    return omega_n**2 * M_eq - K_eq, 2.0 * M_eq * omega_n * zeta


def steer_torque(phi, phi_dot, K, C, rest, amp_torque, amp_inv_scale, quad, m=NUMPY):
    """Steer-direction shell couple τ_φ [N m] about the rocking axis (numpy or symbolic via ``m``).

    τ_φ = −K Δ − A tanh(B Δ) − K_2 Δ|Δ| − C φ̇,  Δ = φ − φ_0. With A = K_2 = φ_0 = 0 this is the
    paper's eq. 9 (−K_inject φ − C_inject φ̇). Forms: see :data:`STEER_LAW_FORMS`.
    """
    d = phi - rest
    return -K * d - amp_torque * m.tanh(amp_inv_scale * d) - quad * d * m.abs(d) - C * phi_dot


def injected_torques(
    phi, phi_dot, omega_d, K, C_steer, C_drive, rest=0.0, amp_torque=0.0, amp_inv_scale=1.0, quad=0.0, m=NUMPY
):
    """Injected shell torques (eq. 9 and §IV) [N m]: (τ_φ, τ_d).

    Steer direction: :func:`steer_torque`. Drive direction: τ_d = −C_drive ω_d (the paper drops
    K_inject there and damps the rolling velocity). Arguments in :data:`LAW_GAIN_NAMES` order.
    """
    return steer_torque(phi, phi_dot, K, C_steer, rest, amp_torque, amp_inv_scale, quad, m=m), -C_drive * omega_d


@dataclass(frozen=True)
class SteerLaw:
    """The steer-direction spring's form and its pressure-independent numbers.

    The linear stiffness K_inject(p) and damping C_inject(p) come from ω_n(p), ζ(p) (eqs. 7–8);
    ``rest_angle_rad`` φ_0 [rad] and the amplitude terms are held over the pressure range.
    """

    form: str = "linear"
    rest_angle_rad: float = 0.0
    amplitude_stiffness_nm_per_rad: float = 0.0
    amplitude_scale_rad: float = 1.0
    quadratic_stiffness_nm_per_rad2: float = 0.0

    def gains_tail(self) -> tuple[float, float, float, float]:
        """(φ_0, A, B, K_2) of :data:`LAW_GAIN_NAMES`."""
        if self.form == "saturating":
            a = self.amplitude_scale_rad
            return self.rest_angle_rad, self.amplitude_stiffness_nm_per_rad * a, 1.0 / a, 0.0
        if self.form == "quadratic":
            return self.rest_angle_rad, 0.0, 1.0, self.quadratic_stiffness_nm_per_rad2
        return self.rest_angle_rad, 0.0, 1.0, 0.0

    def stiffness(self, phi, K_inject: float):
        """Tangent stiffness −∂τ_φ/∂φ [N m/rad] of the shell spring at pipe angle ``phi``."""
        d = np.asarray(phi, dtype=float) - self.rest_angle_rad
        _, A, B, Q = self.gains_tail()
        return K_inject + A * B / np.cosh(B * d) ** 2 + 2.0 * Q * np.abs(d)

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"form": self.form, "rest_angle_rad": self.rest_angle_rad}
        for k in STEER_LAW_FORMS[self.form]:
            out[k] = getattr(self, k)
        return out


def gravity_stiffness_free_pendulum(robot) -> float:
    """Gravity's rocking stiffness at φ = 0 with the pendulum hanging free [N m/rad].

    On flat ground the centre stays at height R; a pendulum free on the steer joint (axis through
    the centre) hangs plumb and its weight passes through the contact point, so only the pitch
    center's offset r_pc restores: K_g = m_pc r_pc g, and the moment is K_g sin φ. This is the least
    gravity the robot can have, so it is the safe value for the stand-still check.
    """
    from sphere_env.models.rigid_body import GRAVITY_M_S2

    return robot.m_pc * robot.r_pc * GRAVITY_M_S2
