"""Tasks: what an episode asks (command, observation layout, reward terms, termination), and
the plain functions/data they use (observation assembly, rewards, termination, randomization).

Nothing here imports Drake; inputs are :class:`~sphere_env.physics.TwinState` snapshots (or
anything with the same attributes) and plain numbers.
"""

from sphere_env.tasks.observation import (
    DEFAULT_NOISE_STD,
    MEASURED_COMPONENTS,
    MEASURED_INDEX,
    ObservationLayout,
    assemble_observation,
    wrap_angle,
)
from sphere_env.tasks.ramp_descent import RampDescentTask
from sphere_env.tasks.randomization import Distribution, PressureSchedule, RandomizationSpec, Term
from sphere_env.tasks.rewards import RampRewardWeights, RollRewardWeights, ramp_descent_terms, roll_terms
from sphere_env.tasks.roll import RollTask
from sphere_env.tasks.task import Scene, Task
from sphere_env.tasks.termination import physics_failure, ramp_status

__all__ = [
    "Task",
    "Scene",
    "RampDescentTask",
    "RollTask",
    "ObservationLayout",
    "DEFAULT_NOISE_STD",
    "MEASURED_COMPONENTS",
    "MEASURED_INDEX",
    "assemble_observation",
    "wrap_angle",
    "Distribution",
    "PressureSchedule",
    "RandomizationSpec",
    "Term",
    "RampRewardWeights",
    "RollRewardWeights",
    "ramp_descent_terms",
    "roll_terms",
    "physics_failure",
    "ramp_status",
]
