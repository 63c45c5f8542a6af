"""Drake physics: the only subpackage that imports pydrake.

``Twin`` (:mod:`.twin`) with its config and state types (:mod:`.config`), terrain (:mod:`.terrain`),
diagram building (:mod:`.diagram`), friction/shell force systems (:mod:`.forces`), views
(:mod:`.render`: Meshcat, RGB frames), the state read from the plant (:mod:`.state`), the
explicit-torque margins and initial clearance (:mod:`.admissibility`) and the cache of re-meshed
hydroelastic shells (:mod:`.shell_cache`).
"""

import logging


class _NoDeformableHalfSpaceNote(logging.Filter):
    """Drop Drake's note that half spaces take no part in *deformable* contact (we have none)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "not currently supported for deformable contact" not in record.getMessage()


logging.getLogger("drake").addFilter(_NoDeformableHalfSpaceNote())


from sphere_env.physics.config import FIXTURES, InitialState, TwinConfig, TwinState  # noqa: E402
from sphere_env.physics.render import start_meshcat  # noqa: E402
from sphere_env.physics.twin import Twin  # noqa: E402

__all__ = ["FIXTURES", "InitialState", "Twin", "TwinConfig", "TwinState", "start_meshcat"]
