"""Joint friction and the shell couple as Drake systems evaluated in C++.

The laws are the pure functions of :mod:`sphere_env.models` (friction laws, and the shell's
:func:`~sphere_env.models.steer_law.injected_torques`), evaluated with Drake's symbolic math into
``SymbolicVectorSystem`` s. Drake then evaluates the expression trees in C++ at every plant step,
which costs a few µs instead of the 25–70 µs of a Python ``LeafSystem``.

The force system's input is the plant state [q; v] (for the injected couple on a floating base,
the shell kinematics of the two stages before it, and the state entries the friction laws read).
Its numeric parameter: :data:`GAIN_NAMES` — the shell law's numbers
(:data:`~sphere_env.models.steer_law.LAW_GAIN_NAMES`: K_inject, C_steer, C_drive, φ_0, amplitude terms)
then the two friction scale factors, which the twin sets in the context when pressure or
calibration change (``BoundShell.law_gains``).
Output: generalized forces (size nv) for the plant's applied-generalized-force port."""

from __future__ import annotations

import math

import numpy as np
import pydrake.symbolic as sym
from pydrake.symbolic import Expression, Variable, if_then_else

from sphere_env.models.steer_law import LAW_GAIN_NAMES, injected_torques

COS_PHI_FLOOR = 1e-3
#: C_spin [N m s/rad]: the soft shell's couple against spinning about the ground normal (``drive_law``).
GAIN_NAMES = (*LAW_GAIN_NAMES, "C_spin", "steer_friction_scale", "drive_friction_scale")


class SymbolicMath:
    """Math backend for :mod:`sphere_env.models` laws producing Drake expressions."""

    exp = staticmethod(sym.exp)
    abs = staticmethod(sym.abs)
    tanh = staticmethod(sym.tanh)

    @staticmethod
    def sign(v):
        return if_then_else(v > 0, 1.0, if_then_else(v < 0, -1.0, 0.0))


SYMBOLIC = SymbolicMath()


