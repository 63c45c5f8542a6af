"""Gymnasium environments: one generic :class:`SphereEnv` (twin + task) and the factories of
``sphere_env/RampDescent-v2`` and ``sphere_env/Roll-v1``."""

from sphere_env.envs.env import SphereEnv
from sphere_env.envs.factories import make_ramp_descent, make_roll

__all__ = ["SphereEnv", "make_ramp_descent", "make_roll"]
