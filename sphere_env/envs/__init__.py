"""Gymnasium environments: ``sphere_env/RampDescent-v0`` and ``sphere_env/Roll-v0``."""

from sphere_env.envs.base import SphereEnvBase
from sphere_env.envs.ramp_descent import RampDescentEnv
from sphere_env.envs.roll import RollEnv

__all__ = ["SphereEnvBase", "RampDescentEnv", "RollEnv"]
