"""Pure-numpy models: friction laws, shell laws, pressure curves, eq. 4 equivalents.

Nothing in this subpackage imports pydrake, so every law can be tested and plotted on its own.
The physics layer evaluates the very same functions, handing them Drake's symbolic math.
"""

from sphere_env.models.friction import FRICTION_LAWS, FrictionModel, load_friction_presets
from sphere_env.models.rigid_body import RobotParameters
from sphere_env.models.shell import ShellCalibration
from sphere_env.params import SHELL_MODELS

__all__ = [
    "FRICTION_LAWS",
    "FrictionModel",
    "load_friction_presets",
    "RobotParameters",
    "SHELL_MODELS",
    "ShellCalibration",
]