def quaternion_y_axis(qw, qx, qy, qz):
    """Second column of the rotation matrix of unit quaternion (w, x, y, z): the body y axis in W."""
    return (2 * (qx * qy - qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz + qw * qx))


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross3(a, b):
    """a × b for 3-sequences (numeric or symbolic), as a tuple."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def pipe_projections(y_W, w_W, n_W):
    """The driveshaft axis ŷ against the ground normal n: (ŷ·n, ŷ×n, ẏ·n) with ẏ = ω × ŷ, given
    y_W, the base angular velocity w_W and n_W (all world-frame; symbolic or numeric)."""
    return _dot(y_W, n_W), cross3(y_W, n_W), _dot(cross3(w_W, y_W), n_W)


def pipe_angle_from_projections(s, yxn, y_dot_n):
    """φ, φ̇ and the rocking axis from :func:`pipe_projections` (see :func:`pipe_angle_expressions`)."""
    symbolic = any(isinstance(a, (Expression, Variable)) for a in (s, *yxn, y_dot_n))
    sqrt, atan2, fmax = (sym.sqrt, sym.atan2, sym.max) if symbolic else (math.sqrt, math.atan2, max)
    cos_phi = fmax(sqrt(_dot(yxn, yxn)), COS_PHI_FLOOR)
    phi = atan2(s, cos_phi)
    phi_dot = y_dot_n / cos_phi
    axis = [c / cos_phi for c in yxn]
    return phi, phi_dot, axis


def pipe_angle_expressions(y_W, w_W, n_W):
    """φ, φ̇ and the rocking axis, given the driveshaft axis y_W, base angular velocity w_W and the
    ground normal n_W (all world-frame; symbolic or numeric).

    φ = atan2(ŷ·n, |ŷ×n|): the driveshaft's tilt against the ground (= asin(ŷ·n) for a unit ŷ),
    positive about the axis ŷ×n/|ŷ×n|. |ŷ×n| is floored at COS_PHI_FLOOR so the rates stay bounded
    when the driveshaft stands vertical (φ → ±90°, far outside the shell model's validity).
    φ̇ = (ω × ŷ)·n / |ŷ×n|.
    """
    return pipe_angle_from_projections(*pipe_projections(y_W, w_W, n_W))


# Stage 1 of the shell kinematics (in the state x): ŷ·n, ŷ×n, ẏ·n, ŷ, ω_d.
PROJECTION_NAMES = (
    *("s", "yxn_x", "yxn_y", "yxn_z", "y_dot_n", "p_y_x", "p_y_y", "p_y_z", "p_omega_d"),
    *("p_spin", "p_n_x", "p_n_y", "p_n_z"),
)
# Stage 2 (in the stage-1 outputs): what the shell law reads.
KINEMATICS_NAMES = (
    *("phi", "phi_dot", "axis_x", "axis_y", "axis_z", "y_x", "y_y", "y_z", "omega_d"),
    *("spin", "n_x", "n_y", "n_z"),
)


def build_force_expressions(layout, steer_law, drive_law, shell_couple: bool, ground_normal_fn):
    """Expressions of the force system, in three stages.

    Returns ``(x, g, out, kinematics)``: state variables x = [q; v], gain variables g, the output
    generalized forces ``out`` (size nv), and for the injected model on a floating base
    ``kinematics = (p, p_exprs, k, k_exprs)``: stage 1, variables p (:data:`PROJECTION_NAMES`:
    ŷ·n, ŷ×n, ẏ·n, ŷ_PC, ω_d) with their expressions in x; stage 2, variables k
    (:data:`KINEMATICS_NAMES`: φ, φ̇, rocking axis, ŷ_PC, ω_d) with their expressions in p. ``out``
    is written in terms of x, k and g. Drake's expression evaluation shares no subexpressions, so
    each stage is its own system and a later stage reads the earlier one's outputs as variables:
    the quaternion/normal tree is evaluated once per step, |ŷ×n| once per φ, φ̇ and axis component
    (not the quaternion tree inside each), and φ once per output component.

    ``shell_couple``: add the shell couple (the injected law; the hydroelastic model carries its
    steer part on top of hydroelastic contact, with the gains :meth:`BoundShell.law_gains` gives).

    ``layout`` describes index positions in [q; v] (see ``TwinDiagram.layout``); ``*_law`` are
    :class:`~sphere_env.models.friction.FrictionModel`; ``ground_normal_fn(p_W)`` returns the
    world ground normal under a base position (symbolic-friendly).
    """
    nq, nv = layout["nq"], layout["nv"]
    x = np.array([Variable(f"x{i}") for i in range(nq + nv)])
    g = np.array([Variable(n) for n in GAIN_NAMES])
    q, v = x[:nq], x[nq:]
    n_law = len(LAW_GAIN_NAMES)
    law_g, c_spin, (s_steer, s_drive) = g[:n_law], g[n_law], g[n_law + 1 :]
    out = [Expression(0.0) for _ in range(nv)]
    kinematics = None

    if layout["steer_v"] is not None and not layout["steer_locked"]:
        out[layout["steer_v"]] += s_steer * steer_law.torque(v[layout["steer_v"]], m=SYMBOLIC)
    if layout["drive_v"] is not None and not layout["drive_locked"]:
        out[layout["drive_v"]] += s_drive * drive_law.torque(v[layout["drive_v"]], m=SYMBOLIC)

    if shell_couple and layout["base"] == "quaternion":
        qi, wi, pi = layout["base_q"], layout["base_v"], layout["base_q"] + 4
        y_W = quaternion_y_axis(*q[qi : qi + 4])
        w_W = v[wi : wi + 3]
        n_W = ground_normal_fn(q[pi : pi + 3])
        # ω_d: shell angular velocity about the driveshaft, + when rolling toward +x_PC.
        drive_rate = v[layout["drive_v"]] if not layout["drive_locked"] else 0.0
        omega_d = _dot(w_W, y_W) - drive_rate
        s, yxn, y_dot_n = pipe_projections(y_W, w_W, n_W)
        p = np.array([Variable(n) for n in PROJECTION_NAMES])
        # the shell's spin about the ground normal: ω_shell·n̂ with ω_shell = ω_PC − q̇_d ŷ_PC
        spin = _dot(w_W, n_W) - drive_rate * s
        p_exprs = np.array(
            [
                s,
                *yxn,
                y_dot_n,
                *y_W,
                omega_d,
                spin,
                *(c if isinstance(c, Expression) else Expression(float(c)) for c in n_W),
            ],
            dtype=object,
        )
        phi, phi_dot, axis = pipe_angle_from_projections(p[0], p[1:4], p[4])
        k = np.array([Variable(n) for n in KINEMATICS_NAMES])
        k_exprs = np.array([phi, phi_dot, *axis, *(Expression(c) for c in p[5:13])], dtype=object)
        kinematics = (p, p_exprs, k, k_exprs)
        k_phi, k_phi_dot, k_axis, k_y, k_omega_d, k_spin, k_n = k[0], k[1], k[2:5], k[5:8], k[8], k[9], k[10:13]
        # eq. 9 / the calibration's steer law, and §IV's drive damper (no K_inject there)
        tau_phi, tau_d = injected_torques(k_phi, k_phi_dot, k_omega_d, *law_g, m=SYMBOLIC)
        # ... and the couple −C_spin (ω_shell·n̂) n̂ against spinning about the ground normal (drilling)
        tau_spin = -c_spin * k_spin
        torque_W = [tau_phi * a + tau_d * y + tau_spin * n for a, y, n in zip(k_axis, k_y, k_n)]  # on the shell
        for j in range(3):
            out[wi + j] += torque_W[j]
        if not layout["drive_locked"]:
            out[layout["drive_v"]] += -tau_d - tau_spin * _dot(k_n, k_y)  # the drive joint axis is −ŷ
    elif shell_couple and layout["base"] == "planar":
        # Planar steer-plane fixture: coordinates (y_W, z_W, φ) on flat ground.
        phi, phi_dot = q[layout["base_q"] + 2], v[layout["base_v"] + 2]
        out[layout["base_v"] + 2] += injected_torques(phi, phi_dot, 0.0, *law_g, m=SYMBOLIC)[0]
    return x, g, np.array(out, dtype=object), kinematics
