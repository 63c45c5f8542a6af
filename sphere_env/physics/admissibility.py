"""Numerical admissibility of the twin: what the explicit torques and the initial pose may be.

Joint friction and the injected shell torques are evaluated explicitly, from the state at the
start of each plant step, so steep friction laws, large injected damping or a stiff injected shell
make a step diverge; :class:`ExplicitStability` computes the twin's margins once and says which
of them a time step and friction scales break (:data:`EXPLICIT_DAMPING_LIMIT`,
:data:`INJECTED_OMEGA_DT_LIMIT`). :func:`ground_clearance_m` measures how far an initial sphere
centre sits from the ground (:data:`MAX_INITIAL_PENETRATION_M` inside it at the most).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sphere_env.physics.terrain import Terrain

#: An initial sphere centre may sit at most this far inside the ground [m] (a settled shell
#: deflects by a few cm); deeper, the contact pushes the robot out violently on the first step.
MAX_INITIAL_PENETRATION_M = 0.05
#: Joint friction and the injected shell torques are evaluated explicitly, from the state at the
#: start of each plant step. An explicit damper of slope c [N m s/rad] on a joint of inverse
#: inertia m⁻¹ (diagonal of the free-body M⁻¹) is unstable for c·dt·m⁻¹ ≥ 2 whenever the robot is
#: off the ground; such gains are refused. Ground contact stiffens the joints, so below the limit
#: most runs are fine, but near it long full-torque runs can still diverge (at dt = 5 ms: drive
#: c = 120 N m s/rad under point contact after 52–92 steps; hydroelastic drive c = 150 within 5
#: steps, steer c = 180 within 11); the physics-failure truncation reports those.
EXPLICIT_DAMPING_LIMIT = 2.0
#: The injected shell stiffness is explicit too: refused for ω_n·dt above this (at dt = 5 ms,
#: ω_n = 250 rad/s diverged within 16 steps at full torque, 200 rad/s ran; the measured shell
#: ω_n is ≈3 rad/s).
INJECTED_OMEGA_DT_LIMIT = 1.0


def ground_clearance_m(terrain: Terrain, position_m) -> float:
    """Signed distance of a point from the ground surface [m] (< 0 inside the ground).

    The ground is the plane through the origin with normal ``terrain.n_ramp``, or for a finite ramp
    the union of that half-space and the run-out's (horizontal plane through the ramp's end).
    """
    p = np.asarray(position_m, dtype=float)
    d = float(np.dot(terrain.n_ramp, p))
    end = terrain.ramp_end_W
    if end is not None:
        d = min(d, float(p[2] - end[2]))
    return d


def friction_peak_slope(model) -> float:
    """The largest damping slope −dτ/dv of a friction law over |v| ≤ 50 rad/s [N m s/rad]."""
    v = np.linspace(-50.0, 50.0, 200_001)
    tau = np.asarray(model.torque(v), dtype=float)
    return float(max(np.max(-np.gradient(tau, v)), 0.0))


class ExplicitStability:
    """The explicit-torque margins of one twin: each joint's peak friction slope and free-body
    inverse inertia and, for the injected shell, its largest ω_n and C_inject over the
    calibration's pressure range. Computed once, on first use."""

    def __init__(self, plant: Any, layout: dict, config: Any, calibration: Any, shell: Any):
        ctx = plant.CreateDefaultContext()
        self.config, self.calibration = config, calibration
        self.minv = np.diag(np.linalg.inv(plant.CalcMassMatrix(ctx)))
        self.joints = {
            "steer": (friction_peak_slope(config.steer_friction), layout["steer_v"]),
            "drive": (friction_peak_slope(config.drive_friction), layout["drive_v"]),
        }
        self.omega_n = self.C = self.C_drive = None
        # the calibration's drive law: × the drive friction law, × C_inject on the drive direction
        drive = calibration.drive_law_of(config.shell_model)
        self.drive_friction_scale = drive.friction_scale
        if config.shell_model == "injected":
            lo, hi = calibration.pressure_range_kpa
            ps = np.linspace(lo, hi, 23)
            self.omega_n = float(np.max(calibration.omega_n(ps)))
            self.C = max(shell.injected_gains(float(p))[1] for p in ps)
            self.C_drive = self.C * drive.rolling_damping_factor

    def problem(
        self,
        steer_friction_scale: float = 1.0,
        drive_friction_scale: float = 1.0,
        shell_stiffness_scale: float = 1.0,
        shell_damping_scale: float = 1.0,
    ) -> str | None:
        """Why the explicit torques would diverge at the configuration's time step, or ``None``
        (the shell's spring and dampers × their scales: ω_n grows as √ of the stiffness scale at most)."""
        dt = self.config.time_step_s
        omega_n = None if self.omega_n is None else self.omega_n * math.sqrt(max(shell_stiffness_scale, 1.0))
        if omega_n is not None and omega_n * dt > INJECTED_OMEGA_DT_LIMIT:
            lo, hi = self.calibration.pressure_range_kpa
            return (
                f"calibration: omega_n reaches {omega_n:.4g} rad/s over [{lo:g}, {hi:g}] kPa; the injected "
                f"shell torques are explicit and diverge for omega_n·time_step_s > {INJECTED_OMEGA_DT_LIMIT:g}; "
                f"allowed at time_step_s={dt:g} s: omega_n <= {INJECTED_OMEGA_DT_LIMIT / dt:.4g} rad/s"
            )
        drive_friction_scale = drive_friction_scale * self.drive_friction_scale
        for joint, scale in (("steer", steer_friction_scale), ("drive", drive_friction_scale)):
            slope, idx = self.joints[joint]
            if idx is None:
                continue
            injected = self.C_drive * shell_damping_scale if joint == "drive" and self.C is not None else 0.0
            damping = slope * scale + injected
            ratio = damping * dt * self.minv[idx]
            if ratio > EXPLICIT_DAMPING_LIMIT:
                allowed = EXPLICIT_DAMPING_LIMIT / (dt * self.minv[idx])
                extra = f" + injected C_inject {injected:.4g}" if joint == "drive" and self.C is not None else ""
                if joint == "drive" and self.drive_friction_scale != 1.0:
                    extra = f" (× {self.drive_friction_scale:g} of the calibration's drive_law)" + extra
                return (
                    f"friction_model: {joint} joint damping {damping:.4g} N m s/rad (friction law "
                    f"{getattr(self.config, joint + '_friction').law!r} peak slope {slope:.4g} × "
                    f"{joint}_friction_scale {scale:g}{extra}) diverges at time_step_s={dt:g} s: explicit "
                    f"torques need damping·dt/inertia <= {EXPLICIT_DAMPING_LIMIT:g}; allowed: <= {allowed:.4g} N m s/rad"
                )
        return None
