"""Seeing the twin: Meshcat (live view and HTML replays) and headless RGB frames from VTK.

The twin exposes these through its own methods (``render_rgb``, ``publish``,
``start_recording``, ``save_recording``); nothing outside :mod:`sphere_env.physics` needs pydrake.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from pydrake.geometry import (
    ClippingRange,
    ColorRenderCamera,
    LightParameter,
    MakeRenderEngineVtk,
    Meshcat,
    RenderCameraCore,
    RenderEngineVtkParams,
    StartMeshcat,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.sensors import CameraInfo

_log = logging.getLogger("sphere_env")

RENDERER_NAME = "sphere_env_vtk"
#: Camera offset from the sphere centre [m] (behind-left, above), looking at the centre.
CAMERA_OFFSET_M = (-1.5, -1.5, 0.9)


def start_meshcat() -> Meshcat:
    """Start a Meshcat server (live 3-D view in a browser; its URL is logged)."""
    meshcat = StartMeshcat()
    _log.info("sphere_env: Meshcat at %s", meshcat.web_url())
    return meshcat


class RgbCamera:
    """A VTK (EGL, headless) render engine in one twin's SceneGraph context and a colour camera
    that follows a point from :data:`CAMERA_OFFSET_M`."""

    def __init__(self, scene_graph, sg_context, width: int, height: int):
        params = RenderEngineVtkParams()
        params.backend = "EGL"  # headless; GLX needs an X display
        params.lights = [  # sun from above plus a camera headlight (defaults leave the ground dark)
            LightParameter(type="directional", direction=[0.3, 0.2, -1.0], frame="world", intensity=0.9),
            LightParameter(type="directional", direction=[0.0, 0.0, 1.0], frame="camera", intensity=0.4),
        ]
        scene_graph.AddRenderer(sg_context, RENDERER_NAME, MakeRenderEngineVtk(params))
        self._scene_graph, self._sg_context = scene_graph, sg_context
        self.size = (0, 0)
        self._set_size(width, height)

    def _set_size(self, width: int, height: int) -> None:
        if (width, height) != self.size:
            core = RenderCameraCore(
                RENDERER_NAME, CameraInfo(width, height, math.pi / 3), ClippingRange(0.05, 60.0), RigidTransform()
            )
            self.camera = ColorRenderCamera(core, False)
            self.size = (width, height)

    def render(self, target_W: np.ndarray, width: int, height: int) -> np.ndarray:
        """An (height, width, 3) uint8 frame looking at ``target_W`` [m]."""
        self._set_size(width, height)
        c = np.asarray(target_W, dtype=float)
        eye = c + np.array(CAMERA_OFFSET_M)
        z = c - eye
        z /= np.linalg.norm(z)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        X_WC = RigidTransform(RotationMatrix(np.column_stack([x, np.cross(z, x), z])), eye)
        sg = self._scene_graph
        query = sg.get_query_output_port().Eval(self._sg_context)
        image = query.RenderColorImage(self.camera, sg.world_frame_id(), X_WC)
        return np.array(image.data[:, :, :3], dtype=np.uint8)
