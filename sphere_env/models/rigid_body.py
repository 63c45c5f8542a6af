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

from sphere_env.params import GRAVITY_M_S2
from sphere_env.resources import asset_path

DEFAULT_URDF = asset_path("robot", "roboball.urdf")


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
        return cls(links=links, radius_m=radius, urdf_path=str(path))

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
        return math.sqrt(self.m_p * GRAVITY_M_S2 * self.r_p / self._ixx_about_centre("pendulum"))

    @property
    def com_below_centre_m(self) -> float:
        """d: distance of the whole robot's COM below the sphere centre at θ = 0 [m]."""
        return -sum(l.mass_kg * l.com_m[2] for l in self.links.values()) / self.m_total

    @property
    def inertia_y_about_com(self) -> float:
        """I_G: whole-robot inertia about the y axis through its COM, joints locked [kg m²]."""
        about_centre = sum(
            l.inertia_kgm2[1] + l.mass_kg * (l.com_m[0] ** 2 + l.com_m[2] ** 2) for l in self.links.values()
        )
        return about_centre - self.m_total * self.com_below_centre_m**2

    def locked_rolling_rhs(self, incline_rad: float):
        """Exact planar dynamics of the joint-locked robot rolling without slip down an incline α.

        Coordinates: rolling angle β (β = 0 with the COM straight below the centre), centre
        travel s = R β. With d the COM offset and J(β) = I_G + m (R² + d² − 2 R d cos(β − α)):
            J β̈ = m g (R sin α − d sin β) − m R d sin(β − α) β̇²
        Returns f(t, [β, β̇]) for scipy's solve_ivp. For d = 0 this is the textbook
        a = R β̈ = g sin α / (1 + I_G/(m R²)).
        """
        m, R, d, I_G, g = self.m_total, self.radius_m, self.com_below_centre_m, self.inertia_y_about_com, GRAVITY_M_S2

        def rhs(_t, y):
            beta, beta_dot = y
            J = I_G + m * (R * R + d * d - 2 * R * d * np.cos(beta - incline_rad))
            acc = (
                m * g * (R * np.sin(incline_rad) - d * np.sin(beta))
                - m * R * d * np.sin(beta - incline_rad) * beta_dot**2
            ) / J
            return [beta_dot, acc]

        return rhs

    def uniform_ball_rolling_acceleration_m_s2(self, incline_rad: float) -> float:
        """a = g sin α / (1 + I_c/(m R²)) for a ball whose COM is at its centre [m/s²]."""
        I_c = self.inertia_y_about_com + self.m_total * self.com_below_centre_m**2
        return GRAVITY_M_S2 * np.sin(incline_rad) / (1.0 + I_c / (self.m_total * self.radius_m**2))
