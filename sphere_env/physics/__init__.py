"""Drake physics: the only subpackage that imports pydrake."""

import logging


class _NoDeformableHalfSpaceNote(logging.Filter):
    """Drop Drake's note that half spaces take no part in *deformable* contact (we have none)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "not currently supported for deformable contact" not in record.getMessage()


logging.getLogger("drake").addFilter(_NoDeformableHalfSpaceNote())


from sphere_env.physics.twin import FIXTURES, InitialState, Twin, TwinConfig, TwinState

__all__ = ["FIXTURES", "InitialState", "Twin", "TwinConfig", "TwinState"]
