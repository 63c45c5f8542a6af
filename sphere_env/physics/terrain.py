"""Ground geometry of the twin: an inclined plane, or a finite ramp with a flat run-out.

The visible ground carries a grid of dark lines (:data:`GRID_SPACING_M`), visual only (no collision
role), so that motion shows in camera frames and Meshcat even when the camera follows the robot: a
plain ground looks the same wherever the robot is.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import Box, HalfSpace, ProximityProperties
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.symbolic import Expression, Variable, if_then_else

GROUND_RGBA = np.array([0.55, 0.5, 0.45, 1.0])
RUNOUT_RGBA = np.array([0.45, 0.5, 0.55, 1.0])
#: Grid on the visible ground: line spacing, width and colour (lines sit on the surface).
GRID_SPACING_M = 0.5
GRID_LINE_WIDTH_M = 0.025
GRID_RGBA = np.array([0.22, 0.2, 0.18, 1.0])
_GRID_LINE_HEIGHT_M = 0.004  # a thin box whose lower half is inside the ground slab


def grid_geometries(
    R_WS: RotationMatrix, p_WSo: np.ndarray, x_range_m: tuple[float, float], y_range_m: tuple[float, float], name: str
) -> list[tuple[str, RigidTransform, object, np.ndarray]]:
    """Visual grid lines on a flat surface patch, as (name, X_WG, shape, rgba): frame S (rotation
    ``R_WS``, origin ``p_WSo`` on the surface, z_S its normal), lines along x_S and y_S every
    :data:`GRID_SPACING_M` over ``x_range_m`` × ``y_range_m`` (in S) [m]. Lines at multiples of the
    spacing from S's origin, so the grid is fixed in the world."""
    s, w, h = GRID_SPACING_M, GRID_LINE_WIDTH_M, _GRID_LINE_HEIGHT_M
    (x0, x1), (y0, y1) = x_range_m, y_range_m
    out = []
    for k in range(math.ceil(x0 / s), math.floor(x1 / s) + 1):  # lines across x_S (along y_S)
        p_S = np.array([k * s, (y0 + y1) / 2, 0.0])
        out.append(
            (f"{name}_grid_x{len(out)}", RigidTransform(R_WS, p_WSo + R_WS @ p_S), Box(w, y1 - y0, h), GRID_RGBA)
        )
    for k in range(math.ceil(y0 / s), math.floor(y1 / s) + 1):  # lines along x_S
        p_S = np.array([(x0 + x1) / 2, k * s, 0.0])
        out.append(
            (f"{name}_grid_y{len(out)}", RigidTransform(R_WS, p_WSo + R_WS @ p_S), Box(x1 - x0, w, h), GRID_RGBA)
        )
    return out


class Terrain:
    """Ground geometry: an inclined plane, or a ramp of finite length with a flat run-out."""

    def __init__(self, incline_deg: float, ramp_length_m: float | None):
        self.alpha = math.radians(incline_deg)
        self.ramp_length_m = ramp_length_m
        self.R_WG = RotationMatrix.MakeYRotation(self.alpha)  # x_G down the fall line
        self.n_ramp = self.R_WG.col(2)
        self.t_ramp = self.R_WG.col(0)
        self._n_ramp = tuple(float(c) for c in self.n_ramp)
        # x_W where the flat run-out starts (inf: the incline never ends)
        self._x_runout = math.inf if ramp_length_m is None or self.alpha == 0.0 else float(self.ramp_end_W[0])

    @property
    def ramp_end_W(self) -> np.ndarray | None:
        """Bottom end of the ramp in W [m] (``None`` for an infinite plane)."""
        return None if self.ramp_length_m is None else self.t_ramp * self.ramp_length_m

    @property
    def ramp_end_x_m(self) -> float:
        """x_W of the ramp's bottom end [m]; ``inf`` for an infinite plane."""
        return math.inf if self.ramp_length_m is None else float(self.ramp_end_W[0])

    def normal_at(self, p_W):
        """Ground normal n_W under a point, as a 3-tuple (numeric or symbolic in p_W)."""
        if math.isinf(self._x_runout):
            return self._n_ramp
        if isinstance(p_W[0], (Expression, Variable)):  # symbolic state variables are Variables
            # A component the ramp and the run-out share (n_y = 0) is a constant: no branch to
            # evaluate, and its products drop out of the expressions that use it.
            return tuple(
                nr if nr == nz else if_then_else(p_W[0] < self._x_runout, nr, nz)
                for nr, nz in zip(self._n_ramp, (0.0, 0.0, 1.0))
            )
        return self._n_ramp if p_W[0] < self._x_runout else (0.0, 0.0, 1.0)

    def geometries(self) -> list[tuple[str, RigidTransform, object, np.ndarray | None]]:
        """The ground as (name, X_WG, shape, rgba): collision geometries have ``rgba = None``,
        visual ones a colour."""
        if self.ramp_length_m is None:
            return [
                ("ground", RigidTransform(HalfSpace.MakePose(self.n_ramp, np.zeros(3))), HalfSpace(), None),
                ("ground_vis", RigidTransform(self.R_WG, -0.05 * self.n_ramp), Box(30, 30, 0.1), GROUND_RGBA),
                *grid_geometries(self.R_WG, np.zeros(3), (-15.0, 15.0), (-15.0, 15.0), "ground"),
            ]
        # Ramp + flat run-out = union of two half-spaces: the terrain height is the max of the two
        # planes, so each half-space lies below the other's surface where that one is active.
        # (Half-spaces are much cheaper than boxes for hydroelastic contact.)
        end = self.ramp_end_W
        L, thick, margin = self.ramp_length_m, 0.1, 2.0
        return [
            ("ramp", RigidTransform(HalfSpace.MakePose(self.n_ramp, np.zeros(3))), HalfSpace(), None),
            ("runout", RigidTransform(end), HalfSpace(), None),
            (
                "ramp_vis",
                RigidTransform(self.R_WG, self.t_ramp * (L - margin) / 2 - self.n_ramp * thick / 2),
                Box(L + margin, 6, thick),
                GROUND_RGBA,
            ),
            ("runout_vis", RigidTransform(end + np.array([15.0, 0.0, -thick / 2])), Box(30, 6, thick), RUNOUT_RGBA),
            # Grid lines: the ramp's measured along the slope from its top, the run-out's from its start.
            *grid_geometries(self.R_WG, np.zeros(3), (-margin, L), (-3.0, 3.0), "ramp"),
            *grid_geometries(RotationMatrix(), end, (0.0, 30.0), (-3.0, 3.0), "runout"),
        ]

    def register(self, plant, props: ProximityProperties, body=None) -> dict:
        """Register the ground with the plant on ``body`` (default: the world body, i.e. anchored
        geometry). Returns {name: GeometryId}."""
        body = plant.world_body() if body is None else body
        ids = {}
        for name, X_WG, shape, rgba in self.geometries():
            if rgba is None:
                ids[name] = plant.RegisterCollisionGeometry(body, X_WG, shape, name, props)
            else:
                ids[name] = plant.RegisterVisualGeometry(body, X_WG, shape, name, rgba)
        return ids
