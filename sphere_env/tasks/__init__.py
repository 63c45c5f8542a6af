"""Tasks: what an episode asks, and the randomization that varies it.

:class:`Task` objects (:class:`RampDescentTask`, :class:`RollTask`) hold an episode's command, the
observation layout, the validated reward weights and the termination; they keep state across the
steps of an episode (the command, the progress) and change their weights on request. The
randomization is a frozen :class:`RandomizationSpec` of :class:`Term` s and the stateful
:class:`~sphere_env.tasks.events.EventManager` that draws its values at reset and applies its
interval and schedule events during the episode. Reward terms, termination checks and observation
assembly are pure functions the tasks call.

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
from sphere_env.tasks.randomization import RandomizationSpec
from sphere_env.tasks.rewards import RampRewardWeights, RollRewardWeights, ramp_descent_terms, roll_terms
from sphere_env.tasks.roll import RollTask
from sphere_env.tasks.task import Scene, Task
from sphere_env.tasks.termination import physics_failure, ramp_status
from sphere_env.tasks.terms import Distribution, PressureSchedule, Term

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
