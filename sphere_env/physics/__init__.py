"""Drake physics: the only subpackage that imports pydrake."""

from sphere_env.physics.twin import FIXTURES, InitialState, Twin, TwinConfig, TwinState

__all__ = ["FIXTURES", "InitialState", "Twin", "TwinConfig", "TwinState"]
