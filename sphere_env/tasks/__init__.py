"""Tasks: observation, reward terms, termination and randomization as plain functions/data.

Nothing here touches a Drake Context; inputs are :class:`~sphere_env.physics.twin.TwinState`
snapshots (or anything with the same attributes) and plain numbers.
"""

from sphere_env.tasks.observation import DEFAULT_NOISE_STD, MEASURED_COMPONENTS, assemble_observation, wrap_angle
from sphere_env.tasks.randomization import Distribution, PressureSchedule, RandomizationSpec, Term
from sphere_env.tasks.rewards import RampRewardWeights, RollRewardWeights, ramp_descent_terms, roll_terms
from sphere_env.tasks.termination import physics_failure, ramp_status

__all__ = [
    "DEFAULT_NOISE_STD", "MEASURED_COMPONENTS", "assemble_observation", "wrap_angle",
    "Distribution", "PressureSchedule", "RandomizationSpec", "Term",
    "RampRewardWeights", "RollRewardWeights", "ramp_descent_terms", "roll_terms",
    "physics_failure", "ramp_status",
]
