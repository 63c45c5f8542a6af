"""Rigid-body parameters read from the robot URDF, and the eq. 4 equivalents derived from them.

The URDF in ``assets/robot`` is the one source of truth; nothing here retypes a mass or inertia.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

ASSETS = Path(__file__).resolve().parents[2] / "assets"
DEFAULT_URDF = ASSETS / "robot" / "roboball.urdf"
GRAVITY_M_S2 = 9.81  # Drake's default |g|


@dataclass(frozen=True)
class Link:
    """Inertial data of one link: mass [kg], COM in link frame [m], principal inertia at COM [kg m²]."""

    mass_kg: float
    com_m: tuple[float, float, float]
    inertia_kgm2: tuple[float, float, float]


@dataclass(frozen=True)
class RobotParameters:
    """Masses, inertias and shell radius of the robot, parsed from a URDF.

    Symbols follow paper eq. 4 and Table II: subscripts pc (pitch center), p (pendulum),
    s (shell: pipe assembly). All links hang from the sphere centre (every joint origin is there).
    """

    links: dict
    radius_m: float
    steer_limits_rad: tuple[float, float]
    urdf_path: str

    @classmethod
    def from_urdf(cls, path: str | Path | None = None) -> "RobotParameters":
        path = Path(path) if path is not None else DEFAULT_URDF
        root = ET.parse(path).getroot()
        links = {}
        for link in root.findall("link"):
            inertial = link.find("inertial")
            if inertial is None:
                continue
            origin = inertial.find("origin")
            xyz = tuple(float(x) for x in (origin.get("xyz") if origin is not None else "0 0 0").split())
            it = inertial.find("inertia")
            links[link.get("name")] = Link(
                float(inertial.find("mass").get("value")),
                xyz,
                (float(it.get("ixx")), float(it.get("iyy")), float(it.get("izz"))),
            )
        radius = None
        for link in root.findall("link"):
            sphere = link.find("collision/geometry/sphere")
            if sphere is not None:
                radius = float(sphere.get("radius"))
        if radius is None:
            raise ValueError(f"robot URDF {str(path)!r}: no collision sphere (the shell) found")
        steer = root.find("joint[@name='steer']/limit")
        limits = (float(steer.get("lower")), float(steer.get("upper")))
        return cls(links=links, radius_m=radius, steer_limits_rad=limits, urdf_path=str(path))

    # --- paper symbols ---------------------------------------------------------------------------
    @property
    def m_pc(self) -> float:
        return self.links["pitch_center"].mass_kg

    @property
    def m_p(self) -> float:
        return self.links["pendulum"].mass_kg

    @property
    def m_s(self) -> float:
        return self.links["pipe_assembly"].mass_kg

    @property
    def m_total(self) -> float:
        return sum(link.mass_kg for link in self.links.values())

    @property
    def r_pc(self) -> float:
        """Pitch-center COM distance below the sphere centre [m]."""
        return -self.links["pitch_center"].com_m[2]

    @property
    def r_p(self) -> float:
        """Pendulum COM distance below the sphere centre [m]."""
        return -self.links["pendulum"].com_m[2]

    def _ixx_about_centre(self, name: str) -> float:
        """I_xx of a link about the x axis through the sphere centre [kg m²] (parallel axis)."""
        link = self.links[name]
        _, y, z = link.com_m
        return link.inertia_kgm2[0] + link.mass_kg * (y * y + z * z)

    @property
    def weight_n(self) -> float:
        """f_n, the robot's weight [N]."""
        return self.m_total * GRAVITY_M_S2

    @property
    def pendulum_moment_kgm(self) -> float:
        """m_pc r_pc + m_p r_p [kg m], the pendulum's gravity moment arm sum."""
        return self.m_pc * self.r_pc + self.m_p * self.r_p

    @cached_property
    def K_eq(self) -> float:
        """K_eq = (m_pc r_pc + m_p r_p) g [N m/rad] (eq. 4)."""
        return self.pendulum_moment_kgm * GRAVITY_M_S2

    @cached_property
    def I_eq(self) -> float:
        """I_eq = I_s + (I_pc + m_pc r_pc²) + (I_p + m_p r_p²) + m_total R² [kg m²] (eq. 4)."""
        return (
            self._ixx_about_centre("pipe_assembly")
            + self._ixx_about_centre("pitch_center")
            + self._ixx_about_centre("pendulum")
            + self.m_total * self.radius_m**2
        )

    @cached_property
    def M_eq(self) -> float:
        """M_eq = I_eq − 2 (m_pc r_pc + m_p r_p) R [kg m²]: inertia about the contact point (eq. 4)."""
        return self.I_eq - 2.0 * self.pendulum_moment_kgm * self.radius_m

    @property
    def omega_point_rad_s(self) -> float:
        """Locked-steer rocking frequency under point contact, √(K_eq/M_eq) (eq. 5) [rad/s]."""
        return math.sqrt(self.K_eq / self.M_eq)

    @property
    def omega_stand_rad_s(self) -> float:
        """Small-swing pendulum frequency in the stand, √(m_p g r_p / (I_p,xx + m_p r_p²)) [rad/s]."""
        return math.sqrt(
            self.m_p * GRAVITY_M_S2 * self.r_p / self._ixx_about_centre("pendulum")
        )

    def rolling_acceleration_m_s2(self, incline_rad: float, I_c_kgm2: float, d_m: float = 0.0) -> float:
        """Initial acceleration of a rigid ball rolling without slip from rest down an incline.

        ``I_c_kgm2`` is the inertia about the rolling axis through the COM; ``d_m`` is the COM
        offset from the sphere centre toward the contact point (along the incline normal).
        With d = 0 this is a = g sin α / (1 + I_c/(m R²)); in general the torque about the
        contact point is m g (R − d) sin α and the inertia I_c + m (R − d)², so
        a = α̈ R = m g (R − d) R sin α / (I_c + m (R − d)²).
        """
        m, R = self.m_total, self.radius_m
        arm = R - d_m
        return m * GRAVITY_M_S2 * arm * R * np.sin(incline_rad) / (I_c_kgm2 + m * arm * arm)
